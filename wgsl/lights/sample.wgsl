// Light sampling on the GPU: the WGSL mirror of src/lights/{importance,cut,
// alias,sampler}.rs, following docs/light-sampling.md operation by operation
// (real-time stochastic lightcuts §3.2–3.3). Needs lights/light_prim.wgsl,
// lights/cone.wgsl and lights/bindings.wgsl.
//
//   light_sample(p, n, cut_base, u) -> LightPick  one light and its pmf (the
//                                                 cut kinds: one pick from
//                                                 the cut's mixture)
//   light_pmf(p, n, cut_base, light) -> LightPmf  the pmf of a given light
//   light_sample_subtree(p, n, cut_base, j, u)    the light of subtree j of
//                                                 the pixel's share of the cut
//                                                 and its pmf in that subtree
//   light_pmf_subtree(p, n, cut_base, light)      that pmf of a given light
//   select_cut(p, n, &out) -> u32                 the greedy cut (pre-pass)
//
// `p` is the shading point, `n` its unit normal facing the outgoing direction
// (vec3(0) = no normal), `cut_base` the block's first light_cuts entry
// (light_cut_base; ignored by the kinds without cuts), `u` ∈ [0, 1).
// Probabilities are (mantissa, exponent) pairs renormalized with frexp after
// every product, so 20+ tree levels never underflow.
// No recursion, every loop bounded by MAX_CUT or LIGHT_MAX_DEPTH.

struct LightPmf {
    m: f32,
    e: i32,
}

struct LightPick {
    // The light, or NO_LIGHT (no lights, or all candidates have zero
    // importance), or for sst LIGHT_SUBSTITUTE_BIT | the node whose
    // substitute was picked.
    light: u32,
    // pmf = pmf_m · 2^pmf_e.
    pmf_m: f32,
    pmf_e: i32,
}

struct NodeImportance {
    dmin2: f32,
    dmax2: f32,
    w: f32,
}

// 0x1.fffffep-1, the largest f32 below 1.
const LIGHT_ONE_MINUS_EPSILON: f32 = 0.99999994;

fn light_pmf_from(p: f32) -> LightPmf {
    let r = frexp(p);
    return LightPmf(r.fract, r.exp);
}

fn light_pmf_mul(a: LightPmf, p: f32) -> LightPmf {
    let r = frexp(a.m * p);
    return LightPmf(r.fract, a.e + r.exp);
}

fn light_no_pick() -> LightPick {
    return LightPick(NO_LIGHT, 0.0, 0);
}

// light_uses_tree(), light_uses_bvh(), light_uses_cut(), light_uses_cones()
// and light_substitutes_on() are generated from SamplerKind's predicates
// (lights/kinds.wgsl, gpu_sampler.rs kinds_wgsl): one list of which kind
// does what.

// Eq. 3 of the substitute-tree paper for internal node `node` (substitute.rs
// SubstituteParams::suitable).
fn light_suitable(node: u32) -> bool {
    let sub = light_substitutes[node];
    return light_nodes[node].intensity > 0.0 && sub.nu >= light_params.sst_nu_min
        && substitute_sigma_z2(sub) <= light_params.sst_sigma_max2;
}

fn light_is_leaf(node: u32) -> bool {
    if (light_uses_bvh()) {
        return (light_nodes[node].id & LIGHT_INTERNAL_BIT) == 0u;
    }
    return node + 1u >= light_params.leaf_count;
}

// Left child of an internal node; the right child is left + 1 in both layouts.
fn light_left_child(node: u32) -> u32 {
    if (light_uses_bvh()) {
        return light_nodes[node].id & ~LIGHT_INTERNAL_BIT;
    }
    return 2u * node + 1u;
}

fn light_length(v: vec3<f32>) -> f32 {
    return sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
}

