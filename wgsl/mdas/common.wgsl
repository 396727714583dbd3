// Bindings, parameters and storage layout shared by the MDAS kernels.
// src/integrator/mdas/mod.rs documents the layout and generates the
// constants used here: DIMS, BITS_PER_DIM, EXTRA_BITS, SAMPLES_PER_CELL,
// MAX_PER_LEAF, CANDIDATES, RECONSTRUCT_PIXEL, COORD_WORDS, SAMPLE_STRIDE, LEAF_STRIDE, WG,
// STATS_PER_INVOCATION, PIXELS_PER_PASS, the leaf header's INDEX_MASK,
// COUNT_SHIFT, COLLAPSED_BIT and DIRTY (src/integrator/mdas/words.rs) and
// the indices C_* (counters) and S_* (state). Needs shared/rng.wgsl and shared/morton.wgsl.
//
// The iteration state (leaf and sample counts, iteration number, the
// range to evaluate, the stop flag) lives in `state` on the GPU, not in
// `params`: plan.wgsl advances it after every iteration and writes the
// next dispatches' indirect arguments, so the host records many
// iterations in one submission and never waits inside the loop.
//
// leaves[k·LEAF_STRIDE + …] (LEAF_STRIDE = 3): 0 Morton cell, 1 header
// (slot 0 | count << COUNT_SHIFT | collapsed << 31), 2 error bits (DIRTY =
// recompute): the words every pass reads for every leaf.
// boxes[k·BOX_STRIDE + …] (BOX_STRIDE = DIMS + MAX_PER_LEAF − 1), read only
// for the leaves that change: 0 … DIMS − 1 the box along each axis (lo |
// hi << 16, inclusive quanta of the cell, 2^16 each), then slots 1 …
// MAX_PER_LEAF − 1. The slots are the indices of the leaf's samples, in
// order. Slot MAX_PER_LEAF (m + 1 samples) occurs only in a trimmed last
// iteration, after which no error is computed: it is kept in the error
// word. Inline indices: a kernel loads a leaf's samples with independent
// loads, not a chain through the samples. Two buffers so that neither
// binding outgrows 128 MiB as soon as the samples' values do.
// samples[s·SAMPLE_STRIDE + …]: SAMPLE_STRIDE = ⌈DIMS/2⌉ words of two
// 16-bit quanta (cell-relative). Only placement reads them, so the
// reconstruction reuses this buffer for its accumulators.
// values[3s + c]: f32 bits of channel c (an unevaluated sample holds its
// Morton cell in values[3s]).

