//! The lighting grid hierarchy (Lin & Yuksel 2019, *Real-Time Rendering
//! with Lighting Grid Hierarchy*, I3D '19; after Yuksel & Yuksel
//! 2017): many point lights and VPLs replaced by grid lights at doubling
//! cell sizes, the levels blended by distance, shadows estimated with a
//! few stochastic shadow rays. This module is the CPU oracle of the GPU
//! build ([`gpu`], `wgsl/lights/lgh_build.wgsl`) and of the
//! shading (`wgsl/lights/lgh.wgsl`, sampler `lgh` of the `many_light`
//! integrand): the same rules, the same f32 operations in the same order.
//!
//! # Grid (paper §3.1)
//!
//! `L` levels of grid lights `S_1 … S_L` over the bounding box of the
//! lights' positions (`lo`, longest edge `h_top`; `h_top = 1` when all
//! lights coincide). Points and VPLs are grid lights; emissive triangles
//! are not (the integrand samples one of them directly, as the paper
//! computes direct light apart from its VPLs). Level ℓ has cell size `h_ℓ = h_top / 2^(L−ℓ)` and
//! `R_ℓ = 2^(L−ℓ) + 1` vertices per axis from `lo`; the top level `S_L`
//! is one cell with 8 vertices. `S_0` are the original lights (cell size
//! `h_0 = h_1 / 2`). Scaling by powers of two is exact in f32, so CPU and
//! GPU agree on every `h_ℓ` and `1/h_ℓ` (`1/h_1` is computed once on the
//! host). `L` is `lgh_levels`, or by default the largest `L ≤ 8` with
//! at most `N/2` level-1 cells, `8^(L−1) ≤ max(N/2, 1)` (the paper picks
//! the largest `L` with fewer than `N/2` level-1 *lights*; ours is known
//! before the build and never finer).
//!
//! # Construction (deterministic, no float atomics)
//!
//! A light at `p` in level-1 cell `c = clamp(⌊(p − lo)/h_1⌋, 0, R_1 − 2)`
//! with fraction `t = clamp((p − lo)/h_1 − c, 0, 1)` gives the vertex
//! `c + δ` (δ ∈ {0,1}³) the trilinear weight `w = Π (δ ? t : 1 − t)`.
//! The lights are sorted by (cell, id) and each level-1 vertex *gathers*
//! from its 8 cells in a fixed order (δ = 0…7, x fastest; lights in sorted
//! order), so the sums do not depend on thread timing (the paper scatters
//! with float atomics; its demo's order, and so its result, varies from
//! run to run). A grid light holds sums over its lights, with `ω = w·‖I‖`
//! (luminance) and moments about its own vertex `v`:
//! `e = Σ w·I` (RGB), `W = Σ ω`, `P = Σ ω(p − v)`, `Q = Σ ω(p − v)²`
//! (per axis), `N = Σ ω·n` over VPLs, `iso = Σ ω` over point lights: the
//! intensity-weighted illumination centre `v + P/W` (the paper's; its
//! demo weights positions by w alone) and its variance `Q/W − (P/W)²`,
//! without the cancellation of raw second moments far from the origin.
//! Coarser levels gather from the level below — a departure from the
//! paper, which builds every coarser level from the grid lights of the
//! first level S₁ (§3.1: "we build these levels using the grid lights of
//! the first level S₁"). [`build_with`] builds the paper's too
//! ([`Coarse::FromS1`], CPU only); without shadows it measured no better
//! (`benches/lgh_bias.rs`: −9.4 % against the cascade's −7.4 % on
//! `vpl_atrium_points` at α = 1, −1.03 % against −1.15 % on `lights_1m`),
//! so the GPU keeps the cascade. In the cascade a
//! grid light of level ℓ − 1 with centre
//! `y` is scattered like a light at `y` into level ℓ, its moments moved
//! to the new vertex exactly (`P' = P + WΔ`, `Q' = Q + 2ΔP + WΔ²`,
//! `Δ = v_old − v_new`), so each level carries all the light and every
//! level's first and second moments are those of the original lights
//! scattered through the levels below. A vertex with `W = 0` holds no
//! grid light (compaction: [`Lgh::index`] maps vertices to grid lights).
//!
//! # Shading (paper §3.2–3.3)
//!
//! A grid light emits `I(ω) = e·(iso/W + max(0, (N/W)·ω))`: exact for one
//! point light or one VPL, and for VPLs sharing a normal. Its
//! contribution at shading point x with shading normal n is
//! `f = B_ℓ(d)·I(ω)·cosθ_x / (max(d², clamp²) + (c·R)²)`, and 0 for ω
//! behind the geometric surface (as every sampler's `cos_reflect`; until
//! issue 51 the grid hierarchy alone counted such light on smooth-shaded
//! meshes) (`clamp` = the
//! VPL clamp; `c·R` the paper's clamp, `c` = `lgh_clamp`, 0.01 by default
//! as in its demo, R the radius of the lights' bounding cube); the
//! original lights of `S_0` use the integrand's own light model. The blending functions (the paper's
//! demo; a partition of unity over the levels used for any d), with
//! `r_ℓ = α·h_ℓ`:
//!
//! * rising: 0 below `r_ℓ/2`, `2d/r_ℓ − 1` up to `r_ℓ`, then 1 — except
//!   the finest level used (`S_0` with `lgh_level0`, else `S_1`), 1 from 0;
//! * falling: 1 up to `r_ℓ`, `2 − d/r_ℓ` up to `2r_ℓ`, then 0 — except the
//!   top level, 1 to infinity;
//! * `B_ℓ = rising · falling` (the two ramps never overlap, and the fall
//!   of ℓ and the rise of ℓ + 1 share [r_ℓ, 2r_ℓ]).
//!
//! The shading point visits, level by level, the vertices whose grid light
//! can lie within `2r_ℓ` (a light sits within one cell of its vertex:
//! `|v − x| < 2r_ℓ + h_ℓ` per axis, all 8 at the top level) and, for
//! `S_0`, the lights of the level-1 cells within `2r_0 = α·h_1` (per
//! axis, then each cell's box within that distance, so that a point far
//! from the lights' bounds reads none).
//! `U = Σ f` (RGB) and `F = Σ ‖f‖` (luminance) are summed in that order.
//!
//! Shadows: `S` shadow samples (`lgh_shadows`) pick candidates with
//! probability `‖f_i‖/F` by inverting the running sum at the stratified
//! targets `F·(k + ξ)/S` in a second visit of the same candidates (one
//! random number for all S, no reservoir and no race: the paper's
//! streaming picks give the same probabilities, Appendix A). Each picked
//! grid light's shadow ray ends at its centre jittered uniformly in the box
//! `±√3·σ` (the box of its position variance; the demo draws a raised
//! cosine). The estimate is `(F/S)·Σ_k (f_k/‖f_k‖)·V_k`: the shadow
//! ratio estimator `U·(1/S)Σ V_k` when all lights share one colour, and
//! unbiased for the LGH model `Σ_i f_i·E[V_i]` with coloured lights too.
//! `S = 0` gives the unshadowed `U`.