// A node's bounding sphere seen from x: v = c − x, dist = |v|, the squared
// radius, and the sine and cosine of its half-angle θ_b (meaningless when
// x is inside, dist ≤ r). For the emission bound G and the near clamp (the
// reflectance bound F is over the box); each value is computed by the same
// f32 operations as importance.rs and cone.rs compute it.
struct LightSphere {
    v: vec3<f32>,
    dist: f32,
    r2: f32,
    inside: bool,
    sin_b: f32,
    cos_b: f32,
}

fn light_sphere(node: TreeNode, x: vec3<f32>) -> LightSphere {
    let c = 0.5 * (node.bmin + node.bmax);
    let h = 0.5 * (node.bmax - node.bmin);
    let r2 = h.x * h.x + h.y * h.y + h.z * h.z;
    let r = sqrt(r2);
    let v = c - x;
    let dist = light_length(v);
    let sin_b = r / dist;
    let cos_b = sqrt(max(1.0 - sin_b * sin_b, 0.0));
    return LightSphere(v, dist, r2, dist <= r, sin_b, cos_b);
}

// The range (lo, hi) of d·(y − x) over the points y of the node's box
// (importance.rs range_along, summed x, y, z).
fn light_range_along(node: TreeNode, x: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let e0 = d * (node.bmin - x);
    let e1 = d * (node.bmax - x);
    let lo = min(e0.x, e1.x) + min(e0.y, e1.y) + min(e0.z, e1.z);
    let hi = max(e0.x, e1.x) + max(e0.y, e1.y) + max(e0.z, e1.z);
    return vec2<f32>(lo, hi);
}

// The distance from 0 to the range r (0 when it straddles 0).
fn light_range_gap(r: vec2<f32>) -> f32 {
    return max(max(r.x, -r.y), 0.0);
}

// The cosine bound F over the node's box (importance.rs reflectance_bound,
// the authors' GeomTermBound): 0 for a box wholly on or below the tangent
// plane, else a_max / sqrt(b_min² + c_min² + a_max²) along n and the
// tangents t, b = n × t (importance.rs tangent_frame).
fn light_reflectance_bound(node: TreeNode, x: vec3<f32>, n: vec3<f32>) -> f32 {
    if (all(n == vec3<f32>(0.0))) {
        return 1.0;
    }
    let a_max = light_range_along(node, x, n).y;
    if (a_max <= 0.0) {
        return 0.0;
    }
    var t: vec3<f32>;
    if (abs(n.x) > abs(n.y)) {
        let l = sqrt(n.x * n.x + n.z * n.z);
        t = vec3<f32>(-n.z / l, 0.0, n.x / l);
    } else {
        let l = sqrt(n.y * n.y + n.z * n.z);
        t = vec3<f32>(0.0, n.z / l, -n.y / l);
    }
    let b = vec3<f32>(n.y * t.z - n.z * t.y, n.z * t.x - n.x * t.z, n.x * t.y - n.y * t.x);
    let b_min = light_range_gap(light_range_along(node, x, t));
    let c_min = light_range_gap(light_range_along(node, x, b));
    return min(a_max / sqrt(b_min * b_min + c_min * c_min + a_max * a_max), 1.0);
}

// The emission bound G = cos θ' of the node's cone toward x
// (LightCone::emission_bound; its v is x − c = −sp.v, negated exactly).
fn light_emission_bound(cone: LightCone, sp: LightSphere) -> f32 {
    if (cone.cos_o <= -1.0 || sp.inside) {
        return 1.0;
    }
    let w = cone.axis;
    let v = sp.v;
    var cos_w = -(w.x * v.x + w.y * v.y + w.z * v.z) / sp.dist;
    if (cone.two_sided != 0u) {
        cos_w = abs(cos_w);
    }
    let sin_w = sqrt(max(1.0 - cos_w * cos_w, 0.0));
    var cos_x = 1.0;
    var sin_x = 0.0;
    if (!(cos_w > cone.cos_o)) {
        cos_x = cos_w * cone.cos_o + sin_w * cone.sin_o;
        sin_x = sin_w * cone.cos_o - cos_w * cone.sin_o;
    }
    var cos_p = 1.0;
    if (!(cos_x > sp.cos_b)) {
        cos_p = cos_x * sp.cos_b + sin_x * sp.sin_b;
    }
    if (cos_p <= cone.cos_e) {
        return 0.0;
    }
    return cos_p;
}

