//! Constant-time shadow rays: the 2D array of per-direction bit
//! voxelizations of Wang, Meng & Popescu, *Constant-Time Ray-Scene
//! Intersection for Interactive Rendering with Thousands of Dynamic Lights*
//! (a manuscript submitted to ACM Transactions on Graphics;
//! docs/conventions.md, "References"), the second visibility backend beside
//! the BVH. This module holds the
//! parameters, the memory layout, and the CPU oracle of both the build and
//! the query; [`super::gpu_voxel`] builds the same bits on the GPU and
//! `wgsl/shared/voxel.wgsl` answers the queries.
//!
//! # Directions
//! The paper's array: θ and φ in [0°, 180°) in steps of k = 180°/n (its
//! default n = 90, k = 2°). Voxelization (i, j) has its rows along
//! u = (sin θ cos φ, sin θ sin φ, cos θ) with θ = i·k, φ = j·k, and its other
//! two axes a = ∂u/∂θ = (cos θ cos φ, cos θ sin φ, −sin θ) and
//! b = (−sin φ, cos φ, 0). Every line direction has a representative with
//! y ≥ 0, i.e. φ ∈ [0°, 180°]: a query direction is flipped to it, its
//! angles rounded to the nearest step (φ = 180° wraps to φ = 0° with θ
//! mirrored to 180° − θ; θ = 180° is the pole θ = 0°). The row axis is then
//! within k/√2 of the segment's direction. The frames are computed once on
//! the host (f64, stored f32) and shared by the CPU and the GPU.
//!
//! # Objects, grids and resolution
//! Each instance of the scene ([`BuiltScene::instances`]; the static
//! geometry when there are none) is one voxelized object, in its own
//! object space: a moving rigid instance is queried by taking the segment
//! into its frame at the ray's time, the paper's Algorithm 4 (our scenes
//! have rigid motion only, so nothing is rebuilt per frame). The grid of
//! direction (i, j) is the box around the object's bounding box (centre c,
//! half extents e) in the frame (a, b, u): half widths w_x = Σ|x_k|·e_k for
//! x = a, b, u, each cut into R voxels. So the voxels are boxes, not cubes,
//! and as fine as the object is thin in that frame: seen from above, a
//! 20 × 0.6 × 20 floor with a box on it gets rows of 0.6/R per bit, where
//! the paper's cube around the bounding sphere would give 28/R. (Widths
//! are padded by 10⁻⁴ and at least 10⁻³·|e|.) Each direction's frame is
//! stored pre-scaled, x·(R/2w_x), so that voxel coordinates are
//! q = ((p − c)·a', (p − c)·b', (p − c)·u') + R/2. The largest object gets
//! `resolution` voxels per side; smaller ones get proportionally fewer (by
//! |e|, a multiple of 32, at least 32).
//!
//! # Voxelization
//! Voxel (x, y, z) of a direction (x along a, y along b, z along the row
//! axis u) is set when a triangle of the object meets its box, by the
//! separating-axis test of Akenine-Möller (2001) on the 13 axes, in voxel
//! coordinates (an affine map keeps intersections). Only voxels whose
//! column range can hold the triangle's plane are tested (columns along
//! the dominant axis of the normal, ranges widened by 10⁻³ voxel), so the
//! result is conservative up to exact touching: every voxel whose interior
//! a triangle passes through is set, and every set voxel's closed box meets
//! the triangle. Degenerate (zero-area) triangles set nothing, as they hide
//! nothing from the BVH either.
//!
//! # Query (the paper's Algorithm 2, and Algorithm 4 for instances)
//! A shadow segment from P along d for t ∈ [0, t_max] is first tested
//! against each object's world bounds (swept over its keyframes); where it
//! meets them it is taken into the object's frame at the ray's time, then
//! into the voxel coordinates of the object's nearest direction, and
//! clipped to the grid [0, R]³ (slabs). The row is the one through the
//! clipped segment's midpoint; the endpoints are projected on the row
//! axis, and the segment is occluded when a bit between them is set,
//! tested word by word with explicit masks (WGSL shifts use only the low 5
//! bits of the shift).
//!
//! **Self-occlusion rule** (the paper is silent). At a true endpoint of
//! the segment (P, or the light end when the segment stops inside the
//! grid) lies a surface, whose voxels the row passes through near that
//! end: the row runs up to ~√2/2 voxel off P laterally and k/√2 off in
//! angle, so at grazing angles it stays inside the surface's voxels for
//! a while. Left out of the test, at each true endpoint: its own voxel;
//! when the caller gives the surface's normal n (`scene_occluded` does),
//! every voxel of the row up to the last one the tangent plane through the
//! endpoint still touches (for a box of half-sizes ½ in voxel space that is
//! |n_v·(c − p)| ≤ ½(|n_v,x| + |n_v,y| + |n_v,z|), with n_v the normal in
//! voxel coordinates — linear along the row, so one division finds the
//! run; [`endpoint_skip`]); then `skip` more voxels (default 1). A point
//! light has no surface: its own voxel and `skip` more. Ends made by
//! clipping to the grid are not endpoints and keep every voxel. The rule
//! is exact for a planar surface; curved ones and occluders within a
//! voxel of the endpoint's surface are below the array's resolution.
//! Tried and dropped: a row through each endpoint for its half of the
//! segment (no lateral offset at the ends, but a wall near the middle
//! slipped between the two rows), and capping the skipped run at the
//! midpoint (a grazing segment then met its own floor there).

