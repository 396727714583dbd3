//! The GPU runtime: validation errors become Rust errors (never a zeroed
//! read-back), buffers over the binding limit are refused with a message,
//! and the profiler reports every phase.

mod common;

use common::gpu;
use mdas::gpu::profiler::Profiler;
use mdas::gpu::shader::{bind_buffers, storage_entry, Wgsl};

#[test]
fn invalid_wgsl_is_an_error_naming_the_pipeline() {
    let gpu = gpu();
    let layout = gpu.bind_group_layout("test.bad.layout", &[]);
    // Owned text, as a library user reading a shader at run time has it.
    let text =
        String::from("@compute @workgroup_size(1) fn main() { let x: f32 = undefined_name; }");
    let source = Wgsl::new().part((String::from("bad.wgsl"), text));
    let err = gpu
        .compute_pipeline("test.bad", &source, "main", &[&layout])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("test.bad") && err.contains("undefined_name"),
        "{err}"
    );
}

/// A dispatch that wgpu's validation rejects (the pipeline's bind group
/// was never set) comes back from the error scope around it as an error
/// naming the work, not as a silently zeroed result.
#[test]
fn a_validation_error_during_dispatch_is_returned() {
    let gpu = gpu();
    let layout = gpu.bind_group_layout("test.unbound.layout", &[storage_entry(0, false)]);
    let source = Wgsl::new().part((
        "unbound.wgsl",
        "@group(0) @binding(0) var<storage, read_write> data: array<u32>;\n\
         @compute @workgroup_size(1) fn main() { data[0] = 7u; }",
    ));
    let pipeline = gpu
        .compute_pipeline("test.unbound", &source, "main", &[&layout])
        .unwrap();
    // What every integrator does around its passes (`Gpu::scoped`).
    let err = gpu
        .scoped("unbound-dispatch", || {
            let mut profiler = Profiler::new(gpu);
            profiler.phase("unbound", |encoder, timestamps| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("test.unbound"),
                    timestamp_writes: timestamps,
                });
                pass.set_pipeline(&pipeline);
                pass.dispatch_workgroups(1, 1, 1);
            })?;
            profiler.finish().map(drop)
        })
        .unwrap_err();
    let err = format!("{err:#}");
    assert!(err.contains("GPU error during unbound-dispatch"), "{err}");
    // The error was taken: the next scope is clean.
    assert!(gpu.scoped("after", || Ok(())).is_ok());
}

/// A pipeline whose layout contradicts its shader (read-only binding, a
/// kernel that writes) is refused when it is created, naming it.
#[test]
fn a_layout_that_contradicts_the_shader_is_an_error() {
    let gpu = gpu();
    // The kernel expects a read-write buffer at binding 0, the layout says read-only.
    let layout = gpu.bind_group_layout("test.mismatch.layout", &[storage_entry(0, true)]);
    let source = Wgsl::new().part((
        "mismatch.wgsl",
        "@group(0) @binding(0) var<storage, read_write> data: array<u32>;\n\
         @compute @workgroup_size(1) fn main() { data[0] = 7u; }",
    ));
    let err = gpu
        .compute_pipeline("test.mismatch", &source, "main", &[&layout])
        .unwrap_err();
    let err = format!("{err:#}");
    assert!(err.contains("test.mismatch"), "{err}");
}

