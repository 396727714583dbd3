// The integrand point of Halton sample `index` of `pixel` (whose lower
// corner is `px`): the film point from dimensions 0-1, the integrand's
// dimensions 2..dims after it. Shared by the Halton and adaptive Halton
// kernels (src/integrator/halton.rs, src/integrator/adaptive.rs). Needs
// shared/halton.wgsl and the integrand's IntegrandPoint.
fn halton_integrand_point(index: u32, pixel: u32, px: vec2<f32>, dims: u32, seed: u32) -> IntegrandPoint {
    var point: IntegrandPoint;
    point.film = px + vec2<f32>(halton_sample(0u, index, pixel, seed),
                                halton_sample(1u, index, pixel, seed));
    for (var d = 2u; d < dims; d++) {
        point.u[d - 2u] = halton_sample(d, index, pixel, seed);
    }
    return point;
}