use super::{luminance, LightPrim, KIND_TRIANGLE, KIND_VPL};
use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// The GPU build of the grid hierarchy.
pub mod gpu;

/// Most levels `lgh_levels` may ask for.
pub const MAX_LEVELS: u32 = 10;
/// Most levels the default picks.
pub const MAX_AUTO_LEVELS: u32 = 8;
/// Largest α `lgh_alpha` may ask for (beyond it every level spans the
/// scene many times over: use `lgh_level0` with a large α for the exact
/// sum).
pub const MAX_ALPHA: f32 = 1024.0;
/// Most shadow samples per evaluation.
pub const MAX_SHADOW_SAMPLES: u32 = 16;
/// [`Lgh::index`] of a vertex without a grid light.
pub const EMPTY: u32 = u32::MAX;

/// The `[integrand]` keys of the `lgh` sampler.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LghParams {
    /// `L`, the number of grid levels (0: the default, module docs).
    pub levels: u32,
    /// α of the blending radii `r_ℓ = α·h_ℓ` (paper default 1).
    pub alpha: f32,
    /// Whether the original lights are level 0 (the paper's results start
    /// at `S_1`, §4.1).
    pub level0: bool,
    /// Shadow samples per evaluation (0: unshadowed).
    pub shadow_samples: u32,
    /// The paper's distance clamp of grid lights, as a fraction c of the
    /// radius R of the lights' bounding cube: `1/(d² + (c·R)²)` (its demo:
    /// 0.01 of the scene radius). Original lights (level 0) keep the
    /// integrand's own model.
    pub clamp: f32,
}

