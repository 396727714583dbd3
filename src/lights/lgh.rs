//! The lighting grid hierarchy (Lin & Yuksel 2019,
//! `shared/papers/lighting-grid-hierarchy.txt`, after Yuksel & Yuksel
//! 2017): many point lights and VPLs replaced by grid lights at doubling
//! cell sizes, the levels blended by distance, shadows estimated with a
//! few stochastic shadow rays. This module is the CPU oracle of the GPU
//! build ([`super::gpu_lgh`], `wgsl/lights/lgh_build.wgsl`) and of the
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
//! the first level S₁"; issue 49 item 2, its effect not measured yet): a
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
//! contribution at shading point x with normal n is
//! `f = B_ℓ(d)·I(ω)·cosθ_x / (max(d², clamp²) + (c·R)²)` (`clamp` = the
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
//! `S_0`, the lights of the level-1 cells within `2r_0 = α·h_1`.
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
    /// `n` (no blending weight): the WGSL `lgh_emitter_eval`.
    pub fn eval(&self, x: Vec3, n: Vec3) -> Vec3 {
        let to = self.pos - x;
        let d2 = to.dot(to);
        if !positive(d2) {
            return Vec3::ZERO;
        }
        let wi = to / d2.sqrt();
        let cos_x = n.dot(wi);
        if cos_x <= 0.0 {
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

/// Builds the hierarchy over `prims` with `levels` levels (0: default).
pub fn build(prims: &[LightPrim], levels: u32) -> Result<Lgh> {
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
    // Coarser levels gather from the level below.
    for level in 2..=grid.levels {
        let r = grid.res(level);
        let fine = grid.res(level - 1);
        let fine_off = grid.index_offset(level - 1) as usize;
        for_box([0; 3], [r - 1; 3], |v| {
            let vpos = grid.vertex_pos(level, v);
            let mut acc = GridLight::default();
            let lo = v.map(|x| (2 * x).saturating_sub(3));
            let hi = v.map(|x| (2 * x + 3).min(fine - 1));
            for_box(lo, hi, |u| {
                let slot = index[fine_off + grid.vertex_index(level - 1, u) as usize];
                if slot == EMPTY {
                    return;
                }
                let g = lights[slot as usize];
                let upos = grid.vertex_pos(level - 1, u);
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
    /// from (level 0), `clamp2` the VPL clamp².
    pub fn candidates(
        &self,
        prims: &[LightPrim],
        params: &LghParams,
        clamp2: f32,
        x: Vec3,
        n: Vec3,
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
            let f = b * e.eval(x, n);
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
            for_box([rx.0, ry.0, rz.0], [rx.1, ry.1, rz.1], |cell| {
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
mod tests {
    use super::*;

    #[test]
    fn auto_levels_follow_the_cell_budget() {
        assert_eq!(LghGrid::auto_levels(0), 1);
        assert_eq!(LghGrid::auto_levels(15), 1);
        assert_eq!(LghGrid::auto_levels(16), 2);
        assert_eq!(LghGrid::auto_levels(4096), 4);
        assert_eq!(LghGrid::auto_levels(1 << 20), 7);
        assert_eq!(LghGrid::auto_levels(usize::MAX), MAX_AUTO_LEVELS);
    }

    #[test]
    fn powers_of_two_are_exact() {
        assert_eq!(LghGrid::pow2(0), 1.0);
        assert_eq!(LghGrid::pow2(3), 8.0);
        assert_eq!(LghGrid::pow2(-2), 0.25);
    }

    /// `a` and `b` agree to a relative 1e-6 (a few f32 roundings of
    /// operands near 1).
    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() <= 1e-6 * b.abs().max_element().max(1e-30)
    }

    /// Original lights as shading sees them: a point is isotropic with no
    /// normal and no clamp (its `p1` holds its position, not a normal); a
    /// VPL keeps its normal and the VPL clamp.
    #[test]
    fn original_lights_become_emitters() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        let point = Emitter::light(&LightPrim::point(p, Vec3::new(1.0, 2.0, 3.0)), 0.25);
        assert_eq!(
            point,
            Emitter {
                pos: p,
                sigma: Vec3::ZERO,
                e: Vec3::new(1.0, 2.0, 3.0),
                iso: 1.0,
                n: Vec3::ZERO,
                clamp2: 0.0,
                soft2: 0.0,
            }
        );
        let vpl = Emitter::light(&LightPrim::vpl(p, Vec3::Z, Vec3::ONE), 0.25);
        assert_eq!(
            (vpl.iso, vpl.n, vpl.clamp2, vpl.soft2),
            (0.0, Vec3::Z, 0.25, 0.0)
        );
    }

    /// `I(ω)·cosθ_x / (max(d², clamp²) + soft²)` worked by hand: an
    /// emitter 2 above the shading point (d² = 4, ω toward it = +z).
    #[test]
    fn emitter_eval_known_answers() {
        let e = Vec3::new(1.0, 2.0, 3.0);
        let at = |iso: f32, n: Vec3, clamp2: f32, soft2: f32| Emitter {
            pos: Vec3::new(0.0, 0.0, 2.0),
            sigma: Vec3::ZERO,
            e,
            iso,
            n,
            clamp2,
            soft2,
        };
        let point = at(1.0, Vec3::ZERO, 0.0, 0.0);
        assert_eq!(point.eval(Vec3::ZERO, Vec3::Z), e / 4.0);
        // A receiver tilted to cos θ_x = 0.8; one facing away sees nothing.
        let tilted = Vec3::new(0.6, 0.0, 0.8);
        assert!(close(point.eval(Vec3::ZERO, tilted), e * 0.2));
        assert_eq!(point.eval(Vec3::ZERO, -Vec3::Z), Vec3::ZERO);
        assert_eq!(point.eval(Vec3::ZERO, Vec3::X), Vec3::ZERO);
        // The clamp replaces d² when larger; soft² always adds.
        assert!(close(
            at(1.0, Vec3::ZERO, 9.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
            e / 9.0
        ));
        assert_eq!(
            at(1.0, Vec3::ZERO, 1.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
            e / 4.0
        );
        assert_eq!(
            at(1.0, Vec3::ZERO, 0.0, 4.0).eval(Vec3::ZERO, Vec3::Z),
            e / 8.0
        );
        assert_eq!(
            at(1.0, Vec3::ZERO, 12.0, 4.0).eval(Vec3::ZERO, Vec3::Z),
            e / 16.0
        );
        // A cosine lobe about n: facing the point (1), tilted (0.8), away (0).
        assert_eq!(
            at(0.0, -Vec3::Z, 0.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
            e / 4.0
        );
        let lobe = at(0.0, Vec3::new(0.0, 0.6, -0.8), 0.0, 0.0);
        assert!(close(lobe.eval(Vec3::ZERO, Vec3::Z), e * 0.2));
        assert_eq!(
            at(0.0, Vec3::Z, 0.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
            Vec3::ZERO
        );
        // A grid light's mix: iso/W = 1/4 plus the lobe of N/W = (0, 0, −1/2).
        let mix = at(0.25, Vec3::new(0.0, 0.0, -0.5), 0.0, 0.0);
        assert_eq!(mix.eval(Vec3::ZERO, Vec3::Z), e * (0.75 / 4.0));
        // On the light (d = 0) and with a NaN lobe: zero, not NaN.
        assert_eq!(point.eval(point.pos, Vec3::Z), Vec3::ZERO);
        assert_eq!(
            at(f32::NAN, Vec3::ZERO, 0.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
            Vec3::ZERO
        );
    }

    /// The levels of a grid over lights spanning (4, 1, 1) from (1, 2, 3)
    /// with L = 3, worked by hand: h_1 = 4/4 = 1, h_0 = 1/2, h_3 = 4.
    #[test]
    fn grid_geometry_known_answers() {
        let prims = [
            LightPrim::point(Vec3::new(1.0, 2.0, 3.0), Vec3::ONE),
            LightPrim::point(Vec3::new(5.0, 3.0, 4.0), Vec3::ONE),
            // Triangles are not grid lights: it widens nothing.
            LightPrim::triangle(Vec3::splat(-50.0), Vec3::splat(60.0), Vec3::X, Vec3::ONE),
        ];
        let g = LghGrid::new(&prims, 3).unwrap();
        assert_eq!(
            g,
            LghGrid {
                lo: Vec3::new(1.0, 2.0, 3.0),
                levels: 3,
                h1: 1.0,
                inv_h1: 1.0,
            }
        );
        assert_eq!(g.cells(), 4);
        assert_eq!([g.res(1), g.res(2), g.res(3)], [5, 3, 2]);
        assert_eq!([g.h(0), g.h(1), g.h(2), g.h(3)], [0.5, 1.0, 2.0, 4.0]);
        assert_eq!([g.inv_h(1), g.inv_h(2), g.inv_h(3)], [1.0, 0.5, 0.25]);
        assert_eq!(
            [g.index_offset(1), g.index_offset(2), g.index_offset(3)],
            [0, 125, 152]
        );
        assert_eq!(g.index_len(), 160);
        assert_eq!(g.vertex_index(1, [1, 2, 3]), 1 + 5 * (2 + 5 * 3));
        assert_eq!(g.vertex_index(2, [2, 1, 0]), 5);
        assert_eq!(g.vertex_pos(2, [1, 0, 1]), Vec3::new(3.0, 2.0, 5.0));
        assert_eq!(g.vertex_pos(1, [0, 3, 2]), Vec3::new(1.0, 5.0, 5.0));
        assert_eq!(g.vertex_pos(2, [2, 1, 2]), Vec3::new(5.0, 4.0, 7.0));
        // Cells and fractions; the last cell is clamped and takes t = 1
        // on its far side, points outside clamp to the border.
        let cell = |level, p| g.cell_of(level, p);
        assert_eq!(
            cell(1, Vec3::new(2.5, 2.25, 3.0)),
            ([1, 0, 0], Vec3::new(0.5, 0.25, 0.0))
        );
        assert_eq!(
            cell(1, Vec3::new(5.0, 3.0, 4.0)),
            ([3, 1, 1], Vec3::new(1.0, 0.0, 0.0))
        );
        assert_eq!(cell(1, Vec3::new(0.0, 2.0, 3.0)), ([0, 0, 0], Vec3::ZERO));
        assert_eq!(cell(1, Vec3::new(9.0, 2.0, 3.0)), ([3, 0, 0], Vec3::X));
        assert_eq!(
            cell(3, Vec3::new(5.0, 3.0, 4.0)),
            ([0, 0, 0], Vec3::new(1.0, 0.25, 0.25))
        );
        assert_eq!(
            cell(2, Vec3::new(4.0, 3.0, 4.0)),
            ([1, 0, 0], Vec3::new(0.5, 0.5, 0.5))
        );

        // A span that is no power of two: 1/h_1 is rounded once.
        let g = LghGrid::new(&prims[..2], 2).unwrap();
        assert_eq!((g.h1, g.inv_h1), (2.0, 0.5));
        let three = [
            LightPrim::vpl(Vec3::ZERO, Vec3::Z, Vec3::ONE),
            LightPrim::vpl(Vec3::new(0.0, 3.0, 0.0), Vec3::Z, Vec3::ONE),
        ];
        let g = LghGrid::new(&three, 2).unwrap();
        assert_eq!((g.h1, g.inv_h1), (1.5, (1.0f32 / 3.0) * 2.0));
        // Coincident lights span 1 from their position; without grid
        // lights the grid sits at the origin.
        let g = LghGrid::new(&prims[1..2], 1).unwrap();
        assert_eq!((g.lo, g.h1, g.inv_h1), (Vec3::new(5.0, 3.0, 4.0), 1.0, 1.0));
        let g = LghGrid::new(&prims[2..], 4).unwrap();
        assert_eq!((g.lo, g.h1, g.inv_h1), (Vec3::ZERO, 0.125, 8.0));
        // The default level count, and what is refused.
        assert_eq!(LghGrid::new(&prims, 0).unwrap().levels, 1);
        assert!(LghGrid::new(&prims, MAX_LEVELS).is_ok());
        assert!(LghGrid::new(&prims, MAX_LEVELS + 1).is_err());
        let nan = LightPrim::point(Vec3::new(0.0, f32::NAN, 0.0), Vec3::ONE);
        assert!(LghGrid::new(&[prims[0], nan], 2).is_err());
    }

    /// Trilinear weights at t = (1/4, 3/8, 3/4), exact in f32.
    #[test]
    fn trilinear_known_answers() {
        let t = Vec3::new(0.25, 0.375, 0.75);
        let want = [
            0.75 * 0.625 * 0.25,
            0.25 * 0.625 * 0.25,
            0.75 * 0.375 * 0.25,
            0.25 * 0.375 * 0.25,
            0.75 * 0.625 * 0.75,
            0.25 * 0.625 * 0.75,
            0.75 * 0.375 * 0.75,
            0.25 * 0.375 * 0.75,
        ];
        for (delta, w) in want.into_iter().enumerate() {
            assert_eq!(LghGrid::trilinear(t, delta as u32), w, "δ = {delta}");
        }
    }

    /// The paper's clamp `(c·R)²` with R = √3/2·h_top, against f64.
    #[test]
    fn soft_clamp_is_a_fraction_of_the_bounding_radius() {
        let g = LghGrid {
            lo: Vec3::ZERO,
            levels: 3,
            h1: 1.0,
            inv_h1: 1.0,
        };
        let want = (0.01 * 3f64.sqrt() / 2.0 * 4.0).powi(2);
        assert!((g.soft2(0.01) as f64 - want).abs() <= 1e-6 * want);
        assert_eq!(g.soft2(0.0), 0.0);
    }

    /// The blending ramps at hand-picked distances (h_1 = 1, L = 3, α = 1,
    /// so r_1 = 1, r_2 = 2, r_3 = 4; with level 0, r_0 = 1/2).
    #[test]
    fn blend_ramps_known_answers() {
        let g = LghGrid {
            lo: Vec3::ZERO,
            levels: 3,
            h1: 1.0,
            inv_h1: 1.0,
        };
        // (distance, weight) pairs of level `level` with `first` the finest.
        let ramp = |first: u32, level: u32, cases: &[(f32, f32)]| {
            for &(d, want) in cases {
                let got = g.blend(1.0, first, level, d);
                assert_eq!(got, want, "first {first}, level {level}, d = {d}");
            }
        };
        // The finest level used rises from 0; it falls over [r, 2r].
        ramp(
            1,
            1,
            &[(0.0, 1.0), (1.0, 1.0), (1.5, 0.5), (2.0, 0.0), (2.5, 0.0)],
        );
        // Level 2: 0 below r/2 = 1, rises to 1 at r = 2, falls to 0 at 4.
        ramp(
            1,
            2,
            &[(0.5, 0.0), (1.5, 0.5), (2.0, 1.0), (3.0, 0.5), (4.0, 0.0)],
        );
        // The top level rises and never falls.
        ramp(1, 3, &[(1.0, 0.0), (3.0, 0.5), (1e30, 1.0)]);
        // With level 0 first, level 1 rises too.
        ramp(0, 0, &[(0.0, 1.0), (0.625, 0.75), (1.0, 0.0)]);
        ramp(0, 1, &[(0.25, 0.0), (0.625, 0.25), (1.0, 1.0)]);
        // α scales the radii: α = 2 puts level 2's rise over [2, 4].
        assert_eq!(g.blend(2.0, 1, 2, 3.0), 0.5);
    }

    /// A grid light's sums, worked by hand: a point and a VPL added with
    /// their trilinear weights, then the sum moved to another vertex
    /// equals adding the lights there directly.
    #[test]
    fn grid_light_sums_and_moves() {
        let i = Vec3::new(1.0, 2.0, 4.0);
        let lum = luminance(i);
        let point = LightPrim::point(Vec3::new(1.0, 2.0, 3.0), i);
        let normal = Vec3::new(0.0, 0.6, 0.8);
        let vpl = LightPrim::vpl(Vec3::new(0.0, 3.0, 2.0), normal, 2.0 * i);
        let v = Vec3::new(0.0, 2.0, 2.0);
        let mut g = GridLight::default();
        g.add_light(0.5, &point, v);
        g.add_light(0.25, &vpl, v);
        // ω = 0.5·lum and 0.25·2·lum; offsets (1, 0, 1) and (0, 1, 0).
        let w = 0.5 * lum;
        assert!(close(Vec3::from(g.e), 0.5 * i + 0.5 * i));
        assert!((g.w - 2.0 * w).abs() <= 1e-6 * g.w);
        assert!(close(Vec3::from(g.p), Vec3::new(w, w, w)));
        assert!(close(Vec3::from(g.q), Vec3::new(w, w, w)));
        assert_eq!(g.iso, w);
        assert!(close(Vec3::from(g.n), w * normal));
        assert!(close(g.centre(v), v + Vec3::splat(0.5)));

        // Moved to u with weight 1/4: the same as adding the two lights at
        // u with their weights quartered.
        let u = Vec3::new(2.0, -1.0, 0.5);
        let mut moved = GridLight::default();
        moved.add_grid(0.25, &g, v - u);
        let mut direct = GridLight::default();
        direct.add_light(0.125, &point, u);
        direct.add_light(0.0625, &vpl, u);
        for (a, b) in [
            (moved.e, direct.e),
            (moved.p, direct.p),
            (moved.q, direct.q),
            (moved.n, direct.n),
        ] {
            assert!(close(Vec3::from(a), Vec3::from(b)), "{a:?} vs {b:?}");
        }
        assert!((moved.w - direct.w).abs() <= 1e-6 * direct.w);
        assert!((moved.iso - direct.iso).abs() <= 1e-6 * direct.iso);
    }

    /// A grid light as shading sees it: centre v + P/W, σ² = Q/W − (P/W)²
    /// (clamped at 0), iso/W and N/W.
    #[test]
    fn grid_light_emitter_known_answer() {
        let g = GridLight {
            e: [1.0, 2.0, 3.0],
            w: 2.0,
            p: [2.0, 0.0, 4.0],
            iso: 1.0,
            q: [4.0, 2.0, 7.0],
            vertex: 0,
            n: [0.0, 0.0, 1.0],
            level: 1,
        };
        let v = Vec3::new(1.0, 1.0, 1.0);
        assert_eq!(
            g.emitter(v, 0.5, 0.25),
            Emitter {
                pos: Vec3::new(2.0, 1.0, 3.0),
                sigma: Vec3::new(1.0, 1.0, 0.0),
                e: Vec3::new(1.0, 2.0, 3.0),
                iso: 0.5,
                n: Vec3::new(0.0, 0.0, 0.5),
                clamp2: 0.5,
                soft2: 0.25,
            }
        );
        assert_eq!(g.centre(v), Vec3::new(2.0, 1.0, 3.0));
    }

    /// The level-1 gather, vertex by vertex, against the trilinear weights
    /// worked by hand: one cell (L = 1) spanning (0, 0, 0)–(2, 2, 2), a
    /// light on each of two corners and one inside at t = (1/4, 1/2, 3/4);
    /// a dark light adds nothing.
    #[test]
    fn level_one_gathers_trilinear_weights() {
        let prims = [
            LightPrim::point(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)),
            LightPrim::point(Vec3::splat(2.0), Vec3::new(0.0, 1.0, 0.0)),
            LightPrim::point(Vec3::new(0.5, 1.0, 1.5), Vec3::new(0.0, 0.0, 8.0)),
            LightPrim::point(Vec3::new(1.0, 1.0, 1.0), Vec3::ZERO),
        ];
        let h = build(&prims, 1).unwrap();
        assert_eq!(h.grid.h1, 2.0);
        assert_eq!(h.cells, vec![[0, 4]]);
        assert_eq!(h.sorted, vec![0, 1, 2, 3]);
        let t = Vec3::new(0.25, 0.5, 0.75);
        for delta in 0..8u32 {
            let v = [delta & 1, (delta >> 1) & 1, (delta >> 2) & 1];
            let g = h.light_at(1, v).expect("every corner holds light");
            let mut e = Vec3::new(0.0, 0.0, 8.0 * LghGrid::trilinear(t, delta));
            if delta == 0 {
                e.x = 1.0;
            }
            if delta == 7 {
                e.y = 1.0;
            }
            assert_eq!(Vec3::from(g.e), e, "vertex {v:?}");
            assert_eq!(g.vertex, h.grid.vertex_index(1, v));
            assert_eq!(g.level, 1);
        }
        assert_eq!(h.lights.len(), 8);
        // Without the inner light only the two corners hold light.
        let h = build(&[prims[0], prims[1], prims[3]], 1).unwrap();
        assert_eq!(h.lights.len(), 2);
        assert_eq!(h.index.iter().filter(|&&i| i != EMPTY).count(), 2);
        assert_eq!((h.index[0], h.index[7]), (0, 1));
    }

    /// The level-2 gather, vertex by vertex: one light at (1/2, 1/4, 3/2)
    /// between dark lights fixing the bounds (0,0,0)–(2,2,2), L = 2. Every
    /// level-1 grid light is centred on the light, so level 2 (one cell of
    /// side 2) splits it with the trilinear weights of t = (1/4, 1/8, 3/4),
    /// up to the rounding of the centres P/W (relative 1e-6). No two
    /// coordinates of t are equal or 1/2, so a corner's weight names its
    /// corner (a wrong delta bit or axis changes it).
    #[test]
    fn coarse_levels_gather_at_the_centres() {
        let prims = [
            LightPrim::point(Vec3::ZERO, Vec3::ZERO),
            LightPrim::point(Vec3::new(0.5, 0.25, 1.5), Vec3::new(0.0, 0.0, 8.0)),
            LightPrim::point(Vec3::splat(2.0), Vec3::ZERO),
        ];
        let h = build(&prims, 2).unwrap();
        assert_eq!((h.grid.h1, h.grid.res(1), h.grid.res(2)), (1.0, 3, 2));
        // Level 1: cell (0, 0, 1) at t = (1/2, 1/4, 1/2): eight vertices.
        assert_eq!(h.lights.iter().filter(|g| g.level == 1).count(), 8);
        let t = Vec3::new(0.25, 0.125, 0.75);
        for delta in 0..8u32 {
            let v = [delta & 1, (delta >> 1) & 1, (delta >> 2) & 1];
            let g = h.light_at(2, v).expect("every coarse corner holds light");
            let want = Vec3::new(0.0, 0.0, 8.0 * LghGrid::trilinear(t, delta));
            assert!(
                close(Vec3::from(g.e), want),
                "vertex {v:?}: {:?} vs {want}",
                g.e
            );
            let c = g.centre(h.grid.vertex_pos(2, v));
            assert!(
                close(c, Vec3::from(prims[1].p0)),
                "vertex {v:?}: centre {c}"
            );
        }
    }

    /// Lights sorted by (level-1 cell, id) and each cell's range, worked by
    /// hand on L = 2 (2 × 2 × 2 cells of side 1 over (0,0,0)–(2,2,2)).
    #[test]
    fn lights_sort_by_cell_then_id() {
        let at = |x: f32, y: f32, z: f32| LightPrim::point(Vec3::new(x, y, z), Vec3::ONE);
        let prims = [
            at(2.0, 2.0, 2.0), // cell (1, 1, 1) = 7
            at(0.5, 0.5, 0.5), // cell 0
            at(1.5, 0.5, 0.5), // cell 1
            at(0.0, 0.0, 0.0), // cell 0
            at(0.5, 1.5, 1.5), // cell (0, 1, 1) = 6
            LightPrim::triangle(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE),
        ];
        let h = build(&prims, 2).unwrap();
        assert_eq!(h.sorted, vec![1, 3, 2, 4, 0, 5]);
        assert_eq!(
            h.cells,
            vec![
                [0, 2],
                [2, 3],
                [0, 0],
                [0, 0],
                [0, 0],
                [0, 0],
                [3, 4],
                [4, 5]
            ]
        );
    }

    /// `candidates` visits only the lights and grid vertices within reach
    /// of the shading point (the cells within α of it at level 0, the
    /// vertices within 2α + 1 at the finer levels); it must find exactly
    /// what a visit of every light and every vertex of every level finds
    /// (the same blending and emitters: equal bits). Points and VPLs
    /// scattered over [3, 23]³ (a grid whose origin and cell size are not
    /// 0 and 1), shading points inside and just outside the bounds and
    /// far outside them, α from below one cell to four, with and without
    /// level 0.
    #[test]
    fn candidates_equal_a_visit_of_everything() {
        use rand::rngs::StdRng;
        use rand::{RngExt, SeedableRng};
        let mut rng = StdRng::seed_from_u64(43);
        let v3 = |rng: &mut StdRng, lo: f32, hi: f32| {
            Vec3::new(
                rng.random_range(lo..hi),
                rng.random_range(lo..hi),
                rng.random_range(lo..hi),
            )
        };
        let prims: Vec<LightPrim> = (0..400)
            .map(|i| {
                let p = v3(&mut rng, 3.0, 23.0);
                let e = v3(&mut rng, 0.1, 1.0);
                if i % 2 == 0 {
                    LightPrim::point(p, e)
                } else {
                    LightPrim::vpl(p, v3(&mut rng, -1.0, 1.0).normalize(), e)
                }
            })
            .collect();
        let h = build(&prims, 4).unwrap();
        let g = &h.grid;
        assert!(
            g.lo.min_element() > 2.0 && g.h1 != 1.0,
            "{:?}, {}",
            g.lo,
            g.h1
        );
        let clamp2 = 0.05;
        let key = |c: &Candidate| (c.level, c.id);
        let mut compared = 0;
        for alpha in [0.4, 1.0, 2.0, 4.0] {
            for level0 in [false, true] {
                let params = LghParams {
                    alpha,
                    level0,
                    ..LghParams::default()
                };
                let first = if level0 { 0 } else { 1 };
                let soft2 = g.soft2(params.clamp);
                for k in 0..40 {
                    let x = if k < 30 {
                        v3(&mut rng, 2.5, 23.5)
                    } else {
                        v3(&mut rng, -30.0, 56.0)
                    };
                    let n = v3(&mut rng, -1.0, 1.0).normalize();
                    let mut got = h.candidates(&prims, &params, clamp2, x, n);
                    // Everything, with the same filter.
                    let mut want = Vec::new();
                    let mut visit = |level: u32, id: u32, e: Emitter| {
                        let b = g.blend(alpha, first, level, (e.pos - x).length());
                        let f = b * e.eval(x, n);
                        if b > 0.0 && luminance(f) > 0.0 {
                            want.push((level, id, f));
                        }
                    };
                    if level0 {
                        for (i, l) in prims.iter().enumerate() {
                            visit(0, i as u32, Emitter::light(l, clamp2));
                        }
                    }
                    for level in 1..=g.levels {
                        let r = g.res(level);
                        for_box([0; 3], [r - 1; 3], |v| {
                            if let Some(gl) = h.light_at(level, v) {
                                let slot = h.index[(g.index_offset(level)
                                    + g.vertex_index(level, v) as u64)
                                    as usize];
                                visit(
                                    level,
                                    slot,
                                    gl.emitter(g.vertex_pos(level, v), clamp2, soft2),
                                );
                            }
                        });
                    }
                    got.sort_by_key(key);
                    want.sort_by_key(|w| (w.0, w.1));
                    let got: Vec<(u32, u32, Vec3)> =
                        got.iter().map(|c| (c.level, c.id, c.f)).collect();
                    assert_eq!(got, want, "α {alpha}, level 0 {level0}, x {x}");
                    compared += want.len();
                }
            }
        }
        // The comparisons had candidates at every level to miss.
        assert!(compared > 1000, "{compared} candidates");
    }

    /// The stratified picks, worked by hand: ‖f‖ = 1, 2, 1 (F = 4) with
    /// s = 4 and ξ = 1/2 aim at 0.5, 1.5, 2.5, 3.5 of the running sums 1,
    /// 3, 4; ξ = 0 at 0, 1, 2, 3 (a target equal to a running sum goes to
    /// the next candidate); a candidate holding a whole number of strata
    /// (s·‖f‖/F) gets that many picks for every ξ, and a lone one every
    /// pick; no candidate or F = 0 gives no pick; a target that rounding
    /// puts at F goes to the last candidate. (Moved here from
    /// `tests/lights_cpu.rs`, whose cases it keeps.)
    #[test]
    fn picks_follow_the_running_sum() {
        let c = |lum: f32| Candidate {
            f: Vec3::splat(lum),
            lum,
            pos: Vec3::ZERO,
            sigma: Vec3::ZERO,
            level: 1,
            id: 0,
        };
        let cands = [c(1.0), c(2.0), c(1.0)];
        assert_eq!(pick(&cands, 4, 0.5), vec![0, 1, 1, 2]);
        assert_eq!(pick(&cands, 4, 0.0), vec![0, 1, 1, 2]);
        assert_eq!(pick(&cands, 2, 0.0), vec![0, 1]);
        assert_eq!(pick(&cands, 2, 0.75), vec![1, 2]);
        assert_eq!(pick(&cands, 1, 0.3), vec![1]);
        assert_eq!(pick(&cands, 4, 0.999_999), vec![0, 1, 1, 2]);
        assert_eq!(pick(&cands, 8, 0.5), vec![0, 0, 1, 1, 1, 1, 2, 2]);
        assert_eq!(pick(&cands[..1], 3, 0.5), vec![0, 0, 0]);
        // ξ just below 1: k + ξ rounds to k + 1 for k ≥ 1, so the last
        // target is F itself, which no running sum exceeds; the last
        // candidate takes it.
        let xi = 1.0 - f32::EPSILON / 2.0;
        assert_eq!(3.0 + xi, 4.0);
        assert_eq!(pick(&cands, 4, xi), vec![0, 1, 2, 2]);
        assert_eq!(pick(&[], 4, 0.5), Vec::<usize>::new());
        assert_eq!(pick(&[c(0.0), c(0.0)], 2, 0.5), Vec::<usize>::new());
    }

    /// Each coarse level gathers from the fine vertices within three of
    /// twice its own (a fine grid light's centre lies within one fine cell
    /// of its vertex, so no other can reach a coarse vertex's cells): the
    /// gathers must equal, bit for bit, gathers over *every* fine vertex
    /// in the same (z-major) order. 600 points and VPLs, five levels, so
    /// that levels 2–5 have vertices far from the origin on every axis.
    #[test]
    fn coarse_gathers_equal_gathers_over_every_fine_vertex() {
        use rand::rngs::StdRng;
        use rand::{RngExt, SeedableRng};
        let mut rng = StdRng::seed_from_u64(53);
        let prims: Vec<LightPrim> = (0..600)
            .map(|i| {
                let p = Vec3::new(rng.random(), rng.random(), rng.random()) * 16.0;
                let e = Vec3::new(rng.random(), rng.random(), rng.random()) + Vec3::splat(0.1);
                if i % 2 == 0 {
                    LightPrim::point(p, e)
                } else {
                    let n = Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
                    LightPrim::vpl(p, n.normalize(), e)
                }
            })
            .collect();
        let h = build(&prims, 5).unwrap();
        let g = &h.grid;
        assert_eq!(g.levels, 5);
        let mut compared = 0;
        for level in 2..=g.levels {
            let fine = g.res(level - 1);
            let r = g.res(level);
            for_box([0; 3], [r - 1; 3], |v| {
                let vpos = g.vertex_pos(level, v);
                let mut acc = GridLight::default();
                for_box([0; 3], [fine - 1; 3], |u| {
                    let Some(fl) = h.light_at(level - 1, u) else {
                        return;
                    };
                    let upos = g.vertex_pos(level - 1, u);
                    let (cell, t) = g.cell_of(level, fl.centre(upos));
                    let d = [0, 1, 2].map(|a| v[a].wrapping_sub(cell[a]));
                    if d.iter().all(|&x| x <= 1) {
                        let delta = d[0] + 2 * d[1] + 4 * d[2];
                        acc.add_grid(LghGrid::trilinear(t, delta), fl, upos - vpos);
                    }
                });
                match h.light_at(level, v) {
                    Some(got) => {
                        let want = GridLight {
                            vertex: g.vertex_index(level, v),
                            level,
                            ..acc
                        };
                        assert_eq!(*got, want, "level {level}, vertex {v:?}");
                        compared += 1;
                    }
                    None => assert!(acc.w <= 0.0, "level {level}, vertex {v:?} lost its light"),
                }
            });
        }
        assert!(compared > 100, "{compared} grid lights compared");
    }
}
