// A point of an integrand's domain: the film point in raster units
// (dimensions 0, 1) and u[k] = dimension k + 2, each in [0, 1).
struct IntegrandPoint {
    film: vec2<f32>,
    u: array<f32, MAX_U_DIMS>,
}