// dmin², dmax² and W = F·I of node `index`; all 0 for dead nodes (I = 0 or
// EMPTY bounds). With cones (`cones`): W = F·G·I and, without point lights
// below, dmin² ≥ NEAR_CLAMP·r² (importance.rs). The cone is read only when
// F > 0: W = 0 whatever G is otherwise (the same result as the CPU's).
fn light_node_importance(node: TreeNode, index: u32, cones: bool, x: vec3<f32>, n: vec3<f32>) -> NodeImportance {
    if (node.intensity == 0.0 || node.bmin.x > node.bmax.x) {
        return NodeImportance(0.0, 0.0, 0.0);
    }
    let dmin = max(max(node.bmin - x, vec3<f32>(0.0)), x - node.bmax);
    let dmax = max(abs(x - node.bmin), abs(x - node.bmax));
    let dmin2 = dmin.x * dmin.x + dmin.y * dmin.y + dmin.z * dmin.z;
    let dmax2 = dmax.x * dmax.x + dmax.y * dmax.y + dmax.z * dmax.z;
    let f = light_reflectance_bound(node, x, n);
    if (!cones) {
        return NodeImportance(dmin2, dmax2, f * node.intensity);
    }
    let sp = light_sphere(node, x);
    let cone = light_cones[index];
    var near = dmin2;
    if (cone.points == 0u) {
        near = max(dmin2, bitcast<f32>(LIGHT_NEAR_CLAMP_BITS) * sp.r2);
    }
    if (f == 0.0) {
        return NodeImportance(near, dmax2, 0.0);
    }
    let g = light_emission_bound(cone, sp);
    return NodeImportance(near, dmax2, (f * g) * node.intensity);
}

fn light_importance_of(node: u32, x: vec3<f32>, n: vec3<f32>) -> NodeImportance {
    return light_node_importance(light_nodes[node], node, light_uses_cones(), x, n);
}

fn light_ratio(w_j: f32, d_j: f32, w_k: f32, d_k: f32) -> f32 {
    var a = w_j * d_k;
    var b = w_k * d_j;
    if (a + b == 0.0) {
        a = w_j;
        b = w_k;
    }
    return a / (a + b);
}

// Probability of the left child (eq. 1–2), or −1 for a dead branch.
fn light_p_left(j: NodeImportance, k: NodeImportance) -> f32 {
    if (j.w + k.w == 0.0) {
        return -1.0;
    }
    return 0.5 * (light_ratio(j.w, j.dmin2, k.w, k.dmin2) + light_ratio(j.w, j.dmax2, k.w, k.dmax2));
}

// Hierarchical importance sampling from `start` down to a leaf.
fn light_descend(start: u32, x: vec3<f32>, n: vec3<f32>, u_in: f32, pmf_in: LightPmf) -> LightPick {
    var node = start;
    var u = u_in;
    var pmf = pmf_in;
    for (var step = 0u; step < LIGHT_MAX_DEPTH; step++) {
        if (light_is_leaf(node)) {
            break;
        }
        if (light_substitutes_on() && light_suitable(node)) {
            return LightPick(LIGHT_SUBSTITUTE_BIT | node, pmf.m, pmf.e);
        }
        let l = light_left_child(node);
        let p_left = light_p_left(light_importance_of(l, x, n), light_importance_of(l + 1u, x, n));
        if (p_left < 0.0) {
            return light_no_pick();
        }
        let p_right = 1.0 - p_left;
        if (u < p_left) {
            pmf = light_pmf_mul(pmf, p_left);
            u = u / p_left;
            node = l;
        } else {
            pmf = light_pmf_mul(pmf, p_right);
            u = (u - p_left) / p_right;
            node = l + 1u;
        }
        u = min(u, LIGHT_ONE_MINUS_EPSILON);
    }
    let id = light_nodes[node].id;
    if (!light_is_leaf(node) || id == NO_LIGHT) {
        return light_no_pick();
    }
    return LightPick(id, pmf.m, pmf.e);
}

