// Per-pixel adaptive Halton with Blender Cycles' adaptive-sampling rule:
// the control kernels (no integrand), over adaptive.wgsl. See
// src/integrator/adaptive.rs.
//
// Per pixel p:
//   adaptive_sums[4p + 0, 1]: Σ f over its finite samples (rgb, count w)
//     and the Kahan compensation of that sum;
//   adaptive_sums[4p + 2, 3]: the same over its class-A samples only
//     (Cycles' AUX pass: popcount(index & 0xaaaaaaaa) odd);
//   adaptive_state[4p + 0]: samples taken (the next sample index),
//   adaptive_state[4p + 1]: 1 while the pixel takes samples (the dilated
//     unconverged mask), adaptive_state[4p + 2]: 1 where the last check
//     found it unconverged (before dilation).
//
// A round: `reduce`, `scan`, `apply` compact the pixels that want samples
// into adaptive_list (reduce-then-scan, no look-back), each entry
// (pixel, samples this round, first sample index); adaptive_evaluate.wgsl
// `evaluate` writes partial sums per (entry, slot); `accumulate` adds
// them in slot order; after a full round `check` and `dilate` update the
// mask. No atomics: the image is a deterministic function of the inputs.

@group(0) @binding(3) var<storage, read_write> adaptive_sums: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> adaptive_state: array<u32>;
@group(0) @binding(5) var<storage, read_write> adaptive_groups: array<vec2<u32>>;
@group(0) @binding(6) var<storage, read_write> adaptive_totals: array<u32>;

// ------------------------------------------------------------ compaction

var<workgroup> adaptive_scan_buf: array<vec2<u32>, ADAPTIVE_SCAN_WG>;

// Exclusive prefix sum of `v` over the workgroup (Hillis-Steele, 8
// steps); every invocation must call it (uniform control flow).
fn adaptive_workgroup_scan(lid: u32, v: vec2<u32>) -> vec2<u32> {
    adaptive_scan_buf[lid] = v;
    workgroupBarrier();
    for (var offset = 1u; offset < ADAPTIVE_SCAN_WG; offset = offset * 2u) {
        var t = vec2<u32>(0u);
        if (lid >= offset) {
            t = adaptive_scan_buf[lid - offset];
        }
        workgroupBarrier();
        adaptive_scan_buf[lid] = adaptive_scan_buf[lid] + t;
        workgroupBarrier();
    }
    let inclusive = adaptive_scan_buf[lid];
    workgroupBarrier();
    return inclusive - v;
}

// (1, samples it asks for) for a pixel that takes samples this round,
// (0, 0) otherwise.
fn adaptive_want(p: u32) -> vec2<u32> {
    if (p >= adaptive_pixels()) {
        return vec2<u32>(0u);
    }
    let taken = adaptive_state[4u * p];
    if (adaptive_state[4u * p + 1u] == 0u || taken >= adaptive_params.spp_max) {
        return vec2<u32>(0u);
    }
    return vec2<u32>(1u, min(adaptive_params.round_samples, adaptive_params.spp_max - taken));
}

@compute @workgroup_size(ADAPTIVE_SCAN_WG)
fn reduce(@builtin(workgroup_id) wid: vec3<u32>,
          @builtin(num_workgroups) nwg: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    let g = wid.x + wid.y * nwg.x;
    let v = adaptive_want(g * ADAPTIVE_SCAN_WG + lid);
    let before = adaptive_workgroup_scan(lid, v);
    if (lid == ADAPTIVE_SCAN_WG - 1u && g < adaptive_params.pixel_groups) {
        adaptive_groups[g] = before + v;
    }
}

// One workgroup: the groups' totals into exclusive prefixes, in place;
// the grand totals (pixels, samples) into adaptive_totals. Each
// invocation sums a contiguous chunk of ⌈G / 256⌉ totals.
@compute @workgroup_size(ADAPTIVE_SCAN_WG)
fn scan(@builtin(local_invocation_index) lid: u32) {
    let g = adaptive_params.pixel_groups;
    let chunk = (g + ADAPTIVE_SCAN_WG - 1u) / ADAPTIVE_SCAN_WG;
    let start = min(lid * chunk, g);
    let end = min(start + chunk, g);
    var sum = vec2<u32>(0u);
    for (var i = start; i < end; i++) {
        sum += adaptive_groups[i];
    }
    var run = adaptive_workgroup_scan(lid, sum);
    if (lid == ADAPTIVE_SCAN_WG - 1u) {
        adaptive_totals[0] = run.x + sum.x;
        adaptive_totals[1] = run.y + sum.y;
    }
    for (var i = start; i < end; i++) {
        let v = adaptive_groups[i];
        adaptive_groups[i] = run;
        run += v;
    }
}

