// Stochastic substitute trees (src/lights/substitute.rs, which the module
// docs explain): the 9-bit normal code (exact, equal to the CPU's), a node's
// substitute distribution, the merge of two children (within a stated
// tolerance of the CPU's: divisions and square roots), and the substitute
// position drawn from N(mean, Σ) and clamped to the node's box. Needs
// lights/light_prim.wgsl (LightPrim, KIND_VPL).

struct Substitute {
    mean: vec3<f32>,
    nu: f32,
    normal: vec3<f32>,
    cov_xy: f32,
    cov_diag: vec3<f32>,
    cov_xz: f32,
    emission: vec3<f32>,
    cov_yz: f32,
}

fn substitute_zero() -> Substitute {
    return Substitute(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0);
}

// A VPL's normal, zero for other lights.
fn prim_normal(l: LightPrim) -> vec3<f32> {
    if (l.kind == KIND_VPL) {
        return l.p1;
    }
    return vec3<f32>(0.0);
}

// Octant (x, y, z negative), then 3 levels of 4-way subdivision of the
// octant's triangle; doublings are exact, so even a contracted 2a − s rounds
// once, as the CPU's does.
fn normal_code(n: vec3<f32>) -> u32 {
    let octant = (select(0u, 4u, n.x < 0.0) | select(0u, 2u, n.y < 0.0)) | select(0u, 1u, n.z < 0.0);
    var a = abs(n.x);
    var b = abs(n.y);
    var c = abs(n.z);
    let s = (a + b) + c;
    // s > 0 and finite (3.4e38 bounds every finite f32).
    if (!(s > 0.0) || !(s <= 3.4028235e38)) {
        return 0u;
    }
    var code = octant;
    for (var level = 0u; level < 3u; level++) {
        var child = 3u;
        if (2.0 * a >= s) {
            a = 2.0 * a - s;
            b = 2.0 * b;
            c = 2.0 * c;
            child = 0u;
        } else if (2.0 * b >= s) {
            a = 2.0 * a;
            b = 2.0 * b - s;
            c = 2.0 * c;
            child = 1u;
        } else if (2.0 * c >= s) {
            a = 2.0 * a;
            b = 2.0 * b;
            c = 2.0 * c - s;
            child = 2u;
        } else {
            a = s - 2.0 * a;
            b = s - 2.0 * b;
            c = s - 2.0 * c;
        }
        code = (code << 2u) | child;
    }
    return code;
}

fn substitute_of_prim(l: LightPrim) -> Substitute {
    var s = substitute_zero();
    s.mean = prim_centroid(l);
    s.nu = select(0.0, 1.0, l.kind == KIND_VPL);
    s.normal = prim_normal(l);
    s.emission = l.emission;
    return s;
}

// Σ + ΔΔᵀ as (xx, yy, zz, xy, xz, yz).
fn substitute_second(s: Substitute, d: vec3<f32>) -> array<f32, 6> {
    return array<f32, 6>(
        s.cov_diag.x + d.x * d.x,
        s.cov_diag.y + d.y * d.y,
        s.cov_diag.z + d.z * d.z,
        s.cov_xy + d.x * d.y,
        s.cov_xz + d.x * d.z,
        s.cov_yz + d.y * d.z,
    );
}

// The parent of children a, b of scalar intensities ca, cb (a child with
// c = 0 drops out).
fn substitute_merge(a: Substitute, ca: f32, b: Substitute, cb: f32) -> Substitute {
    if (!(cb > 0.0)) {
        if (ca > 0.0) {
            return a;
        }
        return substitute_zero();
    }
    if (!(ca > 0.0)) {
        return b;
    }
    let w = ca + cb;
    let ta = ca / w;
    let tb = cb / w;
    let mean = a.mean + (b.mean - a.mean) * tb;
    let m = a.normal * ca + b.normal * cb;
    let len = length(m);
    var out = substitute_zero();
    out.mean = mean;
    if (len > 0.0) {
        out.normal = m / len;
        out.nu = a.nu * b.nu * max(dot(a.normal, b.normal), 0.0);
    }
    let sa = substitute_second(a, a.mean - mean);
    let sb = substitute_second(b, b.mean - mean);
    out.cov_diag = vec3<f32>(ta * sa[0] + tb * sb[0], ta * sa[1] + tb * sb[1], ta * sa[2] + tb * sb[2]);
    out.cov_xy = ta * sa[3] + tb * sb[3];
    out.cov_xz = ta * sa[4] + tb * sb[4];
    out.cov_yz = ta * sa[5] + tb * sb[5];
    out.emission = a.emission + b.emission;
    return out;
}

// σ_z² = nᵀΣn.
fn substitute_sigma_z2(s: Substitute) -> f32 {
    let n = s.normal;
    let sn = vec3<f32>(
        s.cov_diag.x * n.x + s.cov_xy * n.y + s.cov_xz * n.z,
        s.cov_xy * n.x + s.cov_diag.y * n.y + s.cov_yz * n.z,
        s.cov_xz * n.x + s.cov_yz * n.y + s.cov_diag.z * n.z,
    );
    return dot(n, sn);
}

// √2·erf⁻¹(2u − 1) (Giles 2010, single precision), as inverse_normal_cdf in
// substitute.rs.
fn sst_inverse_normal_cdf(u: f32) -> f32 {
    let x = clamp(2.0 * u - 1.0, -0.99999994, 0.99999994);
    var w = -log((1.0 - x) * (1.0 + x));
    var p: f32;
    if (w < 5.0) {
        w = w - 2.5;
        p = 2.8102264e-8;
        p = 3.4327394e-7 + p * w;
        p = -3.5233877e-6 + p * w;
        p = -4.3915065e-6 + p * w;
        p = 2.1858087e-4 + p * w;
        p = -1.253725e-3 + p * w;
        p = -4.1776816e-3 + p * w;
        p = 0.24664073 + p * w;
        p = 1.5014094 + p * w;
    } else {
        w = sqrt(w) - 3.0;
        p = -2.0021426e-4;
        p = 1.0095056e-4 + p * w;
        p = 1.3493432e-3 + p * w;
        p = -3.6734284e-3 + p * w;
        p = 5.7395077e-3 + p * w;
        p = -7.6224613e-3 + p * w;
        p = 9.4388705e-3 + p * w;
        p = 1.001674 + p * w;
        p = 2.8329768 + p * w;
    }
    return 1.4142135 * p * x;
}

// mean + L·z (L the lower Cholesky factor of Σ, a zero column where a pivot
// is ≤ 0), z = Φ⁻¹(u), clamped to [lo, hi].
fn substitute_position(s: Substitute, u: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec3<f32> {
    let z = vec3<f32>(sst_inverse_normal_cdf(u.x), sst_inverse_normal_cdf(u.y), sst_inverse_normal_cdf(u.z));
    let l00 = sqrt(max(s.cov_diag.x, 0.0));
    var l10 = 0.0;
    var l20 = 0.0;
    if (l00 > 0.0) {
        l10 = s.cov_xy / l00;
        l20 = s.cov_xz / l00;
    }
    let l11 = sqrt(max(s.cov_diag.y - l10 * l10, 0.0));
    var l21 = 0.0;
    if (l11 > 0.0) {
        l21 = (s.cov_yz - l20 * l10) / l11;
    }
    let l22 = sqrt(max(s.cov_diag.z - l20 * l20 - l21 * l21, 0.0));
    let d = vec3<f32>(l00 * z.x, l10 * z.x + l11 * z.y, l20 * z.x + l21 * z.y + l22 * z.z);
    return clamp(s.mean + d, lo, hi);
}
