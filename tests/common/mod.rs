//! Test support: integrands with known answers that need no scene.
#![allow(dead_code)]

use mdas::film::Film;
use mdas::gpu::shader::{storage_entry, Wgsl};
use mdas::gpu::Gpu;
use mdas::integrand::{point_wgsl, Integrand};

/// One of the cases of `tests/kernels/test_integrands.wgsl`.
pub struct TestIntegrand {
    pub case: u32,
    pub dims: u32,
    pub film: Film,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
}

/// The WGSL of case `case` (device-free, for `tests/shader_interfaces.rs`).
pub fn test_integrand_source(case: u32) -> Wgsl {
    point_wgsl().constant("TEST_CASE", case).part((
        "tests/kernels/test_integrands.wgsl",
        include_str!("../kernels/test_integrands.wgsl"),
    ))
}

/// Its group 1: one read-only buffer, empty (case 1 reads its length as an
/// opaque zero).
pub fn test_integrand_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    vec![storage_entry(0, true)]
}

impl TestIntegrand {
    pub fn new(gpu: &Gpu, case: u32, dims: u32, film: Film) -> Self {
        let layout =
            gpu.bind_group_layout("test.integrand.layout", &test_integrand_layout_entries());
        let buffer = gpu
            .buffer_from::<u32>("test.integrand.unused", &[], wgpu::BufferUsages::STORAGE)
            .unwrap();
        let bind_group =
            mdas::gpu::shader::bind_buffers(gpu, "test.integrand", &layout, &[&buffer]);
        TestIntegrand {
            case,
            dims,
            film,
            layout,
            bind_group,
        }
    }
}

impl Integrand for TestIntegrand {
    fn name(&self) -> &'static str {
        "test"
    }
    fn dims(&self) -> u32 {
        self.dims
    }
    fn film(&self) -> Film {
        self.film
    }
    fn wgsl(&self) -> Wgsl {
        test_integrand_source(self.case)
    }
    fn layout(&self) -> Option<&wgpu::BindGroupLayout> {
        Some(&self.layout)
    }
    fn bind_group(&self) -> Option<&wgpu::BindGroup> {
        Some(&self.bind_group)
    }
}

pub fn gpu() -> &'static Gpu {
    Gpu::shared().expect(
        "GPU tests need a wgpu adapter (CI uses lavapipe: apt-get install mesa-vulkan-drivers)",
    )
}

/// The image's bits, for exact determinism checks.
pub fn image_bits(r: &mdas::integrator::Render) -> Vec<u32> {
    r.image.iter().flat_map(|p| p.map(f32::to_bits)).collect()
}

// ----------------------------------------- the Halton points, on the CPU
//
// The definition in `src/integrator/halton.rs`: sample i of a pixel has
// coordinate frac(Φ_{b_k}(i) + shift(pixel, k, seed)) in dimension k.

/// The first primes, the bases of dimensions 0, 1, ….
pub const PRIMES: [u32; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];

/// Φ_b(a) as an exact rational, then rounded once to f64.
pub fn radical_inverse_exact(b: u32, mut a: u32) -> f64 {
    let (mut num, mut den) = (0u128, 1u128);
    while a > 0 {
        num = num * b as u128 + (a % b) as u128;
        den *= b as u128;
        a /= b;
    }
    num as f64 / den as f64
}

/// The Cranley–Patterson shift of (pixel, dimension, seed): 24 bits of
/// `hash3` (wgsl/shared/rng.wgsl; its CPU twin `mdas::rng`), exactly as
/// the GPU forms it.
pub fn cp_shift(pixel: u32, dim: u32, seed: u32) -> f64 {
    let h = mdas::rng::hash3(pixel, dim, seed);
    (h >> 8) as f64 / 16777216.0
}

/// Dimension `dim` of Halton sample `index` of `pixel` (row-major index)
/// in f64: the exact radical inverse plus the pixel's Cranley–Patterson
/// shift, modulo 1. The GPU's f32 value is within 2⁻²² of it.
pub fn halton_point(dim: u32, index: u32, pixel: u32, seed: u32) -> f64 {
    (radical_inverse_exact(PRIMES[dim as usize], index) + cp_shift(pixel, dim, seed)).fract()
}