// Number of nodes of the block's cut this pixel samples (1, the root, for
// the no-cut kinds): all of them, or under interleaved sampling its share
// (light_subset, set by light_cut_base, holds p and p + 1 then).
fn light_cut_len(cut_base: u32) -> u32 {
    if (!light_uses_cut()) {
        return 1u;
    }
    let size = min(light_params.cut_size, MAX_CUT);
    var n = size;
    for (var j = 0u; j < size; j++) {
        if (light_cuts[cut_base + j] == NO_LIGHT) {
            n = j;
            break;
        }
    }
    let m = max(light_params.interleave, 1u);
    if (m == 1u) {
        return n;
    }
    let mm = m * m;
    return (light_subset.y * n) / mm - (light_subset.x * n) / mm;
}

fn light_cut_node(cut_base: u32, j: u32) -> u32 {
    if (!light_uses_cut()) {
        return 0u;
    }
    let m = max(light_params.interleave, 1u);
    if (m == 1u) {
        return light_cuts[cut_base + j];
    }
    let size = min(light_params.cut_size, MAX_CUT);
    var n = size;
    for (var i = 0u; i < size; i++) {
        if (light_cuts[cut_base + i] == NO_LIGHT) {
            n = i;
            break;
        }
    }
    return light_cuts[cut_base + (light_subset.x * n) / (m * m) + j];
}

// Cut node probabilities (eq. 2 over n nodes, docs "Cut node probabilities")
// into `probs`; false when every node has W = 0.
fn light_cut_probabilities(
    x: vec3<f32>,
    n: vec3<f32>,
    cut_base: u32,
    len: u32,
    probs: ptr<function, array<f32, MAX_CUT>>,
) -> bool {
    var imps: array<NodeImportance, MAX_CUT>;
    var w_max = 0.0;
    var inside_min = false;
    var inside_max = false;
    for (var j = 0u; j < len; j++) {
        let imp = light_importance_of(light_cut_node(cut_base, j), x, n);
        imps[j] = imp;
        w_max = max(w_max, imp.w);
        inside_min = inside_min || (imp.dmin2 == 0.0 && imp.w > 0.0);
        inside_max = inside_max || (imp.dmax2 == 0.0 && imp.w > 0.0);
    }
    if (w_max == 0.0) {
        return false;
    }
    if (len == 1u) {
        (*probs)[0] = 1.0; // both normalized weights are w/w = 1
        return true;
    }
    var w_min_of: array<f32, MAX_CUT>;
    var sum_min = 0.0;
    var sum_max = 0.0;
    for (var j = 0u; j < len; j++) {
        let imp = imps[j];
        let w = imp.w / w_max;
        var a = w / max(imp.dmin2, 1e-20);
        if (inside_min) {
            a = select(0.0, w, imp.dmin2 == 0.0 && imp.w > 0.0);
        }
        var b = w / max(imp.dmax2, 1e-20);
        if (inside_max) {
            b = select(0.0, w, imp.dmax2 == 0.0 && imp.w > 0.0);
        }
        w_min_of[j] = a;
        (*probs)[j] = b;
        sum_min += a;
        sum_max += b;
    }
    for (var j = 0u; j < len; j++) {
        (*probs)[j] = 0.5 * (w_min_of[j] / sum_min + (*probs)[j] / sum_max);
    }
    return true;
}

