// 30-bit Morton code of each light's centroid, with the exact quantization
// of src/lights/morton.rs (its docs spell out the WGSL side): E from the
// bits of the extent, powers of two built from bits and split in two above
// 2^127, floor and clamp to 1023. Also writes the light ids 0..N as the
// values the sort carries. The substitute tree's normal codes come first
// (normal_codes, morton_codes_sorted).

fn exponent_of(e: f32) -> i32 {
    let bits = bitcast<u32>(e) & 0x7fffffffu;
    let field = bits >> 23u;
    if (field == 0u) {
        return 31 - i32(countLeadingZeros(bits & 0x7fffffu)) - 149;
    }
    return i32(field) - 127;
}

fn pow2(k: i32) -> f32 {
    return bitcast<f32>(u32(k + 127) << 23u);
}

fn scale_pow2(d: f32, k: i32) -> f32 {
    if (k > 127) {
        return mul_rn(mul_rn(d, pow2(127)), pow2(k - 127));
    }
    return mul_rn(d, pow2(k));
}

fn quantize_axis(c: f32, lo: f32, hi: f32) -> u32 {
    let e = hi - lo;
    if (e == 0.0) {
        return 0u;
    }
    let k = 9 - exponent_of(e);
    return u32(min(floor(scale_pow2(c - lo, k)), 1023.0));
}

fn spread3(v: u32) -> u32 {
    var x = v & 0x3ffu;
    x = (x | (x << 16u)) & 0x030000ffu;
    x = (x | (x << 8u)) & 0x0300f00fu;
    x = (x | (x << 4u)) & 0x030c30c3u;
    x = (x | (x << 2u)) & 0x09249249u;
    return x;
}

// The Morton code of one light's centroid (after the bounds pass).
fn morton_of(l: LightPrim) -> u32 {
    let c = prim_centroid(l);
    var q: array<u32, 3>;
    for (var a = 0u; a < 3u; a++) {
        let lo = from_ordered_bits(~atomicLoad(&centroid_bounds[a]));
        let hi = from_ordered_bits(atomicLoad(&centroid_bounds[3u + a]));
        q[a] = quantize_axis(c[a], lo, hi);
    }
    return (spread3(q[0]) << 2u) | (spread3(q[1]) << 1u) | spread3(q[2]);
}

@compute @workgroup_size(WG)
fn morton_codes(@builtin(workgroup_id) wid: vec3<u32>,
                @builtin(num_workgroups) groups: vec3<u32>,
                @builtin(local_invocation_index) lid: u32) {
    opaque_zero = params.zero;
    let i = linear_index(wid, groups, lid);
    if (i >= params.n) {
        return;
    }
    codes[i] = morton_of(prims[i]);
    sorted_ids[i] = i;
}

// Substitute trees sort by (Morton code, normal code, id) in two stable
// passes: first by normal code (`normal_codes`: the codes and the ids
// 0..N), then by Morton code, the keys gathered in the order the first pass
// left (`morton_codes_sorted`: codes[s] of light sorted_ids[s]).
@compute @workgroup_size(WG)
fn normal_codes(@builtin(workgroup_id) wid: vec3<u32>,
                @builtin(num_workgroups) groups: vec3<u32>,
                @builtin(local_invocation_index) lid: u32) {
    let i = linear_index(wid, groups, lid);
    if (i >= params.n) {
        return;
    }
    codes[i] = normal_code(prim_normal(prims[i]));
    sorted_ids[i] = i;
}

@compute @workgroup_size(WG)
fn morton_codes_sorted(@builtin(workgroup_id) wid: vec3<u32>,
                       @builtin(num_workgroups) groups: vec3<u32>,
                       @builtin(local_invocation_index) lid: u32) {
    opaque_zero = params.zero;
    let s = linear_index(wid, groups, lid);
    if (s >= params.n) {
        return;
    }
    codes[s] = morton_of(prims[sorted_ids[s]]);
}
