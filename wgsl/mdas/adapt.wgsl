// Adaptive sampling (paper §4.2), two passes around scan.wgsl:
//   count: every leaf runs the selection test; the selected ones decide
//          (below) whether they split, packed on the first invocations of
//          the workgroup; per-workgroup totals of selected leaves and
//          splits go to `partials`. A selected
//          leaf's error word (recomputed after this iteration anyway)
//          holds the decision until `apply`: 1 | 0 | split | candidate
//          index (6 bits) | axis (4) | plane (16), from bit 31 down: bit
//          31 set and bit 30 clear never occur in an error (finite,
//          non-negative) or in DIRTY. A leaf that cannot split is marked
//          collapsed here.
//   apply: reads the decisions, a workgroup scan plus the scanned
//          workgroup prefixes give each new sample and each right child
//          its slot (in leaf order: deterministic); packed invocations
//          regenerate the winning candidate from its index and update the
//          leaf.
// Decision of leaf k in iteration t (random numbers: draw(leaf_key(k, t),
// stream), see common.wgsl):
//   * collapsed leaves are skipped;
//   * selected iff E = E_max or E ≥ E_max·(ξ/c)^(1/α) (⇔ c·(E/E_max)^α
//     ≥ ξ, ξ ∈ (0,1) stream 0; α = 0 selects all); c = 1 is the paper's
//     rule, the paced selection raises it (1/c = state[S_INV_PACE],
//     plan.wgsl);
//   * best candidate: CANDIDATES uniform quanta in the box (candidate c,
//     axis a: 16 bits of stream 1 + c·COORD_WORDS + a/2, low half for even
//     a, high for odd), the one farthest (scaled squared distance) from
//     the leaf's own samples wins, first on ties;
//   * a leaf holding MAX_PER_LEAF samples splits once the candidate is in:
//     on the axis with the largest scaled extent among those where the
//     object median separates (sorted quanta v[h−1] < v[h], h = ⌊(m+1)/2⌋)
//     at plane ⌈(v[h−1] + v[h]) / 2⌉; left keeps h samples and the leaf
//     slot, right (m + 1 − h) is appended. If no axis separates, the leaf
//     is marked collapsed instead and takes no sample (it stops splitting).
// Budget: with S selected leaves and R samples left, S ≤ R inserts all;
// otherwise the selected leaf of rank r keeps its sample iff
// ⌊(r+1)R/S⌋ > ⌊rR/S⌋ (exactly R, spread evenly over the leaf order), and
// that last iteration does not split.

struct Decision {
    selected: bool,
    split: bool,
    collapse: bool,
    axis: u32,
    plane: u32,
    cand_index: u32,
    cand: array<u32, DIMS>,
}

// Values in a full leaf's split test: its samples and the candidate.
const SPLIT_N: u32 = MAX_PER_LEAF + 1u;

const DECISION_MARK: u32 = 0x80000000u;
const DECISION_MASK: u32 = 0xc0000000u;
const DECISION_SPLIT: u32 = 0x04000000u;

fn encode_decision(d: Decision) -> u32 {
    return DECISION_MARK | select(0u, DECISION_SPLIT, d.split) | (d.cand_index << 20u) | (d.axis << 16u) | d.plane;
}

// Candidate c of the leaf with key `key`: uniform quanta of its box, two
// axes per draw (16 bits each).
fn candidate(key: u32, c: u32, lo: array<u32, DIMS>, hi: array<u32, DIMS>) -> array<u32, DIMS> {
    var q: array<u32, DIMS>;
    for (var axis = 0u; axis < DIMS; axis++) {
        let r = draw(key, 1u + c * COORD_WORDS + axis / 2u);
        let r16 = select(r & 0xffffu, r >> 16u, axis % 2u == 1u);
        q[axis] = lo[axis] + uniform_below(r16, hi[axis] - lo[axis]);
    }
    return q;
}

// E_max, read once per workgroup (count) and broadcast.
var<workgroup> wg_emax: u32;

