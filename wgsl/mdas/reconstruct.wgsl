// Reconstruction (paper eq. 7, §4.3): every leaf with a finite mean f̄
// splats w·f̄ onto each pixel its film projection overlaps, w = (exact
// overlap area of the projection with the pixel, raster units) × (volume
// of the leaf's non-film extent), and w itself into a fourth channel. The
// host divides the sums by the weight sum (= the pixel area 1 when every
// leaf has a finite mean; less where a region produced only NaN/Inf).
//
// With RECONSTRUCT_PIXEL (`reconstruction = "pixel"`), pixel p gets
// w·(Σ_{s in p} f_s + κ·f̄)/(n_p + κ) instead of w·f̄: the leaf's n_p finite
// samples whose film position (as evaluate.wgsl placed them) lies in p,
// pulled toward the leaf mean by κ = params.pixel_prior pseudo-samples
// (f̄ alone where n_p = 0). With RECONSTRUCT_SAMPLED as well
// (`reconstruction = "sampled"`), a leaf that has no sample in p adds f̄
// there with the weight UNSAMPLED_WEIGHT·w (2⁻¹⁶·w) instead of w: a pixel
// is estimated from the leaves that placed samples in it, so a leaf
// straddling an edge does not carry its mean (a lamp's, say) onto a pixel
// where it has no sample; only a pixel that no leaf sampled is the
// overlap-weighted mean of the leaf means, as with the box. With
// RECONSTRUCT_SHRINK as well (`reconstruction = "shrinkage"`), κ is the
// leaf's own (leaf_kappa): σ²/τ² from a one-way analysis of variance of
// its samples by pixel. The coordinates are read here, so the
// accumulators then have their own buffer.
//
// Sums are 64-bit two's-complement fixed point, added with a 32-bit
// atomicAdd on the low word and the carry folded into the high word:
// integer addition is associative, so the result does not depend on the
// order of the atomics. Colour terms are scaled by 2^fixed_exp with
// fixed_exp = 60 − ⌈log2 max|f|⌉ (so |Σ| < 2^61 for every pixel; max|f|
// and the exponent from stats.wgsl, which the host reads back to decode
// the sums), weights by 2^60. Each leaf covers at most PIXELS_PER_PASS pixels per dispatch;
// the host dispatches pass_offset = 0, PIXELS_PER_PASS, … as needed, which
// bounds every invocation's loop (lavapipe ends loops at 65,535).

// Round a finite |x| < 2^63 to the nearest-below integer (toward zero),
// as two's-complement 64 bits (lo, hi). floor(|x|/2^32) and the remainder
// are exact in f32 (the remainder is a multiple of ulp(x) below 2^32).
fn to_fixed(x: f32) -> vec2<u32> {
    let a = abs(x);
    let hi_f = floor(a * (1.0 / 4294967296.0));
    let lo_f = a - hi_f * 4294967296.0;
    var lo = u32(lo_f);
    var hi = u32(hi_f);
    if (x < 0.0) {
        lo = ~lo + 1u;
        hi = ~hi + select(0u, 1u, lo == 0u);
    }
    return vec2<u32>(lo, hi);
}

fn add_fixed(word: u32, v: vec2<u32>) {
    if (v.x == 0u && v.y == 0u) {
        return;
    }
    let old = atomicAdd(&accum[word], v.x);
    let carry = select(0u, 1u, old + v.x < old);
    let high = v.y + carry;
    if (high != 0u) {
        atomicAdd(&accum[word + 1u], high);
    }
}

// The κ of `reconstruction = "shrinkage"` for a leaf whose `own` finite
// samples lie in footprint pixels pixel_of with values value_of: the
// empirical-Bayes weight σ²/τ² of the leaf mean in a pixel's estimate,
// from a one-way analysis of variance of the samples' channel sums
// (scaled by their largest magnitude) grouped by pixel: σ² the pooled
// within-pixel variance, τ² = (between mean square − σ²)/n₀ the variance
// of the pixels' true means inside the leaf (n₀ the groups' effective
// size). Pixels that differ beyond their samples' noise (a lamp's edge:
// τ² ≫ σ²) keep their own samples (κ → 0); pixels that differ by no more
// than it (motion blur, soft shadows: τ² ≤ 0) share the leaf mean
// (κ = SHRINK_KAPPA_MAX, the box). Where it cannot be estimated — every
// sample in its own pixel, or one pixel — κ = 0 (`sampled`).
fn leaf_kappa(own: u32, pixel_of: ptr<function, array<u32, MAX_PER_LEAF + 1u>>,
              value_of: ptr<function, array<vec3<f32>, MAX_PER_LEAF + 1u>>) -> f32 {
    var v: array<f32, MAX_PER_LEAF + 1u>;
    var big = 0.0;
    for (var n = 0u; n < own; n++) {
        v[n] = dot((*value_of)[n], vec3<f32>(1.0));
        big = max(big, abs(v[n]));
    }
    if (big == 0.0) {
        return SHRINK_KAPPA_MAX;
    }
    var mean = 0.0;
    for (var n = 0u; n < own; n++) {
        v[n] /= big;
        mean += v[n];
    }
    mean /= f32(own);
    var within = 0.0;
    var between = 0.0;
    var groups = 0u;
    var sum_n2 = 0.0;
    for (var n = 0u; n < own; n++) {
        // Each pixel once, at its first sample.
        var first = true;
        for (var q = 0u; q < n; q++) {
            first = first && (*pixel_of)[q] != (*pixel_of)[n];
        }
        if (!first) {
            continue;
        }
        var count = 0.0;
        var sum = 0.0;
        for (var q = n; q < own; q++) {
            if ((*pixel_of)[q] == (*pixel_of)[n]) {
                count += 1.0;
                sum += v[q];
            }
        }
        let group_mean = sum / count;
        for (var q = n; q < own; q++) {
            if ((*pixel_of)[q] == (*pixel_of)[n]) {
                within += (v[q] - group_mean) * (v[q] - group_mean);
            }
        }
        between += count * (group_mean - mean) * (group_mean - mean);
        groups += 1u;
        sum_n2 += count * count;
    }
    if (groups < 2u || own <= groups) {
        return 0.0;
    }
    let sigma2 = within / f32(own - groups);
    let n0 = (f32(own) - sum_n2 / f32(own)) / f32(groups - 1u);
    let tau2 = (between / f32(groups - 1u) - sigma2) / n0;
    if (tau2 <= 0.0) {
        return SHRINK_KAPPA_MAX;
    }
    return min(sigma2 / tau2, SHRINK_KAPPA_MAX);
}

