//! Node importance and child probabilities of hierarchical importance
//! sampling (real-time stochastic lightcuts §3.2, eq. 1–2), exactly as
//! `docs/light-sampling.md` writes them, in f32 and in the same order as
//! `wgsl/lights/sample.wgsl`.
//!
//! For a node with bounds `[bmin, bmax]` and intensity `I` seen from a
//! shading point `x` with normal `n`:
//!
//! * `dmin²`, `dmax²`: squared distances from `x` to the nearest and the
//!   farthest point of the box (`dmin² = 0` inside it);
//! * `F`: an upper bound of the clamped cosine `max(0, n·ω)` over the
//!   directions `ω` toward the points of the node's box, as the authors'
//!   code bounds it (`GeomTermBound`; the paper only says "a bound on the
//!   cosine"): 0 when the box lies wholly on or below the tangent plane,
//!   1 when `x` is inside the box or `n = 0` ([`reflectance_bound`]);
//! * `W = F·I`, 0 for dead nodes (zero intensity or EMPTY bounds).
//!
//! The cone kinds (`tree_cone`, `unbalanced`, `unbalanced_nocut`) also
//! bound where the node's lights emit ([`LightCone::emission_bound`], `G`)
//! and clamp the near distance to the node's size:
//!
//! * `W = F·G·I`;
//! * `dmin² = max(dmin², r²/16)` ([`NEAR_CLAMP`]) with `r` the
//!   half-diagonal of the box: a node of intensity `I` spread over a
//!   region of size `r` delivers on the order of `I/r²` to a point near or
//!   inside it, not `I/0`, so a shading point inside an upper node's box
//!   no longer gives that node a distance-free weight (pbrt-v4 clamps to
//!   `|diagonal|/2`, a length compared with a squared distance; this
//!   compares squares). The factor 1/16 (`dmin ≥ r/4`) is measured, not
//!   derived: on `cornell_lights` at 16 spp, `tree_cone`'s RelMSE is
//!   5.5e-2 without a clamp, 4.5e-2 / 4.1e-2 / 4.2e-2 with `r²/64`,
//!   `r²/16`, `r²/4` and 5.7e-2 with `r²` (BENCHMARKS.md). Only nodes of
//!   area lights are clamped: a point light's `I/d²` really is unbounded
//!   near it, and clamping nodes of points made `vpl_atrium` 4× worse
//!   (the cone's `points` flag).
//!
//! Two children `j` (left) and `k` (right) are weighted as the paper's
//! eq. 2 averages the probabilities obtained with the minimum and the
//! maximum distance: `p_min = W_j/dmin_j² ∕ (W_j/dmin_j² + W_k/dmin_k²)`,
//! written as `W_j·dmin_k² / (W_j·dmin_k² + W_k·dmin_j²)` so that no small
//! distance is divided by (the singular case, `x` inside both boxes, falls
//! back to `W_j / (W_j + W_k)`), `p_max` likewise, `p_left = (p_min + p_max)/2`
//! and `p_right = 1 − p_left`.
//!
//! The greedy cut ranks nodes by the authors' key `W / max(dmin², ε²)`
//! with `ε = 10⁻³ ·` the diagonal of the root's box ([`cut_key`]): finite
//! inside a box, 0 for `W = 0`. docs/light-sampling.md ("Sources") says
//! which rules follow the paper, which the authors' code, and which depart
//! from both.

use super::{LightCone, TreeNode};
use glam::Vec3;

/// The cone kinds' near-distance clamp: `dmin² ≥ NEAR_CLAMP·r²` (module
/// docs).
pub const NEAR_CLAMP: f32 = 1.0 / 16.0;

/// The largest f32 below 1 (`0x1.fffffep-1`): descents clamp `u` to it.
pub const ONE_MINUS_EPSILON: f32 = 0.999_999_94;

/// A shading point: position and unit normal facing the outgoing
/// direction (`n = 0`: no normal, every node has `F = 1`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Shading {
    pub p: Vec3,
    pub n: Vec3,
}

/// A node's quantities at one shading point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeImportance {
    /// Squared minimum distance (0 inside the box; 0 for dead nodes).
    pub dmin2: f32,
    /// Squared maximum distance (0 for dead nodes).
    pub dmax2: f32,
    /// `W = F·I` (0 for dead nodes).
    pub w: f32,
}

