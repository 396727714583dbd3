//! Upload of a scene to the device: the `@group(1)` scene bindings.
//!
//! [`GpuScene`] owns the buffers and bind group that `wgsl/shared/scene.wgsl`
//! declares (uniforms, CWBVH nodes, triangles, instances, keyframes,
//! materials, emitters, lights) and the bind-group layout every kernel that
//! uses the scene puts at group 1. Besides the BVH ([`BuiltScene`]) it
//! derives the camera frame of docs/conventions.md "Primary ray" for the
//! render film and the emissive-triangle selection table ([`emitter_table`]).

use anyhow::Result;
use glam::Vec3;

use super::build::BuiltScene;
use super::gpu_voxel::GpuVoxels;
use super::layout::{
    GpuEmitter, GpuLight, GpuMaterial, SceneUniforms, LIGHT_DIRECTIONAL, LIGHT_POINT,
    VISIBILITY_VOXEL,
};
use super::voxel::{Visibility, VoxelLayout};
use crate::film::Film;
use crate::gpu::buffer::STORAGE;
use crate::gpu::shader::{bind_buffers, storage_entry, uniform_entry};
use crate::gpu::Gpu;
use crate::scene::{Light, Scene};

/// What was built and uploaded, for logs and reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneStats {
    pub triangles: u32,
    pub instances: u32,
    /// CWBVH nodes, TLAS and BLASes together (80 bytes each).
    pub nodes: u32,
    pub emitters: u32,
    /// Traversal stack entries the deepest TLAS+BLAS path needs (of
    /// [`super::BVH_STACK_SIZE`]).
    pub stack_depth: u32,
    /// Wall time of the obvhs builds, milliseconds.
    pub build_ms: f64,
    /// Bytes of all scene buffers on the device (voxel array included).
    pub gpu_bytes: u64,
    /// Bytes of the voxel visibility array (0 with BVH visibility).
    pub voxel_bytes: u64,
    /// Wall time of the voxel array's build on the device, ms.
    pub voxel_build_ms: f64,
}

/// A scene on the device, bound at `@group(1)` (see `shared/scene.wgsl`).
pub struct GpuScene {
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    pub stats: SceneStats,
    /// Host copy of the uniform buffer's contents.
    pub uniforms: SceneUniforms,
    /// How shadow rays are answered (`scene_occluded` in shading.wgsl).
    pub visibility: Visibility,
    /// The voxel array's layout, with voxel visibility.
    pub voxel_layout: Option<VoxelLayout>,
    /// The buffers of bindings 0–10, for integrands that extend `@group(1)`
    /// with their own bindings ([`GpuScene::layout_entries`],
    /// [`GpuScene::bind_group_entries`]).
    buffers: [wgpu::Buffer; SCENE_BINDINGS],
}

/// Bindings of the scene group: 0 uniforms, 1–7 geometry, materials and
/// lights, 8–10 the voxel visibility array (`shared/voxel.wgsl`).
pub const SCENE_BINDINGS: usize = 11;

impl GpuScene {
    /// Builds the BVHs and uploads `scene` for rendering at resolution
    /// `film` (which may differ from `scene.film`).
    pub fn new(gpu: &Gpu, scene: &Scene, film: Film) -> Result<GpuScene> {
        GpuScene::with_visibility(gpu, scene, film, Visibility::Bvh)
    }

    /// [`GpuScene::new`] with shadow rays answered by `visibility` (the
    /// voxel array is built here, on the device).
    pub fn with_visibility(
        gpu: &Gpu,
        scene: &Scene,
        film: Film,
        visibility: Visibility,
    ) -> Result<GpuScene> {
        let built = BuiltScene::new(scene)?;
        GpuScene::upload_with(gpu, scene, &built, film, visibility)
    }

    /// Uploads an already built scene; `built` must come from `scene`.
    pub fn upload(gpu: &Gpu, scene: &Scene, built: &BuiltScene, film: Film) -> Result<GpuScene> {
        GpuScene::upload_with(gpu, scene, built, film, Visibility::Bvh)
    }