use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::f64::consts::PI;

use super::build::BuiltScene;

mod oracle;
pub use oracle::*;

/// Voxel rows are stored in 32-bit words.
pub const WORD_BITS: u32 = 32;
/// Columns per side of one build work item's tile (see [`work_items`]).
pub const TILE: u32 = 16;
/// Most directions per angle (1° steps).
pub const MAX_DIRECTIONS: u32 = 180;
/// Most voxels per side of an object.
pub const MAX_RESOLUTION: u32 = 1024;
/// Most extra skipped voxels at an endpoint.
pub const MAX_SKIP: u32 = 16;

/// The parameters of voxel visibility (scene file `[integrand]` keys
/// `voxel_directions`, `voxel_resolution`, `voxel_skip`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VoxelParams {
    /// n: the direction array is n × n, steps of 180°/n (paper: 90).
    pub directions: u32,
    /// Voxels per side of the largest object, a multiple of 32 (paper: 128).
    pub resolution: u32,
    /// Voxels skipped beyond an endpoint's own and those its surface's
    /// tangent plane touches (the self-occlusion rule).
    pub skip: u32,
}

impl Default for VoxelParams {
    /// 30 × 30 directions (6°) at 64³: 28 MiB for one object, within
    /// lavapipe's 128 MiB storage binding.
    fn default() -> Self {
        VoxelParams {
            directions: 30,
            resolution: 64,
            skip: 1,
        }
    }
}

impl VoxelParams {
    /// The paper's configuration: 2° steps (90 × 90) at 128³, ~2 GB.
    pub const PAPER: VoxelParams = VoxelParams {
        directions: 90,
        resolution: 128,
        skip: 1,
    };

    /// Checks the ranges (messages name the scene-file keys).
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_DIRECTIONS).contains(&self.directions) {
            bail!(
                "voxel_directions must be in 1..={MAX_DIRECTIONS}, found {}",
                self.directions
            );
        }
        if self.resolution < WORD_BITS
            || self.resolution > MAX_RESOLUTION
            || !self.resolution.is_multiple_of(WORD_BITS)
        {
            bail!(
                "voxel_resolution must be a multiple of 32 in 32..={MAX_RESOLUTION}, found {}",
                self.resolution
            );
        }
        if self.skip > MAX_SKIP {
            bail!("voxel_skip must be at most {MAX_SKIP}, found {}", self.skip);
        }
        Ok(())
    }

    /// Voxelizations in the array (n²).
    pub fn direction_count(&self) -> u32 {
        self.directions * self.directions
    }

    /// The angle step k in degrees.
    pub fn step_degrees(&self) -> f64 {
        180.0 / self.directions as f64
    }

    /// "30×30 directions (6°) at 64³".
    pub fn describe(&self) -> String {
        let r = self.resolution;
        format!(
            "{n}×{n} directions ({k}°) at {r}³",
            n = self.directions,
            k = trim(self.step_degrees())
        )
    }
}