struct Params {
    seed: u32,
    budget: u32,
    max_iterations: u32,
    // Largest workgroup count per dispatch dimension (adapter limit).
    max_groups: u32,
    pass_offset: u32,
    width: u32,
    height: u32,
    select_all: u32,
    scale_factor: f32,
    inv_alpha: f32,
    epsilon: f32,
    // κ of the per-pixel reconstruction (RECONSTRUCT_PIXEL).
    pixel_prior: f32,
    // The paced selection (plan.wgsl): the share of the samples left that
    // an iteration aims to place (0: the paper's rule), and the fewest.
    pace: f32,
    pace_floor: u32,
    // The fewest workgroups an evaluate dispatch aims for (plan.wgsl
    // `evaluate_groups`): four per hardware thread on a CPU adapter.
    eval_min_groups: u32,
    _pad4: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// Bindings 1 (leaves), 2 (samples), 3 (values) and 7 (boxes) are paged
// arrays, declared with their accessors leaves_get / leaves_set, … by
// `Pages::wgsl` (src/integrator/mdas/config.rs): one binding each while
// the array fits the adapter's largest storage binding, else pages of
// 2^PAGE_SHIFT words at bindings 9 and up. Kernels index them only
// through the accessors.
@group(0) @binding(4) var<storage, read_write> partials: array<u32>;
@group(0) @binding(5) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> accum: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read_write> state: array<u32>;

const QUANTUM_BITS: u32 = 16u;

// counters[C_*]: words updated with atomics by many invocations;
// state[S_*]: written by one invocation at a time, read by all with plain
// loads. The indices are generated from `counter` and `state` in
// src/integrator/mdas/mod.rs, which documents each word.

fn leaf_count() -> u32 {
    return state[S_LEAVES];
}

fn iteration() -> u32 {
    return state[S_ITERATION];
}

// Linear thread index of a 2D dispatch of `groups.x × groups.y`
// workgroups of `size` invocations (direct or indirect: the width comes
// from the num_workgroups built-in).
fn thread_index(gid: vec3<u32>, groups: vec3<u32>, size: u32) -> u32 {
    return gid.x + gid.y * groups.x * size;
}

fn workgroup_index(wid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return wid.x + wid.y * groups.x;
}

// Workgroups over the leaves (entries of `partials`).
fn leaf_groups() -> u32 {
    return (leaf_count() + WG - 1u) / WG;
}

// ---- random numbers keyed by (leaf, iteration, stream) and the seed ----

// The key of (leaf, iteration) under the seed: three hash rounds, once
// per leaf and kernel.
fn leaf_key(leaf: u32, iteration: u32) -> u32 {
    return hash3(leaf, iteration, params.seed);
}

// Draw number `stream` of a key: one more hash round.
fn draw(key: u32, stream: u32) -> u32 {
    return hash_u32(key + stream * 0x9e3779b9u);
}

// Uniform in the open interval (0, 1).
fn draw_open(key: u32, stream: u32) -> f32 {
    return (f32(draw(key, stream) >> 8u) + 0.5) * (1.0 / 16777216.0);
}

// Uniform integer in [0, n), n ≤ 2^16, from 16 random bits r16.
fn uniform_below(r16: u32, n: u32) -> u32 {
    return (r16 * n) >> 16u;
}

// ---- leaves ----

fn leaf_base(k: u32) -> u32 {
    return k * LEAF_STRIDE;
}

const BOX_STRIDE: u32 = DIMS + MAX_PER_LEAF - 1u;

fn box_base(k: u32) -> u32 {
    return k * BOX_STRIDE;
}

// Slot 0 of a leaf (its first sample), kept in the header.
fn header_first(h: u32) -> u32 {
    return h & INDEX_MASK;
}

fn header_count(h: u32) -> u32 {
    return (h >> COUNT_SHIFT) & 15u;
}

fn header_collapsed(h: u32) -> bool {
    return (h & COLLAPSED_BIT) != 0u;
}

fn make_header(first: u32, count: u32) -> u32 {
    return first | (count << COUNT_SHIFT);
}

// Sample index in slot i of leaf k with header h (i < header_count(h)).
fn leaf_slot(k: u32, h: u32, i: u32) -> u32 {
    if (i == 0u) {
        return header_first(h);
    }
    if (i == MAX_PER_LEAF) {
        return leaves_get(leaf_base(k) + 2u);
    }
    return boxes_get(box_base(k) + DIMS + i - 1u);
}

// Stores sample s in slot i ≥ 1 of leaf k (slot 0 goes in the header,
// slot MAX_PER_LEAF in the error word: trimmed last iteration only).
fn set_leaf_slot(k: u32, i: u32, s: u32) {
    if (i == MAX_PER_LEAF) {
        leaves_set(leaf_base(k) + 2u, s);
    } else {
        boxes_set(box_base(k) + DIMS + i - 1u, s);
    }
}

fn box_lo(word: u32) -> u32 {
    return word & 0xffffu;
}

// Exclusive upper bound in quanta (1 ..= 2^16).
fn box_hi(word: u32) -> u32 {
    return (word >> 16u) + 1u;
}

fn make_box(lo: u32, hi_exclusive: u32) -> u32 {
    return lo | ((hi_exclusive - 1u) << 16u);
}

// ---- samples ----

fn sample_q(s: u32, axis: u32) -> u32 {
    return (samples_get(s * SAMPLE_STRIDE + axis / 2u) >> (16u * (axis % 2u))) & 0xffffu;
}

fn sample_value_bits(s: u32) -> vec3<u32> {
    return vec3<u32>(values_get(3u * s), values_get(3u * s + 1u), values_get(3u * s + 2u));
}

fn finite_bits(v: vec3<u32>) -> bool {
    let e = v & vec3<u32>(0x7f800000u);
    return all(e != vec3<u32>(0x7f800000u));
}

// The largest f32 strictly below x > 0.
fn below(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) - 1u);
}

// ---- cell geometry ----

// Bits of cell coordinate along `axis` (b, plus e for film axes).
fn axis_bits(axis: u32) -> u32 {
    return BITS_PER_DIM + select(0u, EXTRA_BITS, axis < 2u);
}

// Extent of the scaled domain along `axis`: sf·W, sf·H, else 1 (§5.1).
fn axis_side(axis: u32) -> f32 {
    if (axis == 0u) {
        return params.scale_factor * f32(params.width);
    }
    if (axis == 1u) {
        return params.scale_factor * f32(params.height);
    }
    return 1.0;
}

// Normalized [0, 1] coordinate of quantum boundary q of cell coordinate c.
fn axis_coord(axis: u32, c: u32, q: f32) -> f32 {
    return ldexp(f32(c) * 65536.0 + q, -i32(QUANTUM_BITS + axis_bits(axis)));
}

// Size of one quantum along `axis` in the scaled domain.
fn axis_quantum(axis: u32) -> f32 {
    return ldexp(axis_side(axis), -i32(QUANTUM_BITS + axis_bits(axis)));
}

