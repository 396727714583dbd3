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
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("test.integrand.layout"),
                entries: &test_integrand_layout_entries(),
            });
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
