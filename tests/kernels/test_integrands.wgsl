// Integrands with known pixel means, for integrator tests. TEST_CASE is a
// generated constant selecting the function.
//   0: f = (film.x, film.y, u[0])  → pixel mean (i + ½, j + ½, ½)
//   1: f = 1, but NaN when u[0] < ¼ and +Inf when ¼ ≤ u[0] < ⅜
//      → every finite sample is 1; ~⅜ of samples are non-finite
//   2: f = 1e6 where u[0] < 0.2, else 1e-6 (extreme dynamic range)
//   3: f = 1 where 0.8·x + 0.6·y < 7.3, else 0: a sharp straight edge
//      across the film (pixel mean = area of the pixel left of the line)
//   4: f = 25 where |u[0] − ½| < 0.02, else 0: zero over 96% of the
//      domain → pixel mean 1
//   5: f = 1e6 where film.x < 4, else 1e-6 → pixel means 1e6 and 1e-6
//      exactly (columns 0–3 and the rest)
//   6: f = 1 inside a disk of radius 2.5 whose centre moves from (5, 5)
//      to (11, 7) over u[0] (motion blur), else 0. Pixel means have no
//      closed form; on a film of at least 14×10 the disk never leaves it,
//      so the film total is π·2.5² at every time, and so overall.
//   7: f = 400 inside the rectangle [5.3, 7.6) × [4.2, 5.5) of the film,
//      else 0: a small, very bright lamp on black (issue 48). Pixel mean
//      = 400 × the pixel's overlap with the rectangle.

@group(1) @binding(0) var<storage, read> unused: array<u32>;

fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let u0 = (*p).u[0];
    if (TEST_CASE == 0u) {
        return vec3<f32>((*p).film, u0);
    }
    if (TEST_CASE == 1u) {
        let zero = f32(arrayLength(&unused) == 0u);  // 0 at run time, opaque to the compiler
        if (u0 < 0.25) {
            return vec3<f32>(zero / zero);
        }
        if (u0 < 0.375) {
            return vec3<f32>(1.0 / zero);
        }
        return vec3<f32>(1.0);
    }
    if (TEST_CASE == 3u) {
        return vec3<f32>(select(0.0, 1.0, 0.8 * (*p).film.x + 0.6 * (*p).film.y < 7.3));
    }
    if (TEST_CASE == 4u) {
        return vec3<f32>(select(0.0, 25.0, abs(u0 - 0.5) < 0.02));
    }
    if (TEST_CASE == 6u) {
        let d = (*p).film - (vec2<f32>(5.0, 5.0) + vec2<f32>(6.0, 2.0) * u0);
        return vec3<f32>(select(0.0, 1.0, dot(d, d) < 6.25));
    }
    if (TEST_CASE == 7u) {
        let f = (*p).film;
        let inside = f.x >= 5.3 && f.x < 7.6 && f.y >= 4.2 && f.y < 5.5;
        return vec3<f32>(select(0.0, 400.0, inside));
    }
    if (TEST_CASE == 5u) {
        return vec3<f32>(select(1e-6, 1e6, (*p).film.x < 4.0));
    }
    return vec3<f32>(select(1e-6, 1e6, u0 < 0.2));
}