    /// [`GpuScene::upload`] with shadow rays answered by `visibility`.
    pub fn upload_with(
        gpu: &Gpu,
        scene: &Scene,
        built: &BuiltScene,
        film: Film,
        visibility: Visibility,
    ) -> Result<GpuScene> {
        // Refuse an array that cannot fit before uploading anything.
        let voxel_layout = match visibility {
            Visibility::Voxel(params) => {
                let layout = VoxelLayout::new(built, params)?;
                layout.check_fits(gpu.max_binding_bytes())?;
                Some(layout)
            }
            Visibility::Bvh => None,
        };
        let materials: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .map(|m| GpuMaterial {
                albedo: m.albedo.into(),
                checker_scale: m.checker.map_or(0.0, |c| c.scale),
                emission: m.emission.into(),
                one_sided: m.one_sided as u32,
                albedo2: match (m.checker, m.uv_checker) {
                    (Some(c), _) => c.albedo2,
                    (None, Some(c)) => c.albedo2,
                    (None, None) => m.albedo,
                }
                .into(),
                checker_uv: m.uv_checker.is_some() as u32,
                to_uv0: m.uv_checker.map_or([0.0; 4], |c| {
                    let [a, b, t] = c.to_uv[0];
                    [a, b, t, 0.0]
                }),
                to_uv1: m.uv_checker.map_or([0.0; 4], |c| {
                    let [a, b, t] = c.to_uv[1];
                    [a, b, t, 0.0]
                }),
            })
            .collect();
        let lights: Vec<GpuLight> = scene.lights.iter().map(gpu_light).collect();
        let emitters = emitter_table(scene, built);
        let mut uniforms = scene_uniforms(
            scene,
            built,
            film,
            emitters.len() as u32,
            lights.len() as u32,
        );

        let n = built.triangle_count();
        // The triangles, then their shading-normal records (build.rs).
        let geometry = [built.triangles.as_slice(), built.normals.as_slice()].concat();
        gpu.check_binding_size(
            &format!(
                "mdas.scene.triangles ({n} triangles, 48 bytes each, {} with shading normals or texture coordinates, 64 more each)",
                built.normals.len() / super::build::RECORD_ROWS
            ),
            std::mem::size_of_val(geometry.as_slice()) as u64,
        )?;
        gpu.check_binding_size(
            &format!(
                "mdas.scene.nodes ({} CWBVH nodes for {n} triangles)",
                built.nodes.len()
            ),
            std::mem::size_of_val(built.nodes.as_slice()) as u64,
        )?;

        gpu.scoped("uploading the scene", || {
            let triangles =
                gpu.buffer_from("mdas.scene.triangles", &non_empty(&geometry), STORAGE)?;
            let voxels = match voxel_layout {
                Some(layout) => {
                    let v = GpuVoxels::build(gpu, built, &triangles, layout)?;
                    uniforms.visibility = VISIBILITY_VOXEL;
                    uniforms.voxel_directions = v.layout.params.directions;
                    uniforms.voxel_skip = v.layout.params.skip;
                    uniforms.voxel_objects = v.layout.objects.len() as u32;
                    Some(v)
                }
                None => None,
            };
            let voxel_build_ms = voxels.as_ref().map_or(0.0, |v| v.build_ms);
            let voxel_layout = voxels.as_ref().map(|v| v.layout.clone());
            let [bits, objects, frames] = match voxels {
                Some(v) => [v.bits, v.objects, v.frames],
                None => ["bits", "objects", "frames"].map(|what| {
                    gpu.buffer_zeroed(&format!("mdas.voxel.{what} (unused)"), 64, STORAGE)
                        .expect("64 bytes fit any binding")
                }),
            };
            let buffers = [
                gpu.uniform("mdas.scene.uniforms", &uniforms),
                gpu.buffer_from("mdas.scene.nodes", &non_empty(&built.nodes), STORAGE)?,
                triangles,
                gpu.buffer_from(
                    "mdas.scene.instances",
                    &non_empty(&built.instances),
                    STORAGE,
                )?,
                gpu.buffer_from(
                    "mdas.scene.keyframes",
                    &non_empty(&built.keyframes),
                    STORAGE,
                )?,
                gpu.buffer_from("mdas.scene.materials", &non_empty(&materials), STORAGE)?,
                gpu.buffer_from("mdas.scene.emitters", &non_empty(&emitters), STORAGE)?,
                gpu.buffer_from("mdas.scene.lights", &non_empty(&lights), STORAGE)?,
                bits,
                objects,
                frames,
            ];
            let layout = Self::bind_group_layout(gpu);
            let bind_group = bind_buffers(
                gpu,
                "mdas.scene",
                &layout,
                &buffers.iter().collect::<Vec<_>>(),
            );
            let stats = SceneStats {
                triangles: n,
                instances: built.instances.len() as u32,
                nodes: built.nodes.len() as u32,
                emitters: emitters.len() as u32,
                stack_depth: built.stack_depth,
                build_ms: built.build_ms,
                gpu_bytes: buffers.iter().map(|b| b.size()).sum(),
                voxel_bytes: voxel_layout.as_ref().map_or(0, |l| l.bytes()),
                voxel_build_ms,
            };
            Ok(GpuScene {
                layout,
                bind_group,
                stats,
                uniforms,
                visibility,
                voxel_layout,
                buffers,
            })
        })
    }