// Whether leaf k is selected in this iteration (collapsed leaves never are).
fn selected_now(k: u32, emax_bits: u32) -> bool {
    if (k >= leaf_count()) {
        return false;
    }
    let base = leaf_base(k);
    if (header_collapsed(leaves_get(base + 1u))) {
        return false;
    }
    let e_bits = leaves_get(base + 2u);
    if (e_bits == emax_bits || params.select_all != 0u) {
        return true;
    }
    let xi = draw_open(leaf_key(k, iteration()), 0u);  // stream 0
    let inv_pace = bitcast<f32>(state[S_INV_PACE]);
    return bitcast<f32>(e_bits) >= bitcast<f32>(emax_bits) * pow(xi * inv_pace, params.inv_alpha);
}

// The bound n of one of decide's loops. With UNROLL_LOOPS = 0 (CPU
// adapters, Config::unroll_loops) the compiler cannot see that it is the
// constant n (arrayLength(&state) · 4096 > n, unknown until run time), so
// it keeps the loop: unrolled, the count kernel outgrows llvmpipe's
// budget of compiled instructions and is rebuilt at every dispatch.
fn loop_bound(n: u32) -> u32 {
    if (UNROLL_LOOPS == 1u) {
        return n;
    }
    return min(n, arrayLength(&state) * 4096u);
}

