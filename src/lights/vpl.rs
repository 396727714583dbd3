//! Virtual point lights by instant radiosity (Keller 1997), generated on
//! the GPU every frame: the indirect light of a scene as point emitters the
//! light samplers handle like any other ([`LightPrim::vpl`]).
//!
//! # Paths
//!
//! `paths` light paths start from the scene's lights, chosen with
//! probability proportional to their luminance flux ([`source_flux`]):
//!
//! | source | start | direction | flux Φ |
//! |---|---|---|---|
//! | point light (and light-set point) | its position | uniform on the sphere | `4π·I` |
//! | emissive triangle | uniform on it | cosine about its normal | `π·L_e·area` |
//! | directional light | uniform on a disk of the scene's bounding radius R, upstream | the light's | `π·R²·E` |
//!
//! A path carries `Φ / (pmf · paths)` (RGB). At each of its first
//! `bounces` diffuse hits `x` (albedo ρ, shading normal `n` facing the
//! arriving ray: the geometric normal unless the mesh has vertex normals)
//! it deposits one VPL: position `x`, normal `n`, on-axis intensity
//! `ρ·Φ_k/π` (its cosine lobe then emits `ρ·Φ_k` in all, the flux the
//! surface reflects), and goes on in a cosine-distributed direction about
//! `n` with `Φ_{k+1} = ρ·Φ_k` (the Lambertian throughput `f·cos/pdf = ρ`);
//! a direction behind the geometric surface ends the path there.
//! Path `i` writes slots `i·bounces .. (i+1)·bounces`; a path that leaves
//! the scene fills its remaining slots with dark VPLs (zero intensity, at
//! the last ray's origin), so the light ids never depend on the geometry.
//!
//! # Determinism
//!
//! Every random number is a hash of (seed, path, dimension)
//! (`shared/rng.wgsl`) and every write goes to a slot computed from the
//! path index: the VPLs of a seed are the same on every run and device
//! (up to the device's rounding of the traversal).
//!
//! The VPLs are read back to the host and appended to the frame's lights
//! (`integrand::many_light`), so every sampler kind builds over them as
//! over the scene's own lights.

use super::{luminance, LightPrim, KIND_POINT, KIND_TRIANGLE};
use crate::accel::GpuScene;
use crate::gpu::buffer::STORAGE;
use crate::gpu::shader::{storage_entry, uniform_entry, Wgsl};
use crate::gpu::{Gpu, Profiler};
use crate::scene::motion::{normalized_keys, transform_at};
use crate::scene::{Light, Scene};
use crate::wgsl_file;
use anyhow::{bail, Context, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Source kind of a directional light in the path-source list (only
/// there: directional lights are not part of the many-light set).
pub const KIND_DIRECTIONAL_SOURCE: u32 = 3;
/// Invocations per workgroup of the generation kernel.
const WG: u32 = 64;
/// Largest VPL count (slots) of one frame.
pub const MAX_VPLS: u32 = 1 << 22;
/// Largest number of VPLs per path.
pub const MAX_BOUNCES: u32 = 8;

/// The `[integrand]` VPL keys of a `many_light` scene (`vpls`,
/// `vpl_bounces`, `vpl_seed`, `vpl_clamp`; docs/scene-format.md).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VplSpec {
    /// Light paths per frame (0: no VPLs).
    pub paths: u32,
    /// VPLs per path (diffuse hits), 1..=[`MAX_BOUNCES`].
    pub bounces: u32,
    /// Seed of the paths' random numbers.
    pub seed: u32,
    /// Distance clamp of a VPL's `1/d²` (scene units; 0 = none). Biased
    /// by design: it removes the spikes near VPLs and the light they bring.
    pub clamp: f32,
}

impl Default for VplSpec {
    fn default() -> Self {
        VplSpec {
            paths: 0,
            bounces: 1,
            seed: 0,
            clamp: 0.0,
        }
    }
}

impl VplSpec {
    /// VPL slots: `paths · bounces`.
    pub fn count(&self) -> u32 {
        self.paths * self.bounces
    }
}

/// Uniform of `wgsl/lights/vpl.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct VplParams {
    pub paths: u32,
    pub bounces: u32,
    pub seed: u32,
    pub source_count: u32,
    /// Centre and radius of the scene's bounding sphere (directional
    /// sources start on a disk of this radius).
    pub center: [f32; 3],
    pub radius: f32,
    pub time: f32,
    pub _pad: [u32; 3],
}