@compute @workgroup_size(ADAPTIVE_SCAN_WG)
fn apply(@builtin(workgroup_id) wid: vec3<u32>,
         @builtin(num_workgroups) nwg: vec3<u32>,
         @builtin(local_invocation_index) lid: u32) {
    let g = wid.x + wid.y * nwg.x;
    let p = g * ADAPTIVE_SCAN_WG + lid;
    let v = adaptive_want(p);
    let before = adaptive_workgroup_scan(lid, v);
    if (v.x == 0u) {
        return;
    }
    let base = adaptive_groups[g];
    let rank = base.x + before.x;
    let prefix = base.y + before.y;
    var take = 0u;
    if (prefix < adaptive_params.remaining) {
        take = min(v.y, adaptive_params.remaining - prefix);
    }
    adaptive_list[rank] = vec4<u32>(p, take, adaptive_state[4u * p], 0u);
}

// ------------------------------------------------------------ accumulate

fn adaptive_kahan(s: ptr<function, vec4<f32>>, c: ptr<function, vec4<f32>>, x: vec4<f32>) {
    let y = x - *c;
    let t = *s + y;
    *c = (t - *s) - y;
    *s = t;
}

// Entry j: adds the chunk's slots, in slot order, into its pixel's sums
// (Kahan-compensated), and advances the pixel's sample count.
@compute @workgroup_size(ADAPTIVE_WG)
fn accumulate(@builtin(global_invocation_id) gid: vec3<u32>,
              @builtin(num_workgroups) nwg: vec3<u32>) {
    let j = gid.x + gid.y * nwg.x * ADAPTIVE_WG;
    let n = adaptive_params.entries;
    if (j >= n) {
        return;
    }
    let e = adaptive_list[j];
    let p = e.x;
    var s = adaptive_sums[4u * p];
    var c = adaptive_sums[4u * p + 1u];
    var sa = adaptive_sums[4u * p + 2u];
    var ca = adaptive_sums[4u * p + 3u];
    for (var slot = 0u; slot < adaptive_params.slots; slot++) {
        let k = slot * n + j;
        adaptive_kahan(&s, &c, adaptive_partial[2u * k]);
        adaptive_kahan(&sa, &ca, adaptive_partial[2u * k + 1u]);
    }
    adaptive_sums[4u * p] = s;
    adaptive_sums[4u * p + 1u] = c;
    adaptive_sums[4u * p + 2u] = sa;
    adaptive_sums[4u * p + 3u] = ca;
    adaptive_state[4u * p] = e.z + e.y;
}

// ------------------------------------------------------ convergence test

// Cycles' per-pixel error (film_adaptive_sampling_convergence_check): the
// sum over channels of |I − A|, I the mean of all finite samples and A
// that of the class-A half, over 0.0001 + √(R+G+B) of I below 1 and over
// R+G+B from 1 up. A mean with no finite sample counts as 0.
fn adaptive_error(whole: vec4<f32>, part: vec4<f32>) -> f32 {
    let i = select(vec3<f32>(0.0), whole.xyz / whole.w, whole.w > 0.0);
    let a = select(vec3<f32>(0.0), part.xyz / part.w, part.w > 0.0);
    let difference = abs(i.x - a.x) + abs(i.y - a.y) + abs(i.z - a.z);
    let intensity = i.x + i.y + i.z;
    let norm = select(intensity, sqrt(intensity), intensity < 1.0);
    return difference / (0.0001 + norm);
}

// After a full round: a pixel that took samples is tested; one that did
// not keeps its verdict (converged).
@compute @workgroup_size(ADAPTIVE_WG)
fn check(@builtin(global_invocation_id) gid: vec3<u32>,
         @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = gid.x + gid.y * nwg.x * ADAPTIVE_WG;
    if (p >= adaptive_pixels()) {
        return;
    }
    var unconverged = 0u;
    if (adaptive_state[4u * p + 1u] != 0u) {
        let e = adaptive_error(adaptive_sums[4u * p], adaptive_sums[4u * p + 2u]);
        unconverged = select(1u, 0u, e < adaptive_params.threshold);
    }
    adaptive_state[4u * p + 2u] = unconverged;
}

// The unconverged mask dilated by one pixel in x and in y (Cycles'
// filter_x then filter_y passes: a 3×3 box).
@compute @workgroup_size(ADAPTIVE_WG)
fn dilate(@builtin(global_invocation_id) gid: vec3<u32>,
          @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = gid.x + gid.y * nwg.x * ADAPTIVE_WG;
    if (p >= adaptive_pixels()) {
        return;
    }
    let w = adaptive_params.width;
    let h = adaptive_params.height;
    let x = p % w;
    let y = p / w;
    var near = 0u;
    for (var yy = max(y, 1u) - 1u; yy <= min(y + 1u, h - 1u); yy++) {
        for (var xx = max(x, 1u) - 1u; xx <= min(x + 1u, w - 1u); xx++) {
            near |= adaptive_state[4u * (yy * w + xx) + 2u];
        }
    }
    adaptive_state[4u * p + 1u] = near;
}