impl Default for LghParams {
    fn default() -> Self {
        LghParams {
            levels: 0,
            alpha: 1.0,
            level0: false,
            shadow_samples: 4,
            clamp: 0.01,
        }
    }
}

/// One grid light: sums over the lights it represents (module docs),
/// 64 bytes (`GridLight` in `wgsl/lights/lgh.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GridLight {
    /// Σ w·I, RGB.
    pub e: [f32; 3],
    /// W = Σ ω, ω = w·‖I‖.
    pub w: f32,
    /// Σ ω·(p − v).
    pub p: [f32; 3],
    /// Σ ω over point lights.
    pub iso: f32,
    /// Σ ω·(p − v)², per axis.
    pub q: [f32; 3],
    /// Linear index of its vertex in its level (x fastest).
    pub vertex: u32,
    /// Σ ω·n over VPLs.
    pub n: [f32; 3],
    /// Its level, 1..=L.
    pub level: u32,
}

/// A grid light (or an original light) as shading sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    /// Illumination centre.
    pub pos: Vec3,
    /// Standard deviation of the centre per axis (0 for an original light).
    pub sigma: Vec3,
    /// RGB intensity scale `e`.
    pub e: Vec3,
    /// Isotropic share `iso/W`.
    pub iso: f32,
    /// Mean normal `N/W` (length ≤ 1).
    pub n: Vec3,
    /// `clamp²` of the distance (0: none).
    pub clamp2: f32,
    /// The grid lights' additive clamp `(c·R)²` (0 for an original light).
    pub soft2: f32,
}

impl Emitter {
    /// An original point light or VPL (`clamp2` applies to VPLs).
    pub fn light(l: &LightPrim, clamp2: f32) -> Emitter {
        let vpl = l.kind == KIND_VPL;
        Emitter {
            pos: Vec3::from(l.p0),
            sigma: Vec3::ZERO,
            e: Vec3::from(l.emission),
            iso: if vpl { 0.0 } else { 1.0 },
            n: if vpl { Vec3::from(l.p1) } else { Vec3::ZERO },
            clamp2: if vpl { clamp2 } else { 0.0 },
            soft2: 0.0,
        }
    }

    /// `I(ω)·cosθ_x / (max(d², clamp²) + soft²)` at `x` with unit normal
    /// `n` (no blending weight), on a flat surface: [`Emitter::eval_shaded`]
    /// with the geometric normal `n` too.
    pub fn eval(&self, x: Vec3, n: Vec3) -> Vec3 {
        self.eval_shaded(x, n, n)
    }

    /// `I(ω)·cosθ_x / (max(d², clamp²) + soft²)` at `x` with unit shading
    /// normal `n`, and 0 for light from behind the unit geometric normal
    /// `ng` (as every other sampler's `cos_reflect`: light cannot pass
    /// through the surface): the WGSL `lgh_emitter_eval`.
    pub fn eval_shaded(&self, x: Vec3, n: Vec3, ng: Vec3) -> Vec3 {
        let to = self.pos - x;
        let d2 = to.dot(to);
        if !positive(d2) {
            return Vec3::ZERO;
        }
        let wi = to / d2.sqrt();
        let cos_x = n.dot(wi);
        if cos_x <= 0.0 || ng.dot(wi) <= 0.0 {
            return Vec3::ZERO;
        }
        let lobe = self.iso + (-self.n.dot(wi)).max(0.0);
        if !positive(lobe) {
            return Vec3::ZERO;
        }
        self.e * (lobe * cos_x / (d2.max(self.clamp2) + self.soft2))
    }
}