fn light_sample_tree(x: vec3<f32>, n: vec3<f32>, cut_base: u32, u: f32) -> LightPick {
    var probs: array<f32, MAX_CUT>;
    let len = light_cut_len(cut_base);
    if (len == 0u || !light_cut_probabilities(x, n, cut_base, len, &probs)) {
        return light_no_pick();
    }
    // Running CDF; the last node with P > 0 takes what rounding leaves.
    var cdf = 0.0;
    var chosen = 0u;
    var c_prev = 0.0;
    for (var j = 0u; j < len; j++) {
        let p = probs[j];
        if (p <= 0.0) {
            continue;
        }
        let next = cdf + p;
        chosen = j;
        c_prev = cdf;
        if (u < next) {
            break;
        }
        cdf = next;
    }
    let u_node = min((u - c_prev) / probs[chosen], LIGHT_ONE_MINUS_EPSILON);
    return light_descend(light_cut_node(cut_base, chosen), x, n, u_node, light_pmf_from(probs[chosen]));
}

fn light_sample(s_p: vec3<f32>, s_n: vec3<f32>, cut_base: u32, u: f32) -> LightPick {
    let count = light_params.count;
    if (count == 0u) {
        return light_no_pick();
    }
    switch (light_params.kind) {
        case LIGHT_KIND_UNIFORM: {
            let i = min(u32(floor(u * f32(count))), count - 1u);
            let pmf = light_pmf_from(1.0 / f32(count));
            return LightPick(i, pmf.m, pmf.e);
        }
        case LIGHT_KIND_POWER: {
            if (light_params.alias_count == 0u) {
                return light_no_pick();
            }
            let t = u * f32(count);
            let i = min(u32(floor(t)), count - 1u);
            let v = t - f32(i);
            let entry = light_alias[i];
            let light = select(entry.alias_id, i, v < entry.q);
            let pmf = light_pmf_from(bitcast<f32>(light_index[light]));
            return LightPick(light, pmf.m, pmf.e);
        }
        case LIGHT_KIND_LGH: {
            // The grid hierarchy sums over lights (lights/lgh.wgsl): it
            // picks no single light.
            return light_no_pick();
        }
        default: {
            return light_sample_tree(s_p, s_n, cut_base, u);
        }
    }
}

// pmf of `light` in the perfect tree: find the cut node above its leaf, then
// multiply the child probabilities along the path (leaf index bits).
// With `within`, the pmf within the cut node's subtree (no cut probability).
fn light_pmf_perfect(x: vec3<f32>, n: vec3<f32>, cut_base: u32, light: u32, within: bool) -> LightPmf {
    let leaf1 = light_params.leaf_count + light_index[light]; // leaf node + 1
    let leaf_level = light_params.levels - 1u;
    let len = light_cut_len(cut_base);
    var found = NO_LIGHT;
    var d = 0u;
    for (var j = 0u; j < len; j++) {
        let c1 = light_cut_node(cut_base, j) + 1u;
        let level = u32(firstLeadingBit(c1));
        if (level <= leaf_level && (leaf1 >> (leaf_level - level)) == c1) {
            found = j;
            d = leaf_level - level;
            break;
        }
    }
    var pmf = light_pmf_from(1.0);
    if (found == NO_LIGHT) {
        return LightPmf(0.0, 0);
    }
    if (!within) {
        var probs: array<f32, MAX_CUT>;
        if (!light_cut_probabilities(x, n, cut_base, len, &probs)) {
            return LightPmf(0.0, 0);
        }
        pmf = light_pmf_from(probs[found]);
    }
    for (var t = d; t > 0u; t--) {
        let node = (leaf1 >> t) - 1u;
        let child = (leaf1 >> (t - 1u)) - 1u;
        if (light_substitutes_on() && light_suitable(node)) {
            // The descent stops above the leaf: it is never picked.
            return LightPmf(0.0, 0);
        }
        let l = 2u * node + 1u;
        let p_left = light_p_left(light_importance_of(l, x, n), light_importance_of(l + 1u, x, n));
        if (p_left < 0.0) {
            return LightPmf(0.0, 0);
        }
        pmf = light_pmf_mul(pmf, select(1.0 - p_left, p_left, child == l));
    }
    return pmf;
}

