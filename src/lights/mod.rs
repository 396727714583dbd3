//! Many-light sampling: light primitives, the perfect light tree of
//! real-time stochastic lightcuts (Lin & Yuksel, *Real-Time Stochastic
//! Lightcuts*, I3D 2020), and light samplers behind one contract.
//!
//! # Data (shared by the CPU code, the GPU build and the WGSL samplers)
//!
//! * [`LightPrim`] — one light primitive (point light or emissive
//!   triangle), 64 bytes, at one frame time.
//! * [`TreeNode`] — one node of a light tree, 32 bytes: bounds, the total
//!   scalar intensity below it and, for a leaf, the light id.
//!
//! # Perfect light tree layout
//!
//! `P` = the light count rounded up to a power of two (`P = 1` for one
//! light; no tree for zero lights). The tree has `L = log2(P)` + 1 levels,
//! stored level by level in one array of `2P − 1` nodes: level `ℓ`
//! (root ℓ = 0) occupies `[2^ℓ − 1, 2^(ℓ+1) − 1)`, the children of node `i`
//! are `2i + 1` and `2i + 2`. The leaf level holds the lights sorted by
//! (Morton code, light id), followed by bogus leaves (zero intensity,
//! [`TreeNode::EMPTY`] bounds, id [`NO_LIGHT`]). An internal node's bounds
//! are the union of its children's non-empty bounds and its intensity the
//! pairwise sum `I(left) + I(right)` (so building a level directly from
//! any level below it, summing as a balanced pairwise tree in child order,
//! gives bit-identical nodes); its id is [`NO_LIGHT`].
//!
//! # Morton codes (exact on CPU and GPU)
//!
//! 30 bits, 10 per axis, x in the highest bit of each triple. For each axis
//! with global light-centroid bounds `[lo, hi]` and extent `e = hi − lo`:
//! `e == 0` → the axis quantizes to 0; otherwise, with `E` the binary
//! exponent of `e` (`e = m·2^E`, `m ∈ [1, 2)`), `q = min(floor((c − lo)·2^(9−E)), 1023)`.
//! Only a subtraction and a multiplication by a power of two: both exact or
//! correctly rounded in IEEE f32 and in WGSL, so the GPU codes equal the
//! CPU codes bit for bit (the grid uses between 512 and 1024 cells of an
//! axis).
//!
//! # Scalar intensity
//!
//! The tree's `‖I‖` is the luminance (Rec. 709 weights) of the radiant
//! intensity bound: `I` for a point light, `L_e · area` for a one-sided
//! Lambertian emissive triangle (its on-axis intensity; its flux is
//! `L_e · area · π`), the on-axis intensity for a VPL.

pub mod bvh;
pub mod cone;
pub mod factory;
pub mod gpu_sampler;
pub mod importance;
pub mod lgh;
pub mod light_params;
pub mod morton;
pub mod registry;
pub mod sampler;
pub mod scene_lights;
pub mod simple;
pub mod substitute;
pub mod tree;
pub mod two_level;
pub mod vpl;

pub use cone::LightCone;
pub use factory::new_sampler;
pub use importance::Shading;
pub use registry::SamplerKind;
pub use sampler::{CutSampling, LightSample, LightSampler};
pub use simple::alias::{AliasEntry, PowerSampler};
pub use simple::UniformSampler;
pub use tree::cut::{select_cut, LightTree, TreeSampler};

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Light id of bogus leaves and internal nodes; also "no light sampled".
pub const NO_LIGHT: u32 = u32::MAX;

/// Rec. 709 luminance.
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Kind of a [`LightPrim`].
pub const KIND_POINT: u32 = 0;
pub const KIND_TRIANGLE: u32 = 1;
pub const KIND_VPL: u32 = 2;

