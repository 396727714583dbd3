// Warps from [0,1)^k to geometric domains. Each takes its random numbers
// as arguments; densities are stated beside each function.

const PI: f32 = 3.14159265358979323846;
const INV_PI: f32 = 0.31830988618379067154;
// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 0x1.fffffep-1;

// Shirley–Chiu concentric map of the unit square to the unit disk
// (uniform: density 1/π).
fn sample_concentric_disk(u: vec2<f32>) -> vec2<f32> {
    let o = 2.0 * u - vec2<f32>(1.0);
    if (o.x == 0.0 && o.y == 0.0) {
        return vec2<f32>(0.0);
    }
    var r: f32;
    var theta: f32;
    if (abs(o.x) > abs(o.y)) {
        r = o.x;
        theta = (PI / 4.0) * (o.y / o.x);
    } else {
        r = o.y;
        theta = (PI / 2.0) - (PI / 4.0) * (o.x / o.y);
    }
    return r * vec2<f32>(cos(theta), sin(theta));
}

// Uniform barycentrics (b0, b1) on a triangle (density 1/area), by the
// square-root warp; b2 = 1 − b0 − b1.
fn sample_uniform_triangle(u: vec2<f32>) -> vec2<f32> {
    let su0 = sqrt(u.x);
    return vec2<f32>(1.0 - su0, u.y * su0);
}

// Finite test on the bits: WGSL lets compilers assume float arithmetic
// never produces NaN or Inf, so comparisons cannot be trusted for this.
fn is_finite3(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(e != vec3<u32>(0x7f800000u));
}

// Cosine-weighted direction on the hemisphere around +z (Malley's method:
// a uniform disk point lifted to the hemisphere); density cosθ/π with
// respect to solid angle.
fn sample_cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let d = sample_concentric_disk(u);
    let z = sqrt(max(0.0, 1.0 - dot(d, d)));
    return vec3<f32>(d, z);
}

// Density of sample_cosine_hemisphere for cosθ = `cos_theta`.
fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    return max(cos_theta, 0.0) * INV_PI;
}

// Orthonormal frame (t, b, n) around the unit vector n: columns 0, 1, 2 of
// the result (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
// The local vector (x, y, z) maps to x·t + y·b + z·n.
fn frame_from_normal(n: vec3<f32>) -> mat3x3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let bt = vec3<f32>(b, s + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}
