//! WGSL assembly and pipeline creation.
//!
//! A kernel's source is the concatenation of WGSL files from `wgsl/`
//! (shared snippets first, the kernel last), preceded by constants
//! generated from Rust ([`Wgsl::constant`]) so that no number is kept in
//! two places. No text substitution happens inside shader files. Each part
//! is preceded by a `// ---- file ----` marker so that the line numbers in a
//! compile error can be traced back to a file.
//!
//! Building a pipeline is the costliest call a render makes on a CPU
//! adapter (lavapipe lowers each module through NIR on every creation,
//! before its own shader cache is consulted), and renders rebuild the same
//! kernels: every `Mdas` or `Halton` instance, every `tune` configuration,
//! every frame's integrand. [`Gpu`] therefore keeps what it built: a bind
//! group layout per list of entries and a pipeline per (source, entry,
//! layouts). A constant that no part of a module names is left out of its
//! source, so two kernels built from different constants share a pipeline
//! wherever they read the same ones (the reconstruction alone reads κ).

use super::Gpu;
use anyhow::Result;
use sha2::{Digest, Sha256};
use std::borrow::Cow;
use std::collections::{HashMap, HashSet};

/// Embeds `wgsl/<path>` at compile time as a named shader part.
#[macro_export]
macro_rules! wgsl_file {
    ($path:literal) => {
        (
            $path,
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/wgsl/", $path)),
        )
    };
}

/// An assembled WGSL module.
#[derive(Clone, Debug, Default)]
pub struct Wgsl {
    constants: Vec<String>,
    parts: Vec<(Cow<'static, str>, Cow<'static, str>)>,
}

impl Wgsl {
    pub fn new() -> Self {
        Self::default()
    }

    /// Declares `const NAME: u32 = value;` ahead of all parts.
    pub fn constant(mut self, name: &str, value: u32) -> Self {
        self.constants
            .push(format!("const {name}: u32 = {value}u;"));
        self
    }

    /// Declares `const NAME: f32 = value;` ahead of all parts (printed
    /// with the shortest digits that read back as the same f32).
    pub fn constant_f32(mut self, name: &str, value: f32) -> Self {
        self.constants
            .push(format!("const {name}: f32 = {value:?};"));
        self
    }

    /// Appends one file, as given by [`wgsl_file!`], or any (name, text)
    /// pair: borrowed `&'static str` or owned `String` (shader text read at
    /// run time needs no leaking).
    pub fn part<N, T>(mut self, (name, text): (N, T)) -> Self
    where
        N: Into<Cow<'static, str>>,
        T: Into<Cow<'static, str>>,
    {
        self.parts.push((name.into(), text.into()));
        self
    }

    /// Appends every part of `other` not already present (constants too).
    pub fn include(mut self, other: &Wgsl) -> Self {
        for c in &other.constants {
            if !self.constants.contains(c) {
                self.constants.push(c.clone());
            }
        }
        for (name, text) in &other.parts {
            if !self.parts.iter().any(|(n, _)| n == name) {
                self.parts.push((name.clone(), text.clone()));
            }
        }
        self
    }