/// The geometry of the levels (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LghGrid {
    /// Minimum corner of the lights' bounds (vertex 0 of every level).
    pub lo: Vec3,
    /// L.
    pub levels: u32,
    /// h_1.
    pub h1: f32,
    /// 1/h_1 (correctly rounded once; the other levels scale it exactly).
    pub inv_h1: f32,
}

impl LghGrid {
    /// The default level count for `n` lights (module docs).
    pub fn auto_levels(n: usize) -> u32 {
        let half = (n / 2).max(1) as u64;
        let mut l = 1;
        while l < MAX_AUTO_LEVELS && 8u64.pow(l) <= half {
            l += 1;
        }
        l
    }

    /// The grid over the points and VPLs of `prims` (emissive triangles are
    /// not grid lights) with `levels` levels (0: [`Self::auto_levels`] of
    /// their count).
    pub fn new(prims: &[LightPrim], levels: u32) -> Result<LghGrid> {
        if levels > MAX_LEVELS {
            bail!("lgh_levels = {levels} exceeds {MAX_LEVELS}");
        }
        let grid_lights = prims.iter().filter(|l| l.kind != KIND_TRIANGLE);
        let levels = if levels == 0 {
            Self::auto_levels(grid_lights.clone().count())
        } else {
            levels
        };
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        let mut any = false;
        for l in grid_lights {
            any = true;
            let p = Vec3::from(l.p0);
            if !p.is_finite() {
                bail!("a light position is not finite: {p}");
            }
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if !any {
            lo = Vec3::ZERO;
            hi = Vec3::ZERO;
        }
        let extent = (hi - lo).max_element();
        let top = if extent > 0.0 { extent } else { 1.0 };
        let scale = (1u32 << (levels - 1)) as f32;
        Ok(LghGrid {
            lo,
            levels,
            h1: top / scale,
            inv_h1: (1.0 / top) * scale,
        })
    }

    /// Level-1 cells per axis, `2^(L−1)`.
    pub fn cells(&self) -> u32 {
        1 << (self.levels - 1)
    }

    /// Vertices per axis of level ℓ ≥ 1, `2^(L−ℓ) + 1`.
    pub fn res(&self, level: u32) -> u32 {
        (1 << (self.levels - level)) + 1
    }

    /// `2^e` for |e| < 64.
    fn pow2(e: i32) -> f32 {
        f32::from_bits(((127 + e) as u32) << 23)
    }

    /// h_ℓ (h_0 = h_1/2).
    pub fn h(&self, level: u32) -> f32 {
        self.h1 * Self::pow2(level as i32 - 1)
    }

    /// 1/h_ℓ, ℓ ≥ 1.
    pub fn inv_h(&self, level: u32) -> f32 {
        self.inv_h1 * Self::pow2(1 - level as i32)
    }

    /// First [`Lgh::index`] entry of level ℓ ≥ 1.
    pub fn index_offset(&self, level: u32) -> u64 {
        (1..level).map(|m| (self.res(m) as u64).pow(3)).sum()
    }

    /// Entries of the vertex index over all levels.
    pub fn index_len(&self) -> u64 {
        self.index_offset(self.levels + 1)
    }

    /// Linear index of vertex `v` of level ℓ (x fastest).
    pub fn vertex_index(&self, level: u32, v: [u32; 3]) -> u32 {
        let r = self.res(level);
        v[0] + r * (v[1] + r * v[2])
    }

    /// World position of vertex `v` of level ℓ: `lo + v·h_ℓ`.
    pub fn vertex_pos(&self, level: u32, v: [u32; 3]) -> Vec3 {
        let h = self.h(level);
        self.lo + Vec3::new(v[0] as f32 * h, v[1] as f32 * h, v[2] as f32 * h)
    }

    /// The cell of level ℓ ≥ 1 holding `p` and `p`'s fraction in it
    /// (module docs).
    pub fn cell_of(&self, level: u32, p: Vec3) -> ([u32; 3], Vec3) {
        let q = (p - self.lo) * self.inv_h(level);
        let last = (self.res(level) - 2) as f32;
        let c = q.floor().clamp(Vec3::ZERO, Vec3::splat(last));
        let t = (q - c).clamp(Vec3::ZERO, Vec3::ONE);
        ([c.x as u32, c.y as u32, c.z as u32], t)
    }

    /// The weight of the vertex `c + δ` (δ = bits x, y, z) of a point with
    /// fraction `t` in cell `c`.
    pub fn trilinear(t: Vec3, delta: u32) -> f32 {
        let a = |bit: u32, t: f32| if delta & bit != 0 { t } else { 1.0 - t };
        a(1, t.x) * a(2, t.y) * a(4, t.z)
    }

    /// The grid lights' additive distance clamp `(c·R)²`, R = √3/2·h_top
    /// the radius of the lights' bounding cube.
    pub fn soft2(&self, clamp: f32) -> f32 {
        let r = clamp * 0.866_025_4 * self.h(self.levels);
        r * r
    }

    /// The blending weight of level ℓ at distance `d` (module docs);
    /// `first` is the finest level used.
    pub fn blend(&self, alpha: f32, first: u32, level: u32, d: f32) -> f32 {
        let r = alpha * self.h(level);
        let rise = if level == first || d >= r {
            1.0
        } else if d < 0.5 * r {
            0.0
        } else {
            2.0 * d / r - 1.0
        };
        let fall = if level == self.levels || d <= r {
            1.0
        } else if d >= 2.0 * r {
            0.0
        } else {
            2.0 - d / r
        };
        rise * fall
    }
}

impl GridLight {
    /// Adds a light at `p` (its vertex at `v`) with trilinear weight `w`.
    fn add_light(&mut self, w: f32, l: &LightPrim, v: Vec3) {
        let i = Vec3::from(l.emission);
        let omega = w * luminance(i);
        let d = Vec3::from(l.p0) - v;
        self.e = (Vec3::from(self.e) + w * i).into();
        self.w += omega;
        self.p = (Vec3::from(self.p) + omega * d).into();
        self.q = (Vec3::from(self.q) + omega * (d * d)).into();
        if l.kind == KIND_VPL {
            self.n = (Vec3::from(self.n) + omega * Vec3::from(l.p1)).into();
        } else {
            self.iso += omega;
        }
    }