/// `dmin²`, `dmax²` and `W` of `node` at `s`, with the node's orientation
/// bound `cone` for the cone kinds (module docs). Dead nodes (I = 0 or
/// EMPTY bounds) get all three 0: their distances never matter since
/// `W = 0` makes every rule that uses them give the same result, and EMPTY
/// bounds would overflow them.
pub fn node_importance(node: &TreeNode, cone: Option<&LightCone>, s: &Shading) -> NodeImportance {
    if node.intensity == 0.0 || node.is_empty() {
        return NodeImportance::default();
    }
    let x = s.p.to_array();
    let mut dmin2 = 0.0f32;
    let mut dmax2 = 0.0f32;
    for ((x, lo), hi) in x.iter().zip(node.min).zip(node.max) {
        let dmin = (lo - x).max(0.0).max(x - hi);
        let dmax = (x - lo).abs().max((x - hi).abs());
        dmin2 += dmin * dmin;
        dmax2 += dmax * dmax;
    }
    let f = reflectance_bound(node, s);
    let Some(cone) = cone else {
        return NodeImportance {
            dmin2,
            dmax2,
            w: f * node.intensity,
        };
    };
    let c: [f32; 3] = std::array::from_fn(|a| 0.5 * (node.min[a] + node.max[a]));
    let h: [f32; 3] = std::array::from_fn(|a| 0.5 * (node.max[a] - node.min[a]));
    let r2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
    let g = cone.emission_bound(c, r2.sqrt(), x);
    NodeImportance {
        dmin2: if cone.points != 0 {
            dmin2
        } else {
            dmin2.max(NEAR_CLAMP * r2)
        },
        dmax2,
        w: (f * g) * node.intensity,
    }
}

/// `(lo, hi)`: the range of `d·(y − x)` over the points `y` of the node's
/// box, per axis the smaller and the larger of `d_a·(bmin_a − x_a)` and
/// `d_a·(bmax_a − x_a)`, summed x, y, z (the WGSL twin sums in the same
/// order).
fn range_along(node: &TreeNode, x: [f32; 3], d: [f32; 3]) -> (f32, f32) {
    let e0: [f32; 3] = std::array::from_fn(|a| d[a] * (node.min[a] - x[a]));
    let e1: [f32; 3] = std::array::from_fn(|a| d[a] * (node.max[a] - x[a]));
    let lo = e0[0].min(e1[0]) + e0[1].min(e1[1]) + e0[2].min(e1[2]);
    let hi = e0[0].max(e1[0]) + e0[1].max(e1[1]) + e0[2].max(e1[2]);
    (lo, hi)
}

/// The tangents `(t, b)` of the unit normal `n` (not 0) that the
/// reflectance bound measures along: the authors' `CoordinateSystem_`
/// (`t ⊥ n` from the two larger components, `b = n × t`), `b` left
/// unnormalized (it is unit within rounding).
fn tangent_frame(n: [f32; 3]) -> ([f32; 3], [f32; 3]) {
    let t = if n[0].abs() > n[1].abs() {
        let l = (n[0] * n[0] + n[2] * n[2]).sqrt();
        [-n[2] / l, 0.0, n[0] / l]
    } else {
        let l = (n[1] * n[1] + n[2] * n[2]).sqrt();
        [0.0, n[2] / l, -n[1] / l]
    };
    let b = [
        n[1] * t[2] - n[2] * t[1],
        n[2] * t[0] - n[0] * t[2],
        n[0] * t[1] - n[1] * t[0],
    ];
    (t, b)
}

/// The cosine bound F over the node's box (docs: "Reflectance bound"; the
/// authors' `GeomTermBound`): with `a`, `b`, `c` the coordinates of
/// `y − x` along `n` and two tangents, the largest `a` over the box
/// (`a_max`) and the smallest `|b|`, `|c|` (0 when the box straddles the
/// plane), `F = a_max / sqrt(b_min² + c_min² + a_max²)`, and `F = 0` when
/// `a_max ≤ 0` (the box lies wholly on or below the tangent plane). For
/// every `y` in the box `cos = a/sqrt(a² + b² + c²)` grows with `a` and
/// shrinks with `|b|`, `|c|`, so F bounds the clamped cosine over the box
/// from above. Not for dead nodes.
pub fn reflectance_bound(node: &TreeNode, s: &Shading) -> f32 {
    let n = s.n.to_array();
    if n == [0.0; 3] {
        return 1.0;
    }
    let x = s.p.to_array();
    let (_, a_max) = range_along(node, x, n);
    if a_max <= 0.0 {
        return 0.0;
    }
    let (t, b) = tangent_frame(n);
    let gap = |(lo, hi): (f32, f32)| lo.max(-hi).max(0.0);
    let b_min = gap(range_along(node, x, t));
    let c_min = gap(range_along(node, x, b));
    (a_max / (b_min * b_min + c_min * c_min + a_max * a_max).sqrt()).min(1.0)
}

/// `a/(a + b)` for weights `a = W_j·d_k`, `b = W_k·d_j`, falling back to
/// `W_j/(W_j + W_k)` when both vanish. Needs `W_j + W_k > 0`.
fn ratio(w_j: f32, d_j: f32, w_k: f32, d_k: f32) -> f32 {
    let mut a = w_j * d_k;
    let mut b = w_k * d_j;
    if a + b == 0.0 {
        a = w_j;
        b = w_k;
    }
    a / (a + b)
}