// The decision of a selected leaf k: best candidate, split or collapse.
fn decide(k: u32) -> Decision {
    var d: Decision;
    d.selected = false;
    d.split = false;
    d.collapse = false;
    d.axis = 0u;
    d.plane = 0u;
    let h = leaves_get(leaf_base(k) + 1u);
    let key = leaf_key(k, iteration());

    // The leaf's samples' coordinates, read once (a selectable leaf holds
    // at most MAX_PER_LEAF: a full one splits when the next arrives).
    // Every loop over a leaf's samples or axes below runs a constant
    // number of times (MAX_PER_LEAF, DIMS), masked by `i < count` where
    // needed, so that compilers unroll them and keep these arrays in
    // registers (indexed by a loop counter that is not a constant, a
    // private array lives in memory: on lavapipe per-lane gathers) —
    // on a GPU; on a CPU adapter `loop_bound` keeps them loops. The
    // slots are loaded first: every load after them is independent.
    let count = min(header_count(h), MAX_PER_LEAF);
    var slots: array<u32, MAX_PER_LEAF>;
    for (var i = 0u; i < loop_bound(MAX_PER_LEAF); i++) {
        if (i < count) {
            slots[i] = leaf_slot(k, h, i);
        }
    }
    var coords: array<u32, MAX_PER_LEAF * COORD_WORDS>;
    // With the contrast split: each sample's channel sum, and whether it
    // is finite.
    var value: array<f32, MAX_PER_LEAF>;
    var finite: array<bool, MAX_PER_LEAF>;
    for (var i = 0u; i < loop_bound(MAX_PER_LEAF); i++) {
        if (i < count) {
            let s = slots[i];
            for (var w = 0u; w < loop_bound(COORD_WORDS); w++) {
                coords[i * COORD_WORDS + w] = samples_get(s * SAMPLE_STRIDE + w);
            }
            if (SPLIT_CONTRAST == 1u) {
                let bits = sample_value_bits(s);
                finite[i] = finite_bits(bits);
                let v = bitcast<vec3<f32>>(bits);
                value[i] = v.x + v.y + v.z;
            }
        }
    }

    // The trimmed rule: the finite sample whose channel sum lies farthest
    // from the finite ones' mean (the first on ties) takes no part in the
    // halves' means, when at least three are finite.
    if (SPLIT_TRIM == 1u && count >= MAX_PER_LEAF) {
        var sum = 0.0;
        var n = 0u;
        for (var i = 0u; i < loop_bound(MAX_PER_LEAF); i++) {
            if (i < count && finite[i]) {
                sum += value[i];
                n += 1u;
            }
        }
        if (n >= 3u) {
            let mean = sum / f32(n);
            var worst = -1.0;
            var j = 0u;
            for (var i = 0u; i < loop_bound(MAX_PER_LEAF); i++) {
                let d = abs(value[i] - mean);
                if (i < count && finite[i] && d > worst) {
                    worst = d;
                    j = i;
                }
            }
            for (var i = 0u; i < loop_bound(MAX_PER_LEAF); i++) {
                finite[i] = finite[i] && i != j;
            }
        }
    }

    // Best candidate among CANDIDATES uniform points of the box.
    var quantum: array<f32, DIMS>;
    var lo: array<u32, DIMS>;
    var hi: array<u32, DIMS>;
    for (var axis = 0u; axis < loop_bound(DIMS); axis++) {
        quantum[axis] = axis_quantum(axis);
        let word = boxes_get(box_base(k) + axis);
        lo[axis] = box_lo(word);
        hi[axis] = box_hi(word);
    }
    var best = -1.0;
    for (var c = 0u; c < loop_bound(CANDIDATES); c++) {
        let q = candidate(key, c, lo, hi);
        var nearest = 3.0e38;
        for (var i = 0u; i < loop_bound(MAX_PER_LEAF); i++) {
            var dist = 0.0;
            for (var axis = 0u; axis < loop_bound(DIMS); axis++) {
                let sq = (coords[i * COORD_WORDS + axis / 2u] >> (16u * (axis % 2u))) & 0xffffu;
                let t = (f32(q[axis]) - f32(sq)) * quantum[axis];
                dist += t * t;
            }
            nearest = select(nearest, min(nearest, dist), i < count);
        }
        if (nearest > best) {
            best = nearest;
            d.cand = q;
            d.cand_index = c;
        }
    }

    // Split test on the m = MAX_PER_LEAF existing samples plus the
    // candidate: SPLIT_N values per axis, whose order statistics h − 1
    // and h come from ranks (ties broken by position), not a sort.
    if (count >= MAX_PER_LEAF) {
        let half = SPLIT_N / 2u;
        var best_extent = -1.0;
        var best_contrast = -1.0;
        for (var axis = 0u; axis < loop_bound(DIMS); axis++) {
            var v: array<u32, SPLIT_N>;
            for (var i = 0u; i < loop_bound(MAX_PER_LEAF); i++) {
                v[i] = (coords[i * COORD_WORDS + axis / 2u] >> (16u * (axis % 2u))) & 0xffffu;
            }
            v[MAX_PER_LEAF] = d.cand[axis];
            var below_median = 0u;
            var above_median = 0u;
            for (var i = 0u; i < loop_bound(SPLIT_N); i++) {
                var rank = 0u;
                for (var j = 0u; j < loop_bound(SPLIT_N); j++) {
                    rank += u32(v[j] < v[i] || (v[j] == v[i] && j < i));
                }
                below_median = select(below_median, v[i], rank == half - 1u);
                above_median = select(above_median, v[i], rank == half);
            }
            if (below_median < above_median) {
                let extent = f32(hi[axis] - lo[axis]) * quantum[axis];
                let plane = (below_median + above_median + 1u) / 2u;
                var contrast = 0.0;
                if (SPLIT_CONTRAST == 1u) {
                    // |mean below the plane − mean above| of the existing
                    // finite samples' channel sums.
                    var sum = vec2<f32>(0.0);
                    var n = vec2<u32>(0u);
                    for (var i = 0u; i < loop_bound(MAX_PER_LEAF); i++) {
                        if (finite[i]) {
                            if (v[i] < plane) {
                                sum.x += value[i];
                                n.x += 1u;
                            } else {
                                sum.y += value[i];
                                n.y += 1u;
                            }
                        }
                    }
                    if (n.x > 0u && n.y > 0u) {
                        contrast = abs(sum.x / f32(n.x) - sum.y / f32(n.y));
                    }
                }
                if (contrast > best_contrast || (contrast == best_contrast && extent > best_extent)) {
                    best_contrast = contrast;
                    best_extent = extent;
                    d.axis = axis;
                    d.plane = plane;
                }
            }
        }
        if (best_extent < 0.0) {
            d.collapse = true;
            return d;
        }
        d.split = true;
    }
    d.selected = true;
    return d;
}

// The count pass in three steps: every invocation runs the selection
// test of its leaf and appends a selected leaf to the workgroup's list;
// then the first invocations decide one listed leaf each, so the costly
// part (best candidate, split test) runs on packed invocations instead of
// on the scattered selected ones among all (a SIMD group or warp pays for
// the decision if any of its lanes decides); the workgroup's totals are
// sums, so the list's order (atomics) changes nothing.
var<workgroup> wg_list: array<u32, WG>;
var<workgroup> wg_listed: atomic<u32>;
var<workgroup> wg_selected: atomic<u32>;
var<workgroup> wg_splits: atomic<u32>;