// pmf of `light` in the BVH: walk up the parent links to the cut, then
// multiply the child probabilities top-down (the order sampling uses).
// With `within`, the pmf within the cut node's subtree (no cut probability).
fn light_pmf_bvh(x: vec3<f32>, n: vec3<f32>, cut_base: u32, light: u32, within: bool) -> LightPmf {
    let len = light_cut_len(cut_base);
    var path: array<u32, LIGHT_MAX_DEPTH>;
    var depth = 0u;
    var node = light_index[light];
    var found = NO_LIGHT;
    for (var step = 0u; step < LIGHT_MAX_DEPTH; step++) {
        path[depth] = node;
        depth += 1u;
        for (var j = 0u; j < len; j++) {
            if (light_cut_node(cut_base, j) == node) {
                found = j;
                break;
            }
        }
        if (found != NO_LIGHT) {
            break;
        }
        node = light_index[light_params.count + node];
        if (node == NO_LIGHT) {
            break;
        }
    }
    var pmf = light_pmf_from(1.0);
    if (found == NO_LIGHT) {
        return LightPmf(0.0, 0);
    }
    if (!within) {
        var probs: array<f32, MAX_CUT>;
        if (!light_cut_probabilities(x, n, cut_base, len, &probs)) {
            return LightPmf(0.0, 0);
        }
        pmf = light_pmf_from(probs[found]);
    }
    for (var i = depth - 1u; i > 0u; i--) {
        if (light_substitutes_on() && light_suitable(path[i])) {
            // The descent stops above the leaf (the radix substitute
            // tree): it is never picked.
            return LightPmf(0.0, 0);
        }
        let l = light_left_child(path[i]);
        let p_left = light_p_left(light_importance_of(l, x, n), light_importance_of(l + 1u, x, n));
        if (p_left < 0.0) {
            return LightPmf(0.0, 0);
        }
        pmf = light_pmf_mul(pmf, select(1.0 - p_left, p_left, path[i - 1u] == l));
    }
    return pmf;
}

fn light_pmf(s_p: vec3<f32>, s_n: vec3<f32>, cut_base: u32, light: u32) -> LightPmf {
    let count = light_params.count;
    if (light >= count) {
        return LightPmf(0.0, 0);
    }
    switch (light_params.kind) {
        case LIGHT_KIND_UNIFORM: {
            return light_pmf_from(1.0 / f32(count));
        }
        case LIGHT_KIND_POWER: {
            if (light_params.alias_count == 0u) {
                return LightPmf(0.0, 0);
            }
            return light_pmf_from(bitcast<f32>(light_index[light]));
        }
        case LIGHT_KIND_LGH: {
            return LightPmf(0.0, 0);
        }
        default: {
            if (light_uses_bvh()) {
                return light_pmf_bvh(s_p, s_n, cut_base, light, false);
            }
            return light_pmf_perfect(s_p, s_n, cut_base, light, false);
        }
    }
}

// Whether an evaluation draws one light per subtree of its share of the cut
// (the paper's estimator: the kinds with cuts, cut_mixture = 0) instead of
// one light_sample.
fn light_per_subtree() -> bool {
    return light_uses_cut() && light_params.cut_mixture == 0u;
}

// The paper's estimator, real-time stochastic lightcuts §2.2 and §4: the
// light drawn with u from subtree j (< light_cut_len) of the pixel's share of
// the cut, by a descent from its cut node; pmf is the probability within that
// subtree. Σ_j f(l_j)/pmf_j over the share estimates the share's lights
// without bias (src/lights/tree/cut.rs TreeSampler::sample_subtree).
// The kinds without cuts have one "subtree", all lights: light_sample.
fn light_sample_subtree(s_p: vec3<f32>, s_n: vec3<f32>, cut_base: u32, j: u32, u: f32) -> LightPick {
    if (!light_uses_cut()) {
        return light_sample(s_p, s_n, cut_base, u);
    }
    if (light_params.count == 0u || j >= light_cut_len(cut_base)) {
        return light_no_pick();
    }
    return light_descend_subtree(s_p, s_n, cut_base, j, u);
}