/// Probability of the left child (eq. 1–2); `None` for a dead branch
/// (`W_j + W_k == 0`). The right child's probability is `1 − p_left`.
pub fn p_left(j: &NodeImportance, k: &NodeImportance) -> Option<f32> {
    if j.w + k.w == 0.0 {
        return None;
    }
    let p_min = ratio(j.w, j.dmin2, k.w, k.dmin2);
    let p_max = ratio(j.w, j.dmax2, k.w, k.dmax2);
    Some(0.5 * (p_min + p_max))
}

/// One descent step with the random number `u ∈ [0, 1)`: returns whether
/// the left child is taken, its probability and the rescaled `u`.
pub fn choose_child(p_left: f32, u: f32) -> (bool, f32, f32) {
    let p_right = 1.0 - p_left;
    let (left, p, u) = if u < p_left {
        (true, p_left, u / p_left)
    } else {
        (false, p_right, (u - p_left) / p_right)
    };
    (left, p, u.min(ONE_MINUS_EPSILON))
}

/// The fraction of the diagonal of the whole lights' box below which the
/// cut key stops growing as `dmin` shrinks (the authors' `errorLimit`,
/// "Min Node Error Bound", 0.001).
pub const CUT_KEY_NEAR: f32 = 1e-3;

/// The squared floor of the cut key's distance for a tree whose root is
/// `root`: `(CUT_KEY_NEAR · |bmax − bmin|)²`, 0 for EMPTY bounds. The
/// authors call the length `sceneLightBoundRadius` but store the length of
/// the lights' box diagonal in it (`FindVPLBboxMinCS.hlsl`,
/// `CPULightCuts::globalBoundDiag`); this follows what they store.
pub fn cut_key_floor2(root: &TreeNode) -> f32 {
    if root.is_empty() {
        return 0.0;
    }
    let d: [f32; 3] = std::array::from_fn(|a| root.max[a] - root.min[a]);
    let e = CUT_KEY_NEAR * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    e * e
}

/// Greedy-cut key of a refinable node (docs: "Cuts"; the authors'
/// `errorFunction`): `W / max(dmin², floor2)` with `floor2` from
/// [`cut_key_floor2`], 0 when `W = 0`, at most `f32::MAX` (a floor of 0
/// with `dmin² = 0` gives `f32::MAX`). Finite: a node around the
/// representative is ranked by its weight, not put first whatever it is.
pub fn cut_key(imp: &NodeImportance, floor2: f32) -> f32 {
    if imp.w == 0.0 {
        return 0.0;
    }
    let d = imp.dmin2.max(floor2);
    if d == 0.0 {
        return f32::MAX;
    }
    (imp.w / d).min(f32::MAX)
}

/// Selection probabilities of the nodes of a cut at one shading point
/// (eq. 2 generalized to n nodes, docs "Cut node probabilities"); `None`
/// when every node has `W = 0`.
pub fn cut_probabilities(imps: &[NodeImportance]) -> Option<Vec<f32>> {
    let w_max = imps.iter().fold(0.0f32, |m, i| m.max(i.w));
    if w_max == 0.0 {
        return None;
    }
    let w: Vec<f32> = imps.iter().map(|i| i.w / w_max).collect();
    let p_min = normalized_weights(imps, &w, |i| i.dmin2);
    let p_max = normalized_weights(imps, &w, |i| i.dmax2);
    Some(
        p_min
            .iter()
            .zip(&p_max)
            .map(|(a, b)| 0.5 * (a + b))
            .collect(),
    )
}

/// Inverse-square weights `w_j / max(d_j, 1e-20)` normalized to sum 1, or,
/// when `x` is inside some live node (`d_j == 0`, `W_j > 0`), `w_j` over
/// those nodes only.
fn normalized_weights(
    imps: &[NodeImportance],
    w: &[f32],
    d: impl Fn(&NodeImportance) -> f32,
) -> Vec<f32> {
    let inside = imps.iter().any(|i| d(i) == 0.0 && i.w > 0.0);
    let weights: Vec<f32> = imps
        .iter()
        .zip(w)
        .map(|(i, &w)| {
            if inside {
                if d(i) == 0.0 && i.w > 0.0 {
                    w
                } else {
                    0.0
                }
            } else {
                w / d(i).max(1e-20)
            }
        })
        .collect();
    let sum: f32 = weights.iter().sum();
    weights.iter().map(|x| x / sum).collect()
}

/// Picks a cut node with `u` by a running f32 CDF over `probs` (the last
/// node with `P > 0` takes what rounding leaves): returns the cut position
/// and the rescaled `u`.
pub fn choose_cut_node(probs: &[f32], u: f32) -> (usize, f32) {
    let mut cdf = 0.0f32;
    let mut chosen = None;
    for (j, &p) in probs.iter().enumerate() {
        if p <= 0.0 {
            continue;
        }
        let next = cdf + p;
        chosen = Some((j, cdf));
        if u < next {
            break;
        }
        cdf = next;
    }
    let (j, c_prev) = chosen.expect("cut probabilities with a positive entry");
    (j, ((u - c_prev) / probs[j]).min(ONE_MINUS_EPSILON))
}

#[cfg(test)]
mod tests;