@compute @workgroup_size(WG)
fn count(@builtin(global_invocation_id) gid: vec3<u32>,
         @builtin(local_invocation_index) lid: u32,
         @builtin(workgroup_id) wid: vec3<u32>,
         @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups, WG);
    if (lid == 0u) {
        wg_emax = atomicLoad(&counters[C_EMAX]);
        atomicStore(&wg_listed, 0u);
        atomicStore(&wg_selected, 0u);
        atomicStore(&wg_splits, 0u);
    }
    if (selected_now(k, workgroupUniformLoad(&wg_emax))) {
        wg_list[atomicAdd(&wg_listed, 1u)] = k;
    }
    workgroupBarrier();
    let listed = atomicLoad(&wg_listed);
    if (lid < listed) {
        let leaf = wg_list[lid];
        let d = decide(leaf);
        if (d.collapse) {
            leaves_set(leaf_base(leaf) + 1u, leaves_get(leaf_base(leaf) + 1u) | COLLAPSED_BIT);
            atomicAdd(&counters[C_COLLAPSED], 1u);
        }
        if (d.selected) {
            leaves_set(leaf_base(leaf) + 2u, encode_decision(d));
            atomicAdd(&wg_selected, 1u);
            if (d.split) {
                atomicAdd(&wg_splits, 1u);
            }
        }
    }
    workgroupBarrier();
    let g = workgroup_index(wid, groups);
    if (lid == 0u && g < leaf_groups()) {
        partials[2u * g] = atomicLoad(&wg_selected);
        partials[2u * g + 1u] = atomicLoad(&wg_splits);
    }
}

// ⌊a·b / c⌋ for a ≤ c (so the quotient fits in 32 bits), c ≤ 2^31:
// 32×32 → 64-bit product from 16-bit halves, then binary long division.
fn mul_div(a: u32, b: u32, c: u32) -> u32 {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    let lo = (p00 & 0xffffu) | (mid << 16u);
    let hi = a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    var rem = 0u;
    var q = 0u;
    for (var i = 0u; i < 64u; i++) {
        let bit_pos = 63u - i;
        var bit: u32;
        if (bit_pos >= 32u) {
            bit = (hi >> (bit_pos - 32u)) & 1u;
        } else {
            bit = (lo >> bit_pos) & 1u;
        }
        rem = (rem << 1u) | bit;
        q = q << 1u;
        if (rem >= c) {
            rem -= c;
            q |= 1u;
        }
    }
    return q;
}

// The apply pass: a workgroup scan of the decisions gives each selected
// leaf its rank among the workgroup's selected leaves and splits; the
// selected leaves are listed in rank order and the first invocations
// apply one each (packed, as in `count`).
var<workgroup> wg_rank: array<vec2<u32>, WG>;

@compute @workgroup_size(WG)
fn apply(@builtin(global_invocation_id) gid: vec3<u32>,
         @builtin(local_invocation_index) lid: u32,
         @builtin(workgroup_id) wid: vec3<u32>,
         @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups, WG);
    var word = 0u;
    if (k < leaf_count()) {
        word = leaves_get(leaf_base(k) + 2u);
    }
    let selected = (word & DECISION_MASK) == DECISION_MARK;
    let split = selected && (word & DECISION_SPLIT) != 0u;
    let local = workgroup_scan(lid, vec2<u32>(u32(selected), u32(split)));
    let listed = wg_total.x;
    if (selected) {
        wg_list[local.x] = k;
        wg_rank[local.x] = local;
    }
    workgroupBarrier();
    if (lid < listed) {
        apply_leaf(wg_list[lid], wg_rank[lid], workgroup_index(wid, groups));
    }
}