fn trim(x: f64) -> String {
    let s = format!("{x:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// How shadow rays are answered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Visibility {
    /// Exact: any-hit traversal of the BVH.
    #[default]
    Bvh,
    /// Approximate, constant time: the voxelization array.
    Voxel(VoxelParams),
}

impl Visibility {
    /// `bvh` or `voxel`.
    pub fn name(&self) -> &'static str {
        match self {
            Visibility::Bvh => "bvh",
            Visibility::Voxel(_) => "voxel",
        }
    }

    /// What a render's report says: `bvh`, or `voxel (30×30 directions
    /// (6°) at 64³, skip 1)`.
    pub fn describe(&self) -> String {
        match self {
            Visibility::Bvh => "bvh".into(),
            Visibility::Voxel(p) => format!("voxel ({}, skip {})", p.describe(), p.skip),
        }
    }

    pub fn is_voxel(&self) -> bool {
        matches!(self, Visibility::Voxel(_))
    }
}

/// The backend a `--visibility` flag names; voxel parameters come from the
/// scene file's `voxel_*` keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VisibilityKind {
    Bvh,
    Voxel,
}

impl VisibilityKind {
    /// The visibility of this kind with the voxel parameters `voxel`.
    pub fn with(self, voxel: VoxelParams) -> Visibility {
        match self {
            VisibilityKind::Bvh => Visibility::Bvh,
            VisibilityKind::Voxel => Visibility::Voxel(voxel),
        }
    }
}

impl std::str::FromStr for VisibilityKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "bvh" => Ok(VisibilityKind::Bvh),
            "voxel" => Ok(VisibilityKind::Voxel),
            other => Err(format!(
                "unknown visibility '{other}', expected bvh or voxel"
            )),
        }
    }
}

impl std::fmt::Display for VisibilityKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            VisibilityKind::Bvh => "bvh",
            VisibilityKind::Voxel => "voxel",
        })
    }
}

/// One voxelized object on the device (`VoxelObject` in voxel.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxelObject {
    /// Centre c of the bounding box and of every grid (object space).
    pub centre: [f32; 3],
    /// Voxels per side R (a multiple of 32).
    pub res: u32,
    /// Words per row, R / 32.
    pub words: u32,
    /// First word of the object's bits; direction v's voxel (x, y, z) is
    /// bit z % 32 of word base + ((v·R + y)·R + x)·words + z / 32.
    pub base: u32,
    /// Index of the object's direction-0 frame in [`VoxelLayout::frames`].
    pub frames: u32,
    pub _pad: u32,
    /// World-space bounds of the object at every time (swept over its
    /// keyframes for a moving instance): a segment that misses them is not
    /// taken into the object's frame at all.
    pub world_min: [f32; 3],
    pub _pad1: u32,
    pub world_max: [f32; 3],
    pub _pad2: u32,
}

/// The grid of one object and direction (`VoxelFrame` in voxel.wgsl): the
/// axes a, b and u (the row axis) scaled by R/(2w) (module docs), each
/// padded to 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxelFrame {
    pub a: [f32; 4],
    pub b: [f32; 4],
    pub u: [f32; 4],
}

const _: () = assert!(std::mem::size_of::<VoxelObject>() == 64);
const _: () = assert!(std::mem::size_of::<VoxelFrame>() == 48);

/// The unit axes (a, b, u) of an n × n array, index i·n + j for θ = i·k,
/// φ = j·k (module docs).
pub fn axes(n: u32) -> Vec<[[f64; 3]; 3]> {
    let k = PI / n as f64;
    let mut out = Vec::with_capacity((n * n) as usize);
    for i in 0..n {
        for j in 0..n {
            let (st, ct) = (i as f64 * k).sin_cos();
            let (sp, cp) = (j as f64 * k).sin_cos();
            out.push([
                [ct * cp, ct * sp, -st],
                [-sp, cp, 0.0],
                [st * cp, st * sp, ct],
            ]);
        }
    }
    out
}

