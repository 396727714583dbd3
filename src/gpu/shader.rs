//! WGSL assembly and pipeline creation.
//!
//! A kernel's source is the concatenation of WGSL files from `wgsl/`
//! (shared snippets first, the kernel last), preceded by constants
//! generated from Rust ([`Wgsl::constant`]) so that no number is kept in
//! two places. No text substitution happens inside shader files. Each part
//! is preceded by a `// ---- file ----` marker so that the line numbers in a
//! compile error can be traced back to a file.

use super::Gpu;
use anyhow::Result;
use std::borrow::Cow;

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

    pub fn source(&self) -> String {
        let mut out = String::from("// ---- generated constants ----\n");
        for c in &self.constants {
            out += c;
            out += "\n";
        }
        for (name, text) in &self.parts {
            out += &format!("// ---- {name} ----\n");
            out += text;
            out += "\n";
        }
        out
    }
}

impl Gpu {
    /// Compiles `source` and builds a compute pipeline for `entry` with the
    /// given bind group layouts (group 0, 1, ...). WGSL or layout errors are
    /// returned, not panicked on.
    pub fn compute_pipeline(
        &self,
        label: &str,
        source: &Wgsl,
        entry: &str,
        layouts: &[&wgpu::BindGroupLayout],
    ) -> Result<wgpu::ComputePipeline> {
        self.scoped(&format!("building pipeline '{label}'"), || {
            let module = self
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(label),
                    source: wgpu::ShaderSource::Wgsl(source.source().into()),
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