// Applies the decision of selected leaf k, whose ranks among its
// workgroup's (number g) selected leaves and splits are `local`.
fn apply_leaf(k: u32, local: vec2<u32>, g: u32) {
    let leaf_total = leaf_count();
    let word = leaves_get(leaf_base(k) + 2u);
    let split = (word & DECISION_SPLIT) != 0u;
    let base = leaf_base(k);
    let h = leaves_get(base + 1u);
    // Recomputed next iteration, whether or not the sample is kept.
    leaves_set(base + 2u, DIRTY);
    var d: Decision;
    d.split = split;
    d.axis = (word >> 16u) & 15u;
    d.plane = word & 0xffffu;
    var lo: array<u32, DIMS>;
    var hi: array<u32, DIMS>;
    for (var axis = 0u; axis < DIMS; axis++) {
        let box = boxes_get(box_base(k) + axis);
        lo[axis] = box_lo(box);
        hi[axis] = box_hi(box);
    }
    d.cand = candidate(leaf_key(k, iteration()), (word >> 20u) & 63u, lo, hi);
    let n = state[S_SAMPLES];
    let left_over = params.budget - n;
    let selected_total = state[S_SELECTED];
    let truncate = selected_total > left_over;
    let rank = partials[2u * g] + local.x;
    var slot = n + rank;
    if (truncate) {
        let before = mul_div(rank, left_over, selected_total);
        let after = mul_div(rank + 1u, left_over, selected_total);
        if (after == before) {
            return;
        }
        slot = n + after - 1u;
    }

    // Write the new sample; the evaluate kernel finds its cell in values.
    var words: array<u32, COORD_WORDS>;
    for (var w = 0u; w < COORD_WORDS; w++) {
        words[w] = 0u;
    }
    for (var axis = 0u; axis < DIMS; axis++) {
        words[axis / 2u] |= d.cand[axis] << (16u * (axis % 2u));
    }
    for (var w = 0u; w < COORD_WORDS; w++) {
        samples_set(slot * SAMPLE_STRIDE + w, words[w]);
    }
    values_set(3u * slot, leaves_get(base));
    let count = header_count(h);

    if (!d.split || truncate) {
        // Appended in slot `count` (≤ MAX_PER_LEAF: a trimmed iteration
        // may fill a full leaf's last slot, the error word marked DIRTY
        // above; no error pass follows that iteration).
        set_leaf_slot(k, count, slot);
        leaves_set(base + 1u, make_header(header_first(h), count + 1u));
        return;
    }

    // Object-median split of the m + 1 samples (a leaf splits only when
    // full: its m slots in order, then the new one): the left ones stay in
    // leaf k's slots, compacted in order (each is written at or before
    // where it was read, and all were read first), the right ones go to
    // the new leaf in order. Every index into `all` and `side` is a
    // constant once the loops are unrolled: registers, not memory.
    var all: array<u32, SPLIT_N>;
    for (var i = 0u; i < MAX_PER_LEAF; i++) {
        all[i] = leaf_slot(k, h, i);
    }
    all[MAX_PER_LEAF] = slot;
    var side: array<bool, SPLIT_N>;
    for (var i = 0u; i < SPLIT_N; i++) {
        side[i] = sample_q(all[i], d.axis) >= d.plane;
    }
    let right = leaf_total + partials[2u * g + 1u] + local.y;
    var left_count = 0u;
    var right_count = 0u;
    var left_first = 0u;
    var right_first = 0u;
    for (var i = 0u; i < SPLIT_N; i++) {
        let s = all[i];
        if (side[i]) {
            if (right_count == 0u) {
                right_first = s;
            } else {
                set_leaf_slot(right, right_count, s);
            }
            right_count += 1u;
        } else {
            if (left_count == 0u) {
                left_first = s;
            } else {
                set_leaf_slot(k, left_count, s);
            }
            left_count += 1u;
        }
    }
    let rbase = leaf_base(right);
    let axis_word = boxes_get(box_base(k) + d.axis);
    for (var axis = 0u; axis < DIMS; axis++) {
        boxes_set(box_base(right) + axis, boxes_get(box_base(k) + axis));
    }
    boxes_set(box_base(k) + d.axis, make_box(box_lo(axis_word), d.plane));
    boxes_set(box_base(right) + d.axis, make_box(d.plane, box_hi(axis_word)));
    leaves_set(base + 1u, make_header(left_first, left_count));
    leaves_set(rbase, leaves_get(base));
    leaves_set(rbase + 1u, make_header(right_first, right_count));
    leaves_set(rbase + 2u, DIRTY);
}