    /// Adds grid light `g` with weight `w`, its moments moved by
    /// `delta = v_g − v_self`.
    fn add_grid(&mut self, w: f32, g: &GridLight, delta: Vec3) {
        let (gp, gq) = (Vec3::from(g.p), Vec3::from(g.q));
        let p = gp + g.w * delta;
        let q = gq + 2.0 * delta * gp + g.w * (delta * delta);
        self.e = (Vec3::from(self.e) + w * Vec3::from(g.e)).into();
        self.w += w * g.w;
        self.p = (Vec3::from(self.p) + w * p).into();
        self.q = (Vec3::from(self.q) + w * q).into();
        self.n = (Vec3::from(self.n) + w * Vec3::from(g.n)).into();
        self.iso += w * g.iso;
    }

    /// Its illumination centre, its vertex at `v`.
    pub fn centre(&self, v: Vec3) -> Vec3 {
        v + Vec3::from(self.p) / self.w
    }

    /// The grid light as shading sees it, its vertex at `v`, with the
    /// VPL clamp² and the grid's additive clamp² ([`LghGrid::soft2`]).
    pub fn emitter(&self, v: Vec3, clamp2: f32, soft2: f32) -> Emitter {
        let m = Vec3::from(self.p) / self.w;
        let var = (Vec3::from(self.q) / self.w - m * m).max(Vec3::ZERO);
        Emitter {
            pos: v + m,
            sigma: Vec3::new(var.x.sqrt(), var.y.sqrt(), var.z.sqrt()),
            e: Vec3::from(self.e),
            iso: self.iso / self.w,
            n: Vec3::from(self.n) / self.w,
            clamp2,
            soft2,
        }
    }
}

/// A built hierarchy (the GPU's buffers, in the oracle's order).
#[derive(Clone, Debug)]
pub struct Lgh {
    pub grid: LghGrid,
    /// Grid lights, level by level, vertices in linear order (the GPU
    /// compacts in the order its threads finish: compare through `index`).
    pub lights: Vec<GridLight>,
    /// Per level ℓ ≥ 1 from [`LghGrid::index_offset`]: the grid light of
    /// each vertex, or [`EMPTY`].
    pub index: Vec<u32>,
    /// Per level-1 cell (linear, x fastest): [start, end) in `sorted`.
    pub cells: Vec<[u32; 2]>,
    /// Light ids sorted by (level-1 cell, id), dark lights included, then
    /// the emissive triangles by id (they are in no cell).
    pub sorted: Vec<u32>,
}

/// Iterates `[lo, hi]³` z-major (x fastest), as the kernels do.
fn for_box(lo: [u32; 3], hi: [u32; 3], mut f: impl FnMut([u32; 3])) {
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                f([x, y, z]);
            }
        }
    }
}