// Normalized coordinate of sample quantum q (its centre) of cell
// coordinate c, below 1.
fn sample_coord(axis: u32, c: u32, q: u32) -> f32 {
    return min(axis_coord(axis, c, f32(q) + 0.5), ONE_MINUS_EPSILON);
}

// Raster coordinate (film axis 0 or 1) of sample quantum q of cell
// coordinate c, below the film size: where evaluate.wgsl puts the sample.
fn sample_raster(axis: u32, c: u32, q: u32) -> f32 {
    let size = select(f32(params.height), f32(params.width), axis == 0u);
    return min(sample_coord(axis, c, q) * size, below(size));
}

fn leaf_cell_coords(k: u32) -> array<u32, MAX_DIMS> {
    return morton_decode(leaves_get(leaf_base(k)), DIMS, BITS_PER_DIM, EXTRA_BITS);
}

// A leaf holds at most MAX_PER_LEAF + 1 samples (a full leaf that takes
// one more splits, except in the trimmed last iteration).
const LEAF_SAMPLES: u32 = MAX_PER_LEAF + 1u;

// The value bits of a leaf's samples. Loops over them run LEAF_SAMPLES
// times, masked by `i < count`, so that compilers unroll them and keep
// the array in registers; the slots are loaded first, then the values,
// all independent loads.
struct LeafValues {
    bits: array<vec3<u32>, LEAF_SAMPLES>,
    count: u32,
}

fn leaf_values(k: u32, h: u32) -> LeafValues {
    var v: LeafValues;
    v.count = min(header_count(h), LEAF_SAMPLES);
    var slots: array<u32, LEAF_SAMPLES>;
    for (var i = 0u; i < LEAF_SAMPLES; i++) {
        if (i < v.count) {
            slots[i] = leaf_slot(k, h, i);
        }
    }
    for (var i = 0u; i < LEAF_SAMPLES; i++) {
        if (i < v.count) {
            v.bits[i] = sample_value_bits(slots[i]);
        }
    }
    return v;
}

// Whether sample i of `v` exists and is finite.
fn leaf_value_finite(v: LeafValues, i: u32) -> bool {
    return i < v.count && finite_bits(v.bits[i]);
}

// Mean of the finite samples of a leaf (w = number of them).
struct LeafMean {
    mean: vec3<f32>,
    finite: u32,
}

fn values_mean(v: LeafValues) -> LeafMean {
    var n = 0u;
    for (var i = 0u; i < LEAF_SAMPLES; i++) {
        n += u32(leaf_value_finite(v, i));
    }
    var mean = vec3<f32>(0.0);
    if (n > 0u) {
        // Each term is scaled before summing so that the sum cannot overflow.
        let inv_n = 1.0 / f32(n);
        for (var i = 0u; i < LEAF_SAMPLES; i++) {
            if (leaf_value_finite(v, i)) {
                mean += bitcast<vec3<f32>>(v.bits[i]) * inv_n;
            }
        }
    }
    return LeafMean(mean, n);
}

fn leaf_mean(k: u32, h: u32) -> LeafMean {
    return values_mean(leaf_values(k, h));
}

// ---- workgroup scan (two-level, deterministic) ----
//
// WG/SEGMENT segments of SEGMENT values: the first WG/SEGMENT invocations
// scan one segment each, invocation 0 scans the segment totals. Three
// barriers instead of the 2·log2(WG) of a Hillis–Steele scan: barriers are
// what costs on CPU drivers (lavapipe runs a workgroup as coroutines), and
// the serial runs of 16 are short on GPUs too.

const SEGMENT: u32 = 16u;

var<workgroup> wg_scan: array<vec2<u32>, WG>;
var<workgroup> wg_segment: array<vec2<u32>, 16>;
var<workgroup> wg_total: vec2<u32>;

// Exclusive prefix sum of `v` over the workgroup; afterwards wg_total
// holds the workgroup total. Call in uniform control flow.
fn workgroup_scan(lid: u32, v: vec2<u32>) -> vec2<u32> {
    wg_scan[lid] = v;
    workgroupBarrier();
    if (lid < WG / SEGMENT) {
        var run = vec2<u32>(0u);
        for (var i = 0u; i < SEGMENT; i++) {
            let x = wg_scan[lid * SEGMENT + i];
            wg_scan[lid * SEGMENT + i] = run;
            run += x;
        }
        wg_segment[lid] = run;
    }
    workgroupBarrier();
    if (lid == 0u) {
        var run = vec2<u32>(0u);
        for (var i = 0u; i < WG / SEGMENT; i++) {
            let x = wg_segment[i];
            wg_segment[i] = run;
            run += x;
        }
        wg_total = run;
    }
    workgroupBarrier();
    return wg_scan[lid] + wg_segment[lid / SEGMENT];
}