#[test]
fn kernels_run_and_read_back() {
    let gpu = gpu();
    let layout = gpu.bind_group_layout("test.square.layout", &[storage_entry(0, false)]);
    let source = Wgsl::new().constant("N", 1000).part((
        "square.wgsl",
        "@group(0) @binding(0) var<storage, read_write> data: array<u32>;\n\
         @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {\n\
             if (id.x < N) { data[id.x] = id.x * id.x; }\n\
         }",
    ));
    let pipeline = gpu
        .compute_pipeline("test.square", &source, "main", &[&layout])
        .unwrap();
    let buffer = gpu
        .buffer_zeroed("test.square.data", 4000, mdas::gpu::buffer::STORAGE)
        .unwrap();
    let group = bind_buffers(gpu, "test.square", &layout, &[&buffer]);
    let mut profiler = Profiler::new(gpu);
    for phase in ["first", "second", "first"] {
        profiler
            .phase(phase, |encoder, timestamps| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("test.square"),
                    timestamp_writes: timestamps,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.dispatch_workgroups(16, 1, 1);
            })
            .unwrap();
    }
    let times = profiler.finish().unwrap();
    let names: Vec<&str> = times.0.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["first", "second"]);
    assert!(times.0.iter().all(|(_, t)| t.is_finite()), "{times:?}");
    let data: Vec<u32> = gpu.read_buffer(&buffer, 1000).unwrap();
    assert!(data.iter().enumerate().all(|(i, &v)| v == (i * i) as u32));
}

#[test]
fn buffers_over_the_binding_limit_are_refused_with_a_message() {
    let gpu = gpu();
    let too_big = gpu.max_binding_bytes() + 4;
    let err = gpu
        .buffer_zeroed("test.huge", too_big, mdas::gpu::buffer::STORAGE)
        .unwrap_err()
        .to_string();
    assert!(err.contains("test.huge") && err.contains("MiB"), "{err}");
}

#[test]
fn large_grids_use_2d_dispatches_within_the_limit() {
    let gpu = gpu();
    let max = gpu.limits.max_compute_workgroups_per_dimension;
    for n in [1, 1000, max, max + 1, 5 * max + 3] {
        let (x, y) = gpu.dispatch_dims(n);
        assert!(
            x <= max && y <= max && x as u64 * y as u64 >= n as u64,
            "{n} → ({x}, {y})"
        );
    }
}

/// A kernel is built once per (source, entry, layouts): a second request
/// returns the same pipeline, also through a second layout with the same
/// entries. A constant no code line names (one in a `//` comment does not
/// count) is left out of the source and does not split the cache; one the
/// code reads does, and its value is what runs.
#[test]
fn kernels_are_built_once_and_unused_constants_do_not_split_them() {
    let gpu = gpu();
    let entries = [storage_entry(0, false)];
    let layout = gpu.bind_group_layout("test.cache.layout", &entries);
    let again = gpu.bind_group_layout("test.cache.layout.again", &entries);
    assert_eq!(layout, again, "equal entries gave two layouts");
    let source = |n: u32, unused: u32| {
        Wgsl::new()
            .constant("N", n)
            .constant("UNUSED", unused)
            .part((
                "cache.wgsl",
                "@group(0) @binding(0) var<storage, read_write> data: array<u32>;\n\
             // UNUSED is named in this comment only.\n\
             @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {\n\
                 if (id.x < 64u) { data[id.x] = N; }\n\
             }",
            ))
    };
    assert!(!source(7, 1).source().contains("const UNUSED"));
    assert!(source(7, 1).source().contains("const N: u32 = 7u;"));
    let build = |s: &Wgsl, l: &wgpu::BindGroupLayout| {
        gpu.compute_pipeline("test.cache", s, "main", &[l]).unwrap()
    };
    let first = build(&source(7, 1), &layout);
    assert_eq!(first, build(&source(7, 1), &layout), "rebuilt");
    assert_eq!(
        first,
        build(&source(7, 2), &again),
        "an unused constant split the cache"
    );
    let other = build(&source(9, 1), &layout);
    assert_ne!(
        first, other,
        "a constant the code reads did not split the cache"
    );
    let buffer = gpu
        .buffer_zeroed("test.cache.data", 256, mdas::gpu::buffer::STORAGE)
        .unwrap();
    let group = bind_buffers(gpu, "test.cache", &layout, &[&buffer]);
    for (pipeline, n) in [(&first, 7), (&other, 9)] {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(1, 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        let data: Vec<u32> = gpu.read_buffer(&buffer, 64).unwrap();
        assert!(data.iter().all(|&v| v == n), "{n}: {data:?}");
    }
}