/// One light primitive at one frame time, as uploaded to the GPU.
///
/// Point light: `p0` = position, `emission` = radiant intensity I (RGB,
/// W/sr), `p1`/`p2` unused (equal to `p0`). Triangle: vertices `p0, p1,
/// p2` (counter-clockwise; emits on the side of `(p1 − p0) × (p2 − p0)`),
/// `emission` = radiance L_e. Virtual point light ([`super::vpl`]):
/// `p0` = position, `p1` = unit normal, `p2` = `p0`, `emission` = the
/// on-axis intensity of its one-sided cosine lobe, `I(ω) = emission ·
/// max(0, n·ω)` (W/sr). Points and VPLs are placed at `p0` exactly: their
/// bounds and centroid are `p0`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightPrim {
    pub p0: [f32; 3],
    pub kind: u32,
    pub p1: [f32; 3],
    pub _pad0: u32,
    pub p2: [f32; 3],
    pub _pad1: u32,
    pub emission: [f32; 3],
    pub _pad2: u32,
}

impl LightPrim {
    pub fn point(position: Vec3, intensity: Vec3) -> LightPrim {
        LightPrim {
            p0: position.into(),
            kind: KIND_POINT,
            p1: position.into(),
            p2: position.into(),
            emission: intensity.into(),
            ..Default::default()
        }
    }

    pub fn triangle(p0: Vec3, p1: Vec3, p2: Vec3, radiance: Vec3) -> LightPrim {
        LightPrim {
            p0: p0.into(),
            kind: KIND_TRIANGLE,
            p1: p1.into(),
            p2: p2.into(),
            emission: radiance.into(),
            ..Default::default()
        }
    }

    /// A virtual point light at `position` emitting `intensity·max(0, n·ω)`
    /// about the unit `normal`.
    pub fn vpl(position: Vec3, normal: Vec3, intensity: Vec3) -> LightPrim {
        LightPrim {
            p0: position.into(),
            kind: KIND_VPL,
            p1: normal.into(),
            p2: position.into(),
            emission: intensity.into(),
            ..Default::default()
        }
    }

    pub fn area(&self) -> f32 {
        match self.kind {
            KIND_TRIANGLE => {
                let (a, b, c) = (
                    Vec3::from(self.p0),
                    Vec3::from(self.p1),
                    Vec3::from(self.p2),
                );
                0.5 * (b - a).cross(c - a).length()
            }
            _ => 0.0,
        }
    }

    /// The tree's scalar intensity ‖I‖ (module docs).
    pub fn intensity(&self) -> f32 {
        let e = luminance(Vec3::from(self.emission));
        match self.kind {
            KIND_TRIANGLE => e * self.area(),
            _ => e,
        }
    }

    /// Centroid (a point light's or VPL's position).
    pub fn centroid(&self) -> Vec3 {
        if self.kind != KIND_TRIANGLE {
            return Vec3::from(self.p0);
        }
        (Vec3::from(self.p0) + Vec3::from(self.p1) + Vec3::from(self.p2)) / 3.0
    }

    pub fn bounds_min(&self) -> Vec3 {
        if self.kind != KIND_TRIANGLE {
            return Vec3::from(self.p0);
        }
        Vec3::from(self.p0)
            .min(Vec3::from(self.p1))
            .min(Vec3::from(self.p2))
    }

    pub fn bounds_max(&self) -> Vec3 {
        if self.kind != KIND_TRIANGLE {
            return Vec3::from(self.p0);
        }
        Vec3::from(self.p0)
            .max(Vec3::from(self.p1))
            .max(Vec3::from(self.p2))
    }
}

/// One light tree node (32 bytes, the paper's size).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TreeNode {
    pub min: [f32; 3],
    /// Total scalar intensity ‖I‖ of the lights below (0 for bogus nodes).
    pub intensity: f32,
    pub max: [f32; 3],
    /// Leaf: the light id; internal or bogus: [`NO_LIGHT`].
    pub id: u32,
}

impl TreeNode {
    /// Bounds of bogus nodes: min > max (finite, so WGSL never sees Inf).
    pub const EMPTY_MIN: f32 = 3.0e38;
    pub const EMPTY_MAX: f32 = -3.0e38;

    /// A bogus node: zero intensity, empty bounds, no light.
    pub const EMPTY: TreeNode = TreeNode {
        min: [Self::EMPTY_MIN; 3],
        intensity: 0.0,
        max: [Self::EMPTY_MAX; 3],
        id: NO_LIGHT,
    };

    pub fn is_empty(&self) -> bool {
        self.min[0] > self.max[0]
    }
}