/// How the levels above S₁ are gathered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coarse {
    /// Each level from the one below (what the GPU builds; module docs).
    Cascade,
    /// Every level from S₁'s grid lights, as the paper builds them (§3.1:
    /// "we build these levels using the grid lights of the first level
    /// S₁"); on the CPU only, for measurement (`benches/lgh_bias.rs`).
    FromS1,
}

/// Builds the hierarchy over `prims` with `levels` levels (0: default).
pub fn build(prims: &[LightPrim], levels: u32) -> Result<Lgh> {
    build_with(prims, levels, Coarse::Cascade)
}

/// [`build`] with the coarse levels gathered as `coarse` says. Level 2 is
/// the same either way (S₁ is the level below it).
pub fn build_with(prims: &[LightPrim], levels: u32, coarse: Coarse) -> Result<Lgh> {
    let grid = LghGrid::new(prims, levels)?;
    let c = grid.cells();
    let cell_key = |l: &LightPrim| {
        if l.kind == KIND_TRIANGLE {
            return c * c * c;
        }
        let (cell, _) = grid.cell_of(1, Vec3::from(l.p0));
        cell[0] + c * (cell[1] + c * cell[2])
    };
    let mut sorted: Vec<u32> = (0..prims.len() as u32).collect();
    sorted.sort_by_key(|&i| (cell_key(&prims[i as usize]), i));
    let mut cells = vec![[0u32; 2]; (c as usize).pow(3)];
    for (s, &i) in sorted.iter().enumerate() {
        let k = cell_key(&prims[i as usize]) as usize;
        if k == cells.len() {
            break;
        }
        if cells[k][1] == 0 {
            cells[k][0] = s as u32;
        }
        cells[k][1] = s as u32 + 1;
    }
    let mut index = vec![EMPTY; grid.index_len() as usize];
    let mut lights = Vec::new();
    // Level 1: each vertex gathers from its 8 cells.
    let r1 = grid.res(1);
    for_box([0; 3], [r1 - 1; 3], |v| {
        let vpos = grid.vertex_pos(1, v);
        let mut acc = GridLight::default();
        for delta in 0..8u32 {
            let d = [delta & 1, (delta >> 1) & 1, (delta >> 2) & 1];
            if (0..3).any(|a| v[a] < d[a] || v[a] - d[a] >= c) {
                continue;
            }
            let cell = [v[0] - d[0], v[1] - d[1], v[2] - d[2]];
            let [start, end] = cells[(cell[0] + c * (cell[1] + c * cell[2])) as usize];
            for &i in &sorted[start as usize..end as usize] {
                let l = &prims[i as usize];
                if !positive(l.intensity()) {
                    continue;
                }
                let (_, t) = grid.cell_of(1, Vec3::from(l.p0));
                acc.add_light(LghGrid::trilinear(t, delta), l, vpos);
            }
        }
        push(&grid, 1, v, acc, &mut lights, &mut index);
    });
    // Coarser levels gather from the level below (or from S₁): a grid
    // light of level `from` centred in one of vertex v's 8 cells lies at
    // most one fine cell beyond them.
    for level in 2..=grid.levels {
        let from = match coarse {
            Coarse::Cascade => level - 1,
            Coarse::FromS1 => 1,
        };
        let s = 1u32 << (level - from);
        let r = grid.res(level);
        let fine = grid.res(from);
        let fine_off = grid.index_offset(from) as usize;
        for_box([0; 3], [r - 1; 3], |v| {
            let vpos = grid.vertex_pos(level, v);
            let mut acc = GridLight::default();
            let lo = v.map(|x| (s * x).saturating_sub(s + 1));
            let hi = v.map(|x| (s * x + s + 1).min(fine - 1));
            for_box(lo, hi, |u| {
                let slot = index[fine_off + grid.vertex_index(from, u) as usize];
                if slot == EMPTY {
                    return;
                }
                let g = lights[slot as usize];
                let upos = grid.vertex_pos(from, u);
                let (cell, t) = grid.cell_of(level, g.centre(upos));
                let d = [0, 1, 2].map(|a| v[a].wrapping_sub(cell[a]));
                if d.iter().any(|&x| x > 1) {
                    return;
                }
                let delta = d[0] | (d[1] << 1) | (d[2] << 2);
                acc.add_grid(LghGrid::trilinear(t, delta), &g, upos - vpos);
            });
            push(&grid, level, v, acc, &mut lights, &mut index);
        });
    }
    Ok(Lgh {
        grid,
        lights,
        index,
        cells,
        sorted,
    })
}