/// The grids of one object with half extents `e` at `res` voxels per side
/// for every direction of `axes`, and the largest scale among them (voxels
/// per unit length).
fn object_frames(axes: &[[[f64; 3]; 3]], e: [f64; 3], res: u32) -> (Vec<VoxelFrame>, f64) {
    let norm = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
    let floor = (1e-3 * norm).max(1e-6);
    let mut largest = 0.0f64;
    let frames = axes
        .iter()
        .map(|f| {
            let mut scaled = |x: [f64; 3]| {
                let w = x[0].abs() * e[0] + x[1].abs() * e[1] + x[2].abs() * e[2];
                let w = (w * (1.0 + 1e-4)).max(floor);
                let s = res as f64 / (2.0 * w);
                largest = largest.max(s);
                [(x[0] * s) as f32, (x[1] * s) as f32, (x[2] * s) as f32, 0.0]
            };
            let (a, b, u) = (scaled(f[0]), scaled(f[1]), scaled(f[2]));
            VoxelFrame { a, b, u }
        })
        .collect();
    (frames, largest)
}

/// The objects of a build and where their bits go.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelLayout {
    pub params: VoxelParams,
    pub objects: Vec<VoxelObject>,
    /// Every object's grid per direction (`VoxelObject::frames` + v).
    pub frames: Vec<VoxelFrame>,
    /// Per object, the largest scale of its frames (voxels per unit
    /// length), for sizing the build's tiles.
    pub max_scale: Vec<f64>,
    /// Per object, its size |e| over the largest object's (sets its
    /// resolution, [`object_resolution`]).
    pub shares: Vec<f64>,
    /// Words of all objects' bits.
    pub words: u64,
}

/// Voxels per side of an object `share` of the largest one's size under
/// `resolution`: proportional, a multiple of 32, at least 32.
pub fn object_resolution(share: f64, resolution: u32) -> u32 {
    let scaled = (resolution as f64 * share).ceil() as u32;
    scaled
        .next_multiple_of(WORD_BITS)
        .clamp(WORD_BITS, resolution)
}

impl VoxelLayout {
    /// Bytes of the bits (the frames and objects are small beside them).
    pub fn bytes(&self) -> u64 {
        self.words * 4
    }