// light_sample_subtree for a kind with cuts, lights and j < light_cut_len
// (ml_direct's loop, which has checked them).
fn light_descend_subtree(s_p: vec3<f32>, s_n: vec3<f32>, cut_base: u32, j: u32, u: f32) -> LightPick {
    return light_descend(light_cut_node(cut_base, j), s_p, s_n, u, light_pmf_from(1.0));
}

// The probability that light_sample_subtree of the cut node above `light`
// returns it (0 when no node of the pixel's share is above it); light_pmf
// for the kinds without cuts.
fn light_pmf_subtree(s_p: vec3<f32>, s_n: vec3<f32>, cut_base: u32, light: u32) -> LightPmf {
    if (!light_uses_cut()) {
        return light_pmf(s_p, s_n, cut_base, light);
    }
    if (light >= light_params.count) {
        return LightPmf(0.0, 0);
    }
    if (light_uses_bvh()) {
        return light_pmf_bvh(s_p, s_n, cut_base, light, true);
    }
    return light_pmf_perfect(s_p, s_n, cut_base, light, true);
}

// The squared floor of the cut key's distance, (10⁻³·|bmax − bmin|)² of the
// root's box (importance.rs cut_key_floor2; 0 for EMPTY bounds).
fn light_cut_key_floor2() -> f32 {
    let root = light_nodes[0];
    if (root.bmin.x > root.bmax.x) {
        return 0.0;
    }
    let d = root.bmax - root.bmin;
    let e = 1e-3 * sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    return e * e;
}

// Greedy-cut key (docs "Cuts", importance.rs cut_key): −1 = not refinable
// (a leaf or I = 0); else W / max(dmin², floor2), 0 when W = 0, at most the
// largest f32 (also when both distances are 0).
fn light_cut_key(node: u32, x: vec3<f32>, n: vec3<f32>, floor2: f32) -> f32 {
    if (light_is_leaf(node) || !(light_nodes[node].intensity > 0.0)) {
        return -1.0;
    }
    let imp = light_importance_of(node, x, n);
    if (imp.w == 0.0) {
        return 0.0;
    }
    let d = max(imp.dmin2, floor2);
    if (d == 0.0) {
        return bitcast<f32>(0x7f7fffffu);
    }
    return min(imp.w / d, bitcast<f32>(0x7f7fffffu));
}

// The greedy cut of at most light_params.cut_size nodes for the
// representative point (p, n), written to `out` in selection order; returns
// its length (0 without lights or for the kinds without a tree).
fn select_cut(p: vec3<f32>, n: vec3<f32>, out: ptr<function, array<u32, MAX_CUT>>) -> u32 {
    if (light_params.count == 0u || !light_uses_tree()) {
        return 0u;
    }
    let size = clamp(light_params.cut_size, 1u, MAX_CUT);
    var keys: array<f32, MAX_CUT>;
    (*out)[0] = 0u;
    let floor2 = light_cut_key_floor2();
    keys[0] = light_cut_key(0u, p, n, floor2);
    var len = 1u;
    for (var it = 1u; it < MAX_CUT; it++) {
        if (len >= size) {
            break;
        }
        var best = NO_LIGHT;
        for (var j = 0u; j < len; j++) {
            let k = keys[j];
            if (k < 0.0) {
                continue;
            }
            if (best == NO_LIGHT || k > keys[best] || (k == keys[best] && (*out)[j] < (*out)[best])) {
                best = j;
            }
        }
        if (best == NO_LIGHT) {
            break;
        }
        let l = light_left_child((*out)[best]);
        (*out)[best] = l;
        keys[best] = light_cut_key(l, p, n, floor2);
        (*out)[len] = l + 1u;
        keys[len] = light_cut_key(l + 1u, p, n, floor2);
        len += 1u;
    }
    return len;
}