    /// The module's text: the constants that some part names outside a
    /// `//` comment, then the parts in order.
    pub fn source(&self) -> String {
        let named: HashSet<&str> = self
            .parts
            .iter()
            .flat_map(|(_, text)| text.lines())
            .map(|line| line.split("//").next().unwrap_or(""))
            .flat_map(|code| code.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_')))
            .collect();
        let mut out = String::from("// ---- generated constants ----\n");
        for c in &self.constants {
            if named.contains(constant_name(c)) {
                out += c;
                out += "\n";
            }
        }
        for (name, text) in &self.parts {
            out += &format!("// ---- {name} ----\n");
            out += text;
            out += "\n";
        }
        out
    }
}

/// `NAME` of a generated `const NAME: type = value;`.
fn constant_name(declaration: &str) -> &str {
    let rest = declaration.strip_prefix("const ").unwrap_or(declaration);
    rest.split(':').next().unwrap_or(rest).trim()
}

/// What a [`Gpu`] has built, by what defines it. Kept for the process's
/// life: a render builds a few dozen kernels and a test process a few
/// hundred, each a few kilobytes of driver state.
#[derive(Default)]
pub(crate) struct KernelCache {
    layouts: HashMap<Vec<wgpu::BindGroupLayoutEntry>, wgpu::BindGroupLayout>,
    pipelines: HashMap<PipelineKey, wgpu::ComputePipeline>,
}

/// A pipeline's definition: the SHA-256 of its module's source, its entry
/// point and its layouts (handles; [`Gpu::bind_group_layout`] gives equal
/// entries one handle).
#[derive(PartialEq, Eq, Hash)]
struct PipelineKey {
    source: [u8; 32],
    entry: String,
    layouts: Vec<wgpu::BindGroupLayout>,
}

impl Gpu {
    /// The bind group layout with these entries, created on first request
    /// (the label of the first request names it).
    pub fn bind_group_layout(
        &self,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> wgpu::BindGroupLayout {
        let entries: Vec<wgpu::BindGroupLayoutEntry> = entries
            .iter()
            .map(|&e| match e.ty {
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset,
                    min_binding_size,
                } if self.uniforms_as_storage => wgpu::BindGroupLayoutEntry {
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset,
                        min_binding_size,
                    },
                    ..e
                },
                _ => e,
            })
            .collect();
        let mut cache = self.kernels.lock().unwrap();
        cache
            .layouts
            .entry(entries.clone())
            .or_insert_with(|| {
                self.device
                    .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                        label: Some(label),
                        entries: &entries,
                    })
            })
            .clone()
    }

    /// The compute pipeline for `entry` of `source` with the given bind
    /// group layouts (group 0, 1, ...), built on first request and shared
    /// after (the label of the first request names it). WGSL or layout
    /// errors are returned, not panicked on, and not kept.
    pub fn compute_pipeline(
        &self,
        label: &str,
        source: &Wgsl,
        entry: &str,
        layouts: &[&wgpu::BindGroupLayout],
    ) -> Result<wgpu::ComputePipeline> {
        let mut text = source.source();
        if self.uniforms_as_storage {
            // Same layout: WGSL's uniform rules only restrict it.
            text = text.replace("var<uniform>", "var<storage, read>");
        }
        let key = PipelineKey {
            source: Sha256::digest(text.as_bytes()).into(),
            entry: entry.to_string(),
            layouts: layouts.iter().map(|&l| l.clone()).collect(),
        };
        if let Some(p) = self.kernels.lock().unwrap().pipelines.get(&key) {
            return Ok(p.clone());
        }
        // Built outside the lock, so that threads build different kernels
        // at once; two threads building the same one keep the first.
        let pipeline = self.build_pipeline(label, text, entry, layouts)?;
        let mut cache = self.kernels.lock().unwrap();
        Ok(cache.pipelines.entry(key).or_insert(pipeline).clone())
    }

    fn build_pipeline(
        &self,
        label: &str,
        source: String,
        entry: &str,
        layouts: &[&wgpu::BindGroupLayout],
    ) -> Result<wgpu::ComputePipeline> {
        self.scoped(&format!("building pipeline '{label}'"), || {
            let module = self
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(label),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
            let layout = self
                .device
                .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(label),
                    bind_group_layouts: &layouts.iter().map(|l| Some(*l)).collect::<Vec<_>>(),
                    immediate_size: 0,
                });
            Ok(self
                .device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(label),
                    layout: Some(&layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                }))
        })
    }
}

/// Bind-group-layout entry for a compute storage buffer.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Bind-group-layout entry for a compute uniform buffer.
pub fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A bind group over whole buffers, bound at 0, 1, 2, ... in order.
pub fn bind_buffers(
    gpu: &Gpu,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<_> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}