    /// The objects of `built` (one per instance, or one for all triangles
    /// when there are no instances) under `params`.
    pub fn new(built: &BuiltScene, params: VoxelParams) -> Result<VoxelLayout> {
        params.validate()?;
        let count = built.instances.len().max(1);
        let mut lo = vec![Vec3::splat(f32::INFINITY); count];
        let mut hi = vec![Vec3::splat(f32::NEG_INFINITY); count];
        for prim in 0..built.triangle_count() {
            let o = object_of(built, prim);
            for v in built.triangle_stored(prim) {
                lo[o] = lo[o].min(v);
                hi[o] = hi[o].max(v);
            }
        }
        let half: Vec<[f64; 3]> = (0..count)
            .map(|o| {
                if lo[o].x <= hi[o].x {
                    ((hi[o] - lo[o]) * 0.5).as_dvec3().to_array()
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        let norms: Vec<f64> = half
            .iter()
            .map(|e| (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt())
            .collect();
        let largest = norms.iter().cloned().fold(0.0f64, f64::max);
        let shares: Vec<f64> = norms
            .iter()
            .map(|&n| if largest > 0.0 { n / largest } else { 1.0 })
            .collect();
        let axes = axes(params.directions);
        let mut base = 0u64;
        let mut objects = Vec::with_capacity(count);
        let mut frames = Vec::with_capacity(count * axes.len());
        let mut max_scale = Vec::with_capacity(count);
        for o in 0..count {
            let res = object_resolution(shares[o], params.resolution);
            let centre = if lo[o].x <= hi[o].x {
                (lo[o] + hi[o]) * 0.5
            } else {
                Vec3::ZERO
            };
            let (world_min, world_max) = world_bounds(built, o, lo[o], hi[o]);
            objects.push(VoxelObject {
                centre: centre.into(),
                res,
                words: res / WORD_BITS,
                base: base.min(u32::MAX as u64) as u32,
                frames: frames.len() as u32,
                world_min: world_min.into(),
                world_max: world_max.into(),
                ..Default::default()
            });
            let (f, scale) = object_frames(&axes, half[o], res);
            frames.extend(f);
            max_scale.push(scale);
            base += words_per_direction(res) * params.direction_count() as u64;
        }
        Ok(VoxelLayout {
            params,
            objects,
            frames,
            max_scale,
            shares,
            words: base,
        })
    }

    /// Bytes of the bits of these objects under `params` (what
    /// [`VoxelLayout::bytes`] would be for a layout built with them).
    pub fn bytes_with(&self, params: VoxelParams) -> u64 {
        let words: u64 = self
            .shares
            .iter()
            .map(|&s| words_per_direction(object_resolution(s, params.resolution)))
            .sum();
        4 * words * params.direction_count() as u64
    }

    /// The grid of object `o` for direction `v`.
    pub fn frame(&self, o: &VoxelObject, v: u32) -> &VoxelFrame {
        &self.frames[(o.frames + v) as usize]
    }

    /// Fails before any work when the bits exceed one storage binding of
    /// `max_bytes` (or 2³² words), naming the size needed and the largest
    /// configurations that fit: the same directions at a lower resolution,
    /// and the same resolution with fewer directions.
    pub fn check_fits(&self, max_bytes: u64) -> Result<()> {
        let max_bytes = max_bytes.min(4 * u32::MAX as u64);
        if self.bytes() <= max_bytes {
            return Ok(());
        }
        let p = self.params;
        let fits = |q: VoxelParams| self.bytes_with(q) <= max_bytes;
        let mut suggestions = Vec::new();
        if let Some(res) = (1..p.resolution / WORD_BITS)
            .rev()
            .map(|w| w * WORD_BITS)
            .find(|&resolution| fits(VoxelParams { resolution, ..p }))
        {
            suggestions.push(VoxelParams {
                resolution: res,
                ..p
            });
        }
        if let Some(n) = (1..p.directions)
            .rev()
            .find(|&directions| fits(VoxelParams { directions, ..p }))
        {
            suggestions.push(VoxelParams { directions: n, ..p });
        }
        let mib = |b: u64| b as f64 / 1048576.0;
        let hint = if suggestions.is_empty() {
            "no configuration of this scene fits".to_string()
        } else {
            let s: Vec<String> = suggestions
                .iter()
                .map(|q| {
                    let b = self.bytes_with(*q);
                    format!(
                        "{} ({:.1} MiB; voxel_directions = {}, voxel_resolution = {})",
                        q.describe(),
                        mib(b),
                        q.directions,
                        q.resolution
                    )
                })
                .collect();
            format!("the largest that fit: {}", s.join(" or "))
        };
        bail!(
            "voxel visibility with {} needs {:.1} MiB for {} object(s), but this adapter \
             allows {:.1} MiB per storage buffer; {hint}",
            p.describe(),
            mib(self.bytes()),
            self.objects.len(),
            mib(max_bytes)
        )
    }
}

/// Words of one direction's bits of an object of `res` voxels per side.
fn words_per_direction(res: u32) -> u64 {
    let r = res as u64;
    r * r * r / WORD_BITS as u64
}

/// World bounds of object `o` with object-space bounds [lo, hi] (empty
/// when lo > hi): swept over its keyframes when it moves, padded by 10⁻⁴
/// of its size (and 10⁻⁶) against rounding.
fn world_bounds(built: &BuiltScene, o: usize, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    if lo.x > hi.x {
        return (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    }
    let moving = built.instances.get(o).is_some_and(|i| i.key_count > 0);
    let (lo, hi) = if moving {
        let keys = built.instance_keys(o as u32);
        let b = crate::scene::motion::swept_bounds(
            &keys,
            &obvhs::aabb::Aabb::new(lo.into(), hi.into()),
        );
        (Vec3::from(b.min), Vec3::from(b.max))
    } else {
        (lo, hi)
    };
    let pad = (hi - lo).max_element() * 1e-4 + 1e-6;
    (lo - pad, hi + pad)
}

#[cfg(test)]
mod tests;
