//! Constant-time shadow rays: the 2D array of per-direction bit
//! voxelizations of Wang, Meng & Popescu, *Constant-Time Ray-Scene
//! Intersection for Interactive Rendering with Thousands of Dynamic Lights*
//! (`../shared/papers/constant-time-ray-scene-intersection.txt`), the
//! second visibility backend beside the BVH. This module holds the
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
            || self.resolution % WORD_BITS != 0
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

/// Whether the world segment p + t·d, t ∈ [0, t_max], meets the box
/// [lo, hi] (slabs; a zero component of d needs p inside that slab).
/// `voxel_segment_meets_box` in WGSL.
pub fn segment_meets_box(p: Vec3, d: Vec3, t_max: f32, lo: [f32; 3], hi: [f32; 3]) -> bool {
    let (mut t0, mut t1) = (0.0f32, t_max);
    for k in 0..3 {
        if d[k] == 0.0 {
            if p[k] < lo[k] || p[k] > hi[k] {
                return false;
            }
        } else {
            let ta = (lo[k] - p[k]) / d[k];
            let tb = (hi[k] - p[k]) / d[k];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    t0 <= t1
}

/// The voxel object of global triangle `prim`.
pub fn object_of(built: &BuiltScene, prim: u32) -> usize {
    if built.instances.is_empty() {
        0
    } else {
        built.triangle_instance(prim) as usize
    }
}

// Explicit scalar arithmetic, operation for operation as in voxel.wgsl,
// so that the CPU and GPU builds agree bit for bit.
fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn sub3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Object-space point `p` in the voxel coordinates of grid `f`.
pub fn to_voxel(o: &VoxelObject, f: &VoxelFrame, p: [f32; 3]) -> [f32; 3] {
    let rel = sub3(p, o.centre);
    let half = (o.res / 2) as f32;
    let ax = |v: [f32; 4]| dot3(rel, [v[0], v[1], v[2]]) + half;
    [ax(f.a), ax(f.b), ax(f.u)]
}

/// Object-space vector `d` in the voxel coordinates of grid `f`.
pub fn to_voxel_vector(f: &VoxelFrame, d: [f32; 3]) -> [f32; 3] {
    let ax = |v: [f32; 4]| dot3(d, [v[0], v[1], v[2]]);
    [ax(f.a), ax(f.b), ax(f.u)]
}

/// Whether the triangle (voxel coordinates, relative to the box centre)
/// meets the box [−½, ½]³: no separating axis among the 3 box normals, the
/// triangle normal and the 9 edge cross products.
pub fn triangle_meets_box(v: [[f32; 3]; 3]) -> bool {
    let e = [sub3(v[1], v[0]), sub3(v[2], v[1]), sub3(v[0], v[2])];
    let separated = |axis: [f32; 3]| {
        let p0 = dot3(axis, v[0]);
        let p1 = dot3(axis, v[1]);
        let p2 = dot3(axis, v[2]);
        let r = 0.5 * (axis[0].abs() + axis[1].abs() + axis[2].abs());
        p0.min(p1).min(p2) > r || p0.max(p1).max(p2) < -r
    };
    let units = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if units.iter().any(|&u| separated(u)) {
        return false;
    }
    if separated(cross3(e[0], e[1])) {
        return false;
    }
    for u in units {
        for edge in e {
            if separated(cross3(u, edge)) {
                return false;
            }
        }
    }
    true
}

/// The voxels one triangle (voxel coordinates `q`) sets in a grid of `res`
/// per side, restricted to columns `cols` (per loop axis, inclusive; the
/// whole footprint when `None`), passed to `set(x, y, z)`. The loop axes
/// are the two axes other than the normal's dominant one. The build
/// kernel runs the same loop over one tile of columns per work item.
pub fn voxelize_triangle(
    q: [[f32; 3]; 3],
    res: u32,
    cols: Option<[[i32; 2]; 2]>,
    mut set: impl FnMut(u32, u32, u32),
) {
    let n = cross3(sub3(q[1], q[0]), sub3(q[2], q[0]));
    let (ax, ay, az) = (n[0].abs(), n[1].abs(), n[2].abs());
    let k = if ax >= ay && ax >= az {
        0
    } else if ay >= az {
        1
    } else {
        2
    };
    let (i, j) = match k {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let nk = n[k];
    if nk == 0.0 || !nk.is_finite() {
        return;
    }
    let last = res as i32 - 1;
    let bound = |axis: usize| {
        let lo = q[0][axis].min(q[1][axis]).min(q[2][axis]).floor();
        let hi = q[0][axis].max(q[1][axis]).max(q[2][axis]).floor();
        // Clamp in f32 first: a far-away vertex must not overflow i32.
        let lo = lo.clamp(-1.0, res as f32) as i32;
        let hi = hi.clamp(-1.0, res as f32) as i32;
        [lo.max(0), hi.min(last)]
    };
    let (bi, bj, bk) = (bound(i), bound(j), bound(k));
    let [ri, rj] = match cols {
        Some([ci, cj]) => [
            [ci[0].max(bi[0]), ci[1].min(bi[1])],
            [cj[0].max(bj[0]), cj[1].min(bj[1])],
        ],
        None => [bi, bj],
    };
    let si = n[i] / nk;
    let sj = n[j] / nk;
    for ci in ri[0]..=ri[1] {
        for cj in rj[0]..=rj[1] {
            // The plane's k over the column's square is base − si·[0, 1] − sj·[0, 1].
            let base = q[0][k] - si * (ci as f32 - q[0][i]) - sj * (cj as f32 - q[0][j]);
            let kmin = base - si.max(0.0) - sj.max(0.0);
            let kmax = base - si.min(0.0) - sj.min(0.0);
            let z0 = ((kmin - 1e-3).floor().clamp(-1.0, res as f32) as i32).max(bk[0]);
            let z1 = ((kmax + 1e-3).floor().clamp(-1.0, res as f32) as i32).min(bk[1]);
            for ck in z0..=z1 {
                let mut cell = [0i32; 3];
                cell[i] = ci;
                cell[j] = cj;
                cell[k] = ck;
                let centre = cell.map(|c| c as f32 + 0.5);
                let v = q.map(|p| sub3(p, centre));
                if triangle_meets_box(v) {
                    set(cell[0] as u32, cell[1] as u32, cell[2] as u32);
                }
            }
        }
    }
}

/// Word index of voxel (x, y, z) of direction `v` of object `o`.
pub fn word_index(o: &VoxelObject, v: u32, x: u32, y: u32, z: u32) -> u64 {
    let r = o.res as u64;
    o.base as u64 + ((v as u64 * r + y as u64) * r + x as u64) * o.words as u64 + (z / 32) as u64
}

/// The CPU oracle of the whole build: the bits of every object and
/// direction (use on small scenes; the GPU build is [`super::gpu_voxel`]).
pub fn build_cpu(built: &BuiltScene, layout: &VoxelLayout) -> Vec<u32> {
    let mut bits = vec![0u32; layout.words as usize];
    for prim in 0..built.triangle_count() {
        let o = &layout.objects[object_of(built, prim)];
        let tri = built.triangle_stored(prim).map(|p| p.to_array());
        for v in 0..layout.params.direction_count() {
            let q = tri.map(|p| to_voxel(o, layout.frame(o, v), p));
            voxelize_triangle(q, o.res, None, |x, y, z| {
                bits[word_index(o, v, x, y, z) as usize] |= 1 << (z % 32);
            });
        }
    }
    bits
}

/// The build's work list: one item per (triangle, tile of
/// [`TILE`]×[`TILE`] columns) as [prim, tile | tiles_per_side << 16]. A
/// triangle of bounding radius ρ spans at most 2ρ·s + 2 columns per axis
/// in any direction, s the object's largest scale, and at most R; tiles
/// are counted from that bound (+1 for rounding), so the items of a
/// triangle cover its footprint in every direction.
pub fn work_items(built: &BuiltScene, layout: &VoxelLayout) -> Vec<[u32; 2]> {
    let mut items = Vec::with_capacity(built.triangle_count() as usize);
    for prim in 0..built.triangle_count() {
        let object = object_of(built, prim);
        let o = &layout.objects[object];
        let [a, b, c] = built.triangle_stored(prim);
        let centroid = (a + b + c) / 3.0;
        let rho = a
            .distance(centroid)
            .max(b.distance(centroid))
            .max(c.distance(centroid));
        let span = (2.0 * rho as f64 * layout.max_scale[object] + 3.0).ceil();
        if !span.is_finite() {
            continue;
        }
        let tiles = ((span / TILE as f64).ceil() as u32).clamp(1, o.res.div_ceil(TILE));
        for t in 0..tiles * tiles {
            items.push([prim, t | (tiles << 16)]);
        }
    }
    items
}

/// The direction index (i·n + j) of the voxelization whose rows best match
/// `d` (any length > 0): d flipped to y ≥ 0, θ = acos z, φ = atan2(y, x),
/// each rounded to the nearest step, φ = 180° wrapping to 0° with θ
/// mirrored, θ = 180° to θ = 0° (module docs). `voxel_direction` in WGSL.
pub fn direction_index(n: u32, d: Vec3) -> u32 {
    let mut d = d.normalize();
    if d.y < 0.0 {
        d = -d;
    }
    let k = n as f32 / std::f32::consts::PI;
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let phi = d.y.max(0.0).atan2(d.x);
    let mut i = ((theta * k + 0.5).floor() as u32).min(n);
    let mut j = ((phi * k + 0.5).floor() as u32).min(n);
    if j == n {
        j = 0;
        i = n - i;
    }
    if i == n {
        i = 0;
    }
    i * n + j
}

/// A shadow segment origin + t·dir, t ∈ [0, t_max], at scene time
/// `time`, starting on a surface of normal `n_origin` and ending on one of
/// normal `n_end` (zero vectors where it does not: a point light, a
/// direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_max: f32,
    pub time: f32,
    pub n_origin: Vec3,
    pub n_end: Vec3,
}

/// Whether the bits of `o` occlude the object-space segment `s` (the query
/// of the module docs; `voxel_object_hit` in WGSL).
pub fn object_hit(bits: &[u32], layout: &VoxelLayout, o: &VoxelObject, s: &Segment) -> bool {
    let (p, d, t_max) = (s.origin, s.dir, s.t_max);
    let v = direction_index(layout.params.directions, d);
    let f = layout.frame(o, v);
    let qp = to_voxel(o, f, p.to_array());
    let qd = to_voxel_vector(f, d.to_array());
    let res = o.res as f32;
    // Clip to the grid [0, R]³, slab by slab.
    let (mut t0, mut t1) = (0.0f32, t_max);
    for k in 0..3 {
        if qd[k] == 0.0 {
            if qp[k] < 0.0 || qp[k] > res {
                return false;
            }
        } else {
            let ta = (0.0 - qp[k]) / qd[k];
            let tb = (res - qp[k]) / qd[k];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    // (Also false for NaN.)
    if t0.partial_cmp(&t1) != Some(std::cmp::Ordering::Less) {
        return false;
    }
    let at = |t: f32| [0, 1, 2].map(|k| qp[k] + qd[k] * t);
    let (x0, xm, x1) = (at(t0), at(0.5 * (t0 + t1)), at(t1));
    let (x, y) = (xm[0].floor(), xm[1].floor());
    if x < 0.0 || y < 0.0 || x >= res || y >= res {
        return false;
    }
    let extra = 1 + layout.params.skip as i32;
    // Voxels excluded at a true endpoint `near`: its own, those its
    // surface's tangent plane touches along the row, `skip` more.
    let excluded = |near: [f32; 3], is_end: bool, n: Vec3| {
        if is_end {
            endpoint_skip(o, f, [x, y], near, xm, n) + extra
        } else {
            0
        }
    };
    let (s0, s1) = (
        excluded(x0, t0 == 0.0, s.n_origin),
        excluded(x1, t1 == t_max, s.n_end),
    );
    let z0 = x0[2].floor().clamp(-1.0, res) as i32;
    let z1 = x1[2].floor().clamp(-1.0, res) as i32;
    let (lo, hi) = if x0[2] <= x1[2] {
        (z0 + s0, z1 - s1)
    } else {
        (z1 + s1, z0 - s0)
    };
    let (lo, hi) = (lo.max(0), hi.min(o.res as i32 - 1));
    if lo > hi {
        return false;
    }
    let row = word_index(o, v, x as u32, y as u32, 0) as usize;
    let (lo, hi) = (lo as u32, hi as u32);
    (lo / 32..=hi / 32).any(|w| {
        let wlo = lo.max(32 * w) - 32 * w;
        let whi = hi.min(32 * w + 31) - 32 * w;
        let mask = (u32::MAX >> (31 - (whi - wlo))) << wlo;
        bits[row + w as usize] & mask != 0
    })
}

/// The voxels after a true endpoint's own that its surface (object-space
/// normal `n`; zero: none) still touches along row `row` towards `far`:
/// the tangent plane through `near` meets the row's k-th voxel from
/// `near`'s (centre c_k) while |n_v·(c_k − near)| ≤ ½(|n_v,x| + |n_v,y| +
/// |n_v,z|), n_v the normal in voxel space (x·n/|x|² for each scaled axis
/// x); that is linear in k, and this is the last such k (0 if none).
pub fn endpoint_skip(
    o: &VoxelObject,
    f: &VoxelFrame,
    row: [f32; 2],
    near: [f32; 3],
    far: [f32; 3],
    n: Vec3,
) -> i32 {
    if n == Vec3::ZERO {
        return 0;
    }
    let n = n.to_array();
    let scaled = |x: [f32; 4]| {
        let x = [x[0], x[1], x[2]];
        dot3(x, n) / dot3(x, x)
    };
    let nv = [scaled(f.a), scaled(f.b), scaled(f.u)];
    let r = 0.5 * (nv[0].abs() + nv[1].abs() + nv[2].abs());
    let c0 = [row[0] + 0.5, row[1] + 0.5, near[2].floor() + 0.5];
    let f0 = nv[0] * (c0[0] - near[0]) + nv[1] * (c0[1] - near[1]) + nv[2] * (c0[2] - near[2]);
    let slope = if far[2] >= near[2] { nv[2] } else { -nv[2] };
    let res = o.res as f32;
    let touching = if slope != 0.0 {
        let q = (r - slope.signum() * f0) / slope.abs();
        // (NaN, from a NaN normal, counts as 0.)
        if q >= 0.0 {
            q.floor().min(res)
        } else {
            0.0
        }
    } else if f0.abs() <= r {
        res
    } else {
        0.0
    };
    touching as i32
}

/// Whether the world-space segment `s` is occluded: any object hit,
/// moving instances queried in their own frame at `s.time`
/// (`voxel_occluded` in WGSL).
pub fn occluded(built: &BuiltScene, layout: &VoxelLayout, bits: &[u32], s: &Segment) -> bool {
    layout.objects.iter().enumerate().any(|(i, o)| {
        if !segment_meets_box(s.origin, s.dir, s.t_max, o.world_min, o.world_max) {
            return false;
        }
        let moving = built
            .instances
            .get(i)
            .is_some_and(|inst| inst.key_count > 0);
        let local = if moving {
            let x = built.instance_transform_at(i as u32, s.time);
            Segment {
                origin: x.inverse_point(s.origin),
                dir: x.inverse_vector(s.dir),
                n_origin: x.inverse_vector(s.n_origin),
                n_end: x.inverse_vector(s.n_end),
                ..*s
            }
        } else {
            *s
        };
        object_hit(bits, layout, o, &local)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    /// Whether the triangle meets the box [−h, h]³, by clipping the
    /// triangle polygon against the box's six planes (Sutherland–Hodgman)
    /// in f64: an oracle independent of the separating-axis test.
    fn clipped_meets_box(v: [[f32; 3]; 3], h: f64) -> bool {
        let mut poly: Vec<[f64; 3]> = v.iter().map(|p| p.map(|c| c as f64)).collect();
        for axis in 0..3 {
            for sign in [1.0, -1.0] {
                // Keep sign·p[axis] ≤ h.
                let inside = |p: &[f64; 3]| sign * p[axis] <= h;
                let mut out = Vec::new();
                for k in 0..poly.len() {
                    let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                    if inside(&a) {
                        out.push(a);
                    }
                    if inside(&a) != inside(&b) {
                        let t = (h - sign * a[axis]) / (sign * (b[axis] - a[axis]));
                        out.push([0, 1, 2].map(|c| a[c] + t * (b[c] - a[c])));
                    }
                }
                poly = out;
                if poly.is_empty() {
                    return false;
                }
            }
        }
        true
    }

    /// The voxelization is conservative up to touching and tight: against
    /// the clipping oracle over a whole 32³ grid, every voxel the triangle
    /// meets with a 10⁻³-voxel margin inside is set, and every set voxel's
    /// box grown by 10⁻³ meets the triangle. Random triangles of every size
    /// (slivers, huge ones reaching outside the grid, tiny ones).
    #[test]
    fn voxelization_is_conservative_and_tight_against_clipping() {
        let mut rng = StdRng::seed_from_u64(11);
        let res = 32u32;
        let (mut set_total, mut tested) = (0usize, 0usize);
        for t in 0..120 {
            let size = [0.3f32, 3.0, 20.0, 60.0][t % 4];
            let centre: [f32; 3] = std::array::from_fn(|_| rng.random_range(2.0..30.0));
            let q: [[f32; 3]; 3] = std::array::from_fn(|_| {
                std::array::from_fn(|c| centre[c] + size * rng.random_range(-1.0..1.0f32))
            });
            let mut set = vec![false; (res * res * res) as usize];
            voxelize_triangle(q, res, None, |x, y, z| {
                set[((z * res + y) * res + x) as usize] = true;
            });
            for z in 0..res {
                for y in 0..res {
                    for x in 0..res {
                        let c = [x, y, z].map(|i| i as f32 + 0.5);
                        let v = q.map(|p| sub3(p, c));
                        let is_set = set[((z * res + y) * res + x) as usize];
                        if clipped_meets_box(v, 0.5 - 1e-3) {
                            assert!(is_set, "triangle {t} {q:?}: voxel {x},{y},{z} missed");
                        }
                        if is_set {
                            assert!(
                                clipped_meets_box(v, 0.5 + 1e-3),
                                "triangle {t} {q:?}: voxel {x},{y},{z} set but apart"
                            );
                            set_total += 1;
                        }
                        tested += 1;
                    }
                }
            }
        }
        assert!(set_total > 10_000, "{set_total} of {tested} set");
    }

    /// Tiles of TILE columns partition a triangle's columns: their union
    /// is the whole footprint's voxels, in any direction.
    #[test]
    fn tiles_cover_the_footprint() {
        let q = [[1.3, 2.2, 3.1], [40.0, 7.5, 12.0], [9.0, 50.0, 30.0]];
        let res = 64;
        let mut whole = Vec::new();
        voxelize_triangle(q, res, None, |x, y, z| whole.push([x, y, z]));
        let mut tiled = Vec::new();
        let t = TILE as i32;
        for ti in 0..4 {
            for tj in 0..4 {
                // Columns counted from the footprint's low corner, as the kernel does.
                let cols = [[ti * t, ti * t + t - 1], [tj * t, tj * t + t - 1]];
                let lo = |axis: usize| q.iter().map(|p| p[axis]).fold(f32::MAX, f32::min);
                let n = cross3(sub3(q[1], q[0]), sub3(q[2], q[0]));
                let k = (0..3)
                    .max_by(|&a, &b| n[a].abs().partial_cmp(&n[b].abs()).unwrap().then(b.cmp(&a)))
                    .unwrap();
                let (i, j) = match k {
                    0 => (1, 2),
                    1 => (0, 2),
                    _ => (0, 1),
                };
                let (li, lj) = (lo(i).floor() as i32, lo(j).floor() as i32);
                let cols = [
                    [li + cols[0][0], li + cols[0][1]],
                    [lj + cols[1][0], lj + cols[1][1]],
                ];
                voxelize_triangle(q, res, Some(cols), |x, y, z| tiled.push([x, y, z]));
            }
        }
        whole.sort();
        tiled.sort();
        assert!(!whole.is_empty());
        assert_eq!(whole, tiled);
    }

    /// Every direction maps to a voxelization whose row axis is within
    /// k/√2 of it (up to sign), the bound of rounding θ and φ to the
    /// nearest step; on-grid directions map to themselves.
    #[test]
    fn direction_index_picks_a_row_axis_within_half_a_diagonal_step() {
        let mut rng = StdRng::seed_from_u64(3);
        for n in [1u32, 6, 30, 90] {
            let frames: Vec<[f32; 3]> = axes(n).iter().map(|f| f[2].map(|c| c as f32)).collect();
            let k = std::f32::consts::PI / n as f32;
            let bound = (k / std::f32::consts::SQRT_2).min(std::f32::consts::FRAC_PI_2) + 1e-4;
            for _ in 0..20_000 {
                let d = Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                if d.length() < 1e-3 {
                    continue;
                }
                let v = direction_index(n, d);
                let u = Vec3::from(frames[v as usize]);
                let angle = d.normalize().dot(u).abs().min(1.0).acos();
                // Near the pole a step of φ moves u by less: the bound holds.
                assert!(angle <= bound, "n {n}, d {d}: {angle} > {bound}");
            }
            for (v, f) in frames.iter().enumerate() {
                let u = Vec3::from(*f);
                let got = direction_index(n, u);
                let same = Vec3::from(frames[got as usize]);
                assert!(
                    got == v as u32 || same.dot(u).abs() > 1.0 - 1e-6,
                    "n {n}: frame {v} maps to {got}"
                );
            }
        }
    }
}