    /// The entries of the scene's `@group(1)` layout: binding 0 uniform,
    /// 1–10 read-only storage.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        let mut entries = vec![uniform_entry(0)];
        entries.extend((1..SCENE_BINDINGS as u32).map(|b| storage_entry(b, true)));
        entries
    }

    /// The voxel array's bits, read back (tests compare them with the CPU
    /// oracle [`super::voxel::build_cpu`]); empty with BVH visibility.
    pub fn read_voxel_bits(&self, gpu: &Gpu) -> Result<Vec<u32>> {
        match &self.voxel_layout {
            Some(l) => gpu.read_buffer::<u32>(&self.buffers[8], l.words as usize),
            None => Ok(Vec::new()),
        }
    }

    /// Bind group entries matching [`GpuScene::layout_entries`].
    pub fn bind_group_entries(&self) -> Vec<wgpu::BindGroupEntry<'_>> {
        self.buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect()
    }

    /// The layout of `@group(1)`: binding 0 uniform, 1–10 read-only storage.
    pub fn bind_group_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
        let entries = Self::layout_entries();
        gpu.bind_group_layout("mdas.scene", &entries)
    }
}

/// `data`, or one zeroed element if it is empty: a binding must hold at
/// least one element of the WGSL array (the counts in the uniforms stay 0).
fn non_empty<T: bytemuck::Pod>(data: &[T]) -> std::borrow::Cow<'_, [T]> {
    if data.is_empty() {
        std::borrow::Cow::Owned(vec![T::zeroed()])
    } else {
        std::borrow::Cow::Borrowed(data)
    }
}

fn gpu_light(light: &Light) -> GpuLight {
    match *light {
        Light::Point {
            position,
            intensity,
        } => GpuLight {
            kind: LIGHT_POINT,
            position: position.into(),
            intensity: intensity.into(),
            ..Default::default()
        },
        Light::Directional {
            direction,
            irradiance,
        } => GpuLight {
            kind: LIGHT_DIRECTIONAL,
            position: direction.normalize_or_zero().into(),
            intensity: irradiance.into(),
            ..Default::default()
        },
    }
}

/// Camera frame (docs/conventions.md "Primary ray"), film, shutter and counts.
pub fn scene_uniforms(
    scene: &Scene,
    built: &BuiltScene,
    film: Film,
    emitters: u32,
    lights: u32,
) -> SceneUniforms {
    let cam = &scene.camera;
    let f = (cam.look_at - cam.position).normalize();
    let r = f.cross(cam.up).normalize();
    let u = r.cross(f);
    SceneUniforms {
        cam_position: cam.position.into(),
        cam_lens_radius: cam.aperture_radius,
        cam_forward: f.into(),
        cam_focus_distance: cam.focus_distance,
        cam_right: r.into(),
        cam_tan_half_fov_y: cam.tan_half_fov_y(),
        cam_up: u.into(),
        cam_aspect: film.width as f32 / film.height as f32,
        film_size: [film.width as f32, film.height as f32],
        shutter: [cam.shutter_open, cam.shutter_close],
        background: scene.background.into(),
        emitter_count: emitters,
        light_count: lights,
        instance_count: built.instances.len() as u32,
        tlas_root: built.tlas_root,
        triangle_count: built.triangle_count(),
        ..Default::default()
    }
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The emissive triangles of `built` with selection pmf ∝
/// luminance(emission) · area, in global triangle order. Triangles whose
/// weight is zero (black emission, zero area) are left out. The cdf is
/// inclusive, accumulated in f64, and its last entry is exactly 1.
pub fn emitter_table(scene: &Scene, built: &BuiltScene) -> Vec<GpuEmitter> {
    let mut table: Vec<(u32, f64, f32)> = Vec::new();
    for prim in 0..built.triangle_count() {
        let emission = scene.materials[built.triangle_material(prim) as usize].emission;
        if emission.max_element() <= 0.0 {
            continue;
        }
        let [a, b, c] = built.triangle_stored(prim);
        let area = 0.5 * (b - a).cross(c - a).length();
        let weight = luminance(emission) as f64 * area as f64;
        if weight > 0.0 && weight.is_finite() {
            table.push((prim, weight, area));
        }
    }
    let total: f64 = table.iter().map(|e| e.1).sum();
    let mut running = 0.0;
    let count = table.len();
    table
        .into_iter()
        .enumerate()
        .map(|(i, (prim, weight, area))| {
            running += weight;
            let cdf = if i + 1 == count {
                1.0
            } else {
                (running / total).min(1.0) as f32
            };
            GpuEmitter {
                prim,
                cdf,
                pmf: (weight / total) as f32,
                area,
            }
        })
        .collect()
}