/// Stores `acc` as vertex `v`'s grid light when it holds light.
fn push(
    grid: &LghGrid,
    level: u32,
    v: [u32; 3],
    mut acc: GridLight,
    lights: &mut Vec<GridLight>,
    index: &mut [u32],
) {
    let at = grid.index_offset(level) as usize + grid.vertex_index(level, v) as usize;
    if acc.w > 0.0 {
        acc.vertex = grid.vertex_index(level, v);
        acc.level = level;
        index[at] = lights.len() as u32;
        lights.push(acc);
    }
}

/// One light a shading point sums over: its contribution `f` (blending
/// weight included), `‖f‖`, and where its shadow ray ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    pub f: Vec3,
    pub lum: f32,
    pub pos: Vec3,
    pub sigma: Vec3,
    /// Level (0: an original light) and grid light or light id.
    pub level: u32,
    pub id: u32,
}

impl Lgh {
    /// The grid light of vertex `v` of level ℓ ≥ 1, if any.
    pub fn light_at(&self, level: u32, v: [u32; 3]) -> Option<&GridLight> {
        let at = self.grid.index_offset(level) + self.grid.vertex_index(level, v) as u64;
        match self.index[at as usize] {
            EMPTY => None,
            slot => Some(&self.lights[slot as usize]),
        }
    }

    /// The candidates with `‖f‖ > 0` of shading point `x` (unit normal
    /// `n`) in visiting order (module docs); `prims` are the lights built
    /// from (level 0), `clamp2` the VPL clamp². On a flat surface: see
    /// [`Lgh::candidates_shaded`].
    pub fn candidates(
        &self,
        prims: &[LightPrim],
        params: &LghParams,
        clamp2: f32,
        x: Vec3,
        n: Vec3,
    ) -> Vec<Candidate> {
        self.candidates_shaded(prims, params, clamp2, x, n, n)
    }