/// The luminance flux of a path source (module docs table).
pub fn source_flux(l: &LightPrim, radius: f32) -> f64 {
    let e = luminance(Vec3::from(l.emission)) as f64;
    let pi = std::f64::consts::PI;
    match l.kind {
        KIND_TRIANGLE => pi * e * l.area() as f64,
        KIND_DIRECTIONAL_SOURCE => pi * (radius as f64).powi(2) * e,
        _ => 4.0 * pi * e,
    }
}

/// The bounding sphere (centre, radius) of the scene's geometry at `time`;
/// radius 0 for an empty scene.
pub fn scene_sphere(scene: &Scene, time: f32) -> (Vec3, f32) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for mesh in &scene.meshes {
        let rigid =
            (!mesh.motion.is_empty()).then(|| transform_at(&normalized_keys(&mesh.motion), time));
        for &p in &mesh.positions {
            let p = rigid.map_or(p, |r| r.apply_point(p));
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    if lo.x > hi.x || !lo.is_finite() || !hi.is_finite() {
        return (Vec3::ZERO, 0.0);
    }
    ((lo + hi) * 0.5, (hi - lo).length() * 0.5)
}

/// The path sources: the frame's many-light list `lights` (points,
/// light-set points, emissive triangles; not VPLs) followed by the scene's
/// directional lights (`p0` = direction of travel, `emission` = E).
pub fn sources(scene: &Scene, lights: &[LightPrim]) -> Vec<LightPrim> {
    let mut out: Vec<LightPrim> = lights
        .iter()
        .filter(|l| l.kind == KIND_POINT || l.kind == KIND_TRIANGLE)
        .copied()
        .collect();
    for l in &scene.lights {
        if let Light::Directional {
            direction,
            irradiance,
        } = *l
        {
            out.push(LightPrim {
                kind: KIND_DIRECTIONAL_SOURCE,
                ..LightPrim::point(direction.normalize(), irradiance)
            });
        }
    }
    out
}

/// The VPL generation kernel, compiled once per scene upload.
pub struct VplGenerator {
    layout: wgpu::BindGroupLayout,
    scene_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl VplGenerator {
    /// The kernel's WGSL: the scene and shading code, the light structs,
    /// then `lights/vpl.wgsl`.
    pub fn source() -> Wgsl {
        crate::kernel_base::scene_wgsl()
            .include(&super::tree::gpu_build::prim_wgsl())
            .constant("VPL_WG", WG)
            .constant("KIND_DIRECTIONAL_SOURCE", KIND_DIRECTIONAL_SOURCE)
            .part(wgsl_file!("shared/rng.wgsl"))
            .part(wgsl_file!("lights/vpl.wgsl"))
    }

    /// Group 0 of the kernel: parameters, sources, their CDF, the VPLs.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        vec![
            uniform_entry(0),
            storage_entry(1, true),
            storage_entry(2, true),
            storage_entry(3, false),
        ]
    }

    pub fn new(gpu: &Gpu) -> Result<VplGenerator> {
        let layout = gpu.bind_group_layout("vpl.group0", &Self::layout_entries());
        let scene_layout = gpu.bind_group_layout("vpl.group1", &GpuScene::layout_entries());
        let pipeline = gpu.compute_pipeline(
            "lights.vpl",
            &Self::source(),
            "generate_vpls",
            &[&layout, &scene_layout],
        )?;
        Ok(VplGenerator {
            layout,
            scene_layout,
            pipeline,
        })
    }

    /// Traces `spec.paths` light paths from `sources` (see [`sources`])
    /// through `gpu_scene` at `time` and returns the `spec.count()` VPLs in
    /// slot order (timed as the profiler phase `many_light.vpl`).
    /// `radius`/`center`: the scene's bounding sphere ([`scene_sphere`]).
    #[allow(clippy::too_many_arguments)]
    pub fn generate(
        &self,
        gpu: &Gpu,
        gpu_scene: &GpuScene,
        sources: &[LightPrim],
        (center, radius): (Vec3, f32),
        spec: &VplSpec,
        time: f32,
        profiler: &mut Profiler,
    ) -> Result<Vec<LightPrim>> {
        let count = spec.count();
        if !(1..=MAX_BOUNCES).contains(&spec.bounces) {
            bail!(
                "vpl_bounces must be in 1..={MAX_BOUNCES}, got {}",
                spec.bounces
            );
        }
        if spec.paths as u64 * spec.bounces as u64 > MAX_VPLS as u64 {
            bail!(
                "{} VPLs ({} paths × {} bounces) exceed the limit of {MAX_VPLS}",
                spec.paths as u64 * spec.bounces as u64,
                spec.paths,
                spec.bounces
            );
        }
        if count == 0 {
            return Ok(Vec::new());
        }
        // The sources' CDF over luminance flux (f64, stored as f32 with the
        // last entry exactly 1); no flux at all: every VPL dark.
        let flux: Vec<f64> = sources.iter().map(|l| source_flux(l, radius)).collect();
        let total: f64 = flux.iter().sum();
        let live = total > 0.0 && total.is_finite();
        let mut cdf = Vec::with_capacity(sources.len());
        let mut acc = 0.0;
        for f in &flux {
            acc += f;
            cdf.push(if live { (acc / total) as f32 } else { 0.0 });
        }
        if let (true, Some(last)) = (live, cdf.last_mut()) {
            *last = 1.0;
        }
        let params = VplParams {
            paths: spec.paths,
            bounces: spec.bounces,
            seed: spec.seed,
            source_count: if live { sources.len() as u32 } else { 0 },
            center: center.into(),
            radius,
            time,
            _pad: [0; 3],
        };
        let bytes = count as u64 * size_of::<LightPrim>() as u64;
        // Name the keys that set the size (issue 54 item 8).
        gpu.check_binding_size("lights.vpl.out", bytes)
            .with_context(|| {
                format!(
                "[integrand] vpls = {} with vpl_bounces = {}: {count} virtual point lights do not \
                 fit this adapter; lower vpls or vpl_bounces",
                spec.paths, spec.bounces
            )
            })?;
        let uniform = gpu.uniform("lights.vpl.params", &params);
        let src = gpu.buffer_from("lights.vpl.sources", sources, STORAGE)?;
        let cdf = gpu.buffer_from("lights.vpl.cdf", &cdf, STORAGE)?;
        let out = gpu.buffer_zeroed("lights.vpl.out", bytes, STORAGE)?;
        let group0 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vpl.group0"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: src.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: cdf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: out.as_entire_binding(),
                },
            ],
        });
        let group1 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vpl.group1"),
            layout: &self.scene_layout,
            entries: &gpu_scene.bind_group_entries(),
        });
        let (gx, gy) = gpu.dispatch_dims(spec.paths.div_ceil(WG));
        gpu.scoped("generating VPLs", || {
            profiler.phase("many_light.vpl", |encoder, timestamps| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("many_light.vpl"),
                    timestamp_writes: timestamps,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &group0, &[]);
                pass.set_bind_group(1, &group1, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            })
        })?;
        gpu.read_buffer::<LightPrim>(&out, count as usize)
    }
}