@compute @workgroup_size(WG)
fn reconstruct(@builtin(global_invocation_id) gid: vec3<u32>,
               @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups, WG);
    if (k >= leaf_count()) {
        return;
    }
    let fixed_exp = bitcast<i32>(state[S_FIXED_EXP]);
    let base = leaf_base(k);
    let h = leaves_get(base + 1u);
    let m = leaf_mean(k, h);
    if (m.finite == 0u) {
        return;
    }
    let cell = leaf_cell_coords(k);
    var nonfilm = 1.0;
    for (var axis = 2u; axis < DIMS; axis++) {
        let word = boxes_get(box_base(k) + axis);
        nonfilm *= ldexp(f32(box_hi(word) - box_lo(word)), -i32(QUANTUM_BITS + axis_bits(axis)));
    }
    let wx = f32(params.width);
    let hy = f32(params.height);
    let bx = boxes_get(box_base(k));
    let by = boxes_get(box_base(k) + 1u);
    let x0 = axis_coord(0u, cell[0], f32(box_lo(bx))) * wx;
    let x1 = axis_coord(0u, cell[0], f32(box_hi(bx))) * wx;
    let y0 = axis_coord(1u, cell[1], f32(box_lo(by))) * hy;
    let y1 = axis_coord(1u, cell[1], f32(box_hi(by))) * hy;
    let i0 = u32(floor(x0));
    let i1 = min(u32(ceil(x1)), params.width);
    let j0 = u32(floor(y0));
    let j1 = min(u32(ceil(y1)), params.height);
    let nx = i1 - i0;
    let total = nx * (j1 - j0);
    // The footprint index t of each finite sample's pixel, and its value.
    var own = 0u;
    var pixel_of: array<u32, MAX_PER_LEAF + 1u>;
    var value_of: array<vec3<f32>, MAX_PER_LEAF + 1u>;
    if (RECONSTRUCT_PIXEL != 0u) {
        for (var n = 0u; n < min(header_count(h), MAX_PER_LEAF + 1u); n++) {
            let s = leaf_slot(k, h, n);
            let bits = sample_value_bits(s);
            if (finite_bits(bits)) {
                let i = u32(sample_raster(0u, cell[0], sample_q(s, 0u)));
                let j = u32(sample_raster(1u, cell[1], sample_q(s, 1u)));
                // Always inside the footprint (the sample is inside the box).
                pixel_of[own] = select(total, (j - j0) * nx + (i - i0),
                                       i >= i0 && i < i1 && j >= j0 && j < j1);
                value_of[own] = bitcast<vec3<f32>>(bits);
                own += 1u;
            }
        }
    }
    var kappa = params.pixel_prior;
    // (Over one pixel κ changes nothing: the pixel holds every sample.)
    if (RECONSTRUCT_SHRINK != 0u && total > 1u) {
        kappa = leaf_kappa(own, &pixel_of, &value_of);
    }
    let end = min(total, params.pass_offset + PIXELS_PER_PASS);
    for (var t = params.pass_offset; t < end; t++) {
        let i = i0 + t % nx;
        let j = j0 + t / nx;
        let ox = min(x1, f32(i + 1u)) - max(x0, f32(i));
        let oy = min(y1, f32(j + 1u)) - max(y0, f32(j));
        if (ox <= 0.0 || oy <= 0.0) {
            continue;
        }
        var w = ox * oy * nonfilm;
        var value = m.mean;
        if (RECONSTRUCT_PIXEL != 0u) {
            var count = 0u;
            for (var n = 0u; n < own; n++) {
                count += select(0u, 1u, pixel_of[n] == t);
            }
            if (count > 0u) {
                // Scaled before summing, as in leaf_mean: no overflow.
                let inv = 1.0 / (f32(count) + kappa);
                value = m.mean * (kappa * inv);
                var own_mean = vec3<f32>(0.0);
                for (var n = 0u; n < own; n++) {
                    if (pixel_of[n] == t) {
                        value += value_of[n] * inv;
                        own_mean += value_of[n] / f32(count);
                    }
                }
                if (RECONSTRUCT_SHRINK != 0u) {
                    // Limited translation in relative terms: within a
                    // factor SHRINK_RATIO of the pixel's own mean.
                    let a = own_mean * SHRINK_RATIO;
                    let b = own_mean / SHRINK_RATIO;
                    value = clamp(value, min(a, b), max(a, b));
                }
            } else if (RECONSTRUCT_SAMPLED != 0u) {
                w *= UNSAMPLED_WEIGHT;
            }
        }
        let word = 8u * (j * params.width + i);
        for (var c = 0u; c < 3u; c++) {
            add_fixed(word + 2u * c, to_fixed(ldexp(value[c] * w, fixed_exp)));
        }
        add_fixed(word + 6u, to_fixed(ldexp(w, 60)));
    }
}