    /// [`Lgh::candidates`] at a point with unit shading normal `n` and
    /// unit geometric normal `ng` ([`Emitter::eval_shaded`]).
    pub fn candidates_shaded(
        &self,
        prims: &[LightPrim],
        params: &LghParams,
        clamp2: f32,
        x: Vec3,
        n: Vec3,
        ng: Vec3,
    ) -> Vec<Candidate> {
        let g = &self.grid;
        let first = if params.level0 { 0 } else { 1 };
        let soft2 = g.soft2(params.clamp);
        let mut out = Vec::new();
        let mut visit = |level: u32, id: u32, e: Emitter| {
            let d = (e.pos - x).length();
            let b = g.blend(params.alpha, first, level, d);
            if !positive(b) {
                return;
            }
            let f = b * e.eval_shaded(x, n, ng);
            let lum = luminance(f);
            if lum > 0.0 {
                out.push(Candidate {
                    f,
                    lum,
                    pos: e.pos,
                    sigma: e.sigma,
                    level,
                    id,
                });
            }
        };
        if params.level0 {
            let c = g.cells();
            let q = (x - g.lo) * g.inv_h1;
            let range = |a: f32| {
                let last = (c - 1) as f32;
                let lo = (a - params.alpha).floor().clamp(0.0, last) as u32;
                let hi = (a + params.alpha).floor().clamp(0.0, last) as u32;
                (lo, hi)
            };
            let (rx, ry, rz) = (range(q.x), range(q.y), range(q.z));
            // A cell farther than 2r_0 = α·h_1 holds no light with B_0 > 0
            // (1.001: the distances' rounding): skipped, as the WGSL does.
            let reach0 = 1.001 * params.alpha * g.h1;
            for_box([rx.0, ry.0, rz.0], [rx.1, ry.1, rz.1], |cell| {
                let box_lo =
                    g.lo + Vec3::new(cell[0] as f32, cell[1] as f32, cell[2] as f32) * g.h1;
                let gap = (box_lo - x)
                    .max(x - (box_lo + Vec3::splat(g.h1)))
                    .max(Vec3::ZERO);
                if gap.length() >= reach0 {
                    return;
                }
                let [start, end] = self.cells[(cell[0] + c * (cell[1] + c * cell[2])) as usize];
                for &i in &self.sorted[start as usize..end as usize] {
                    visit(0, i, Emitter::light(&prims[i as usize], clamp2));
                }
            });
        }
        for level in 1..=g.levels {
            let r = g.res(level);
            let (lo, hi) = if level == g.levels {
                ([0; 3], [r - 1; 3])
            } else {
                let q = (x - g.lo) * g.inv_h(level);
                let reach = 2.0 * params.alpha + 1.0;
                let last = (r - 1) as f32;
                let lo = (q - reach).floor().clamp(Vec3::ZERO, Vec3::splat(last));
                let hi = (q + reach).floor().clamp(Vec3::ZERO, Vec3::splat(last));
                (
                    [lo.x as u32, lo.y as u32, lo.z as u32],
                    [hi.x as u32, hi.y as u32, hi.z as u32],
                )
            };
            for_box(lo, hi, |v| {
                let at = g.index_offset(level) + g.vertex_index(level, v) as u64;
                let slot = self.index[at as usize];
                if slot != EMPTY {
                    let e =
                        self.lights[slot as usize].emitter(g.vertex_pos(level, v), clamp2, soft2);
                    visit(level, slot, e);
                }
            });
        }
        out
    }
}

/// The `s` shadow-sample picks (indices into `candidates`) for the
/// stratification offset `xi ∈ [0, 1)`: the candidates whose running sum of
/// `‖f‖` first exceeds `F·(k + ξ)/s`, k = 0…s−1 (module docs). Empty when
/// there is no candidate.
pub fn pick(candidates: &[Candidate], s: u32, xi: f32) -> Vec<usize> {
    let total: f32 = candidates.iter().fold(0.0, |a, c| a + c.lum);
    let mut picks = Vec::with_capacity(s as usize);
    if candidates.is_empty() || !positive(total) {
        return picks;
    }
    let mut cum = 0.0f32;
    for (i, c) in candidates.iter().enumerate() {
        cum += c.lum;
        while (picks.len() as u32) < s && total * ((picks.len() as f32 + xi) / s as f32) < cum {
            picks.push(i);
        }
    }
    // Rounding can leave the last targets beyond the running sum.
    while (picks.len() as u32) < s {
        picks.push(candidates.len() - 1);
    }
    picks
}

/// `x > 0` (false for NaN).
fn positive(x: f32) -> bool {
    x > 0.0
}

#[cfg(test)]
mod tests;
