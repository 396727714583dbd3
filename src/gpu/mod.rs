//! The GPU runtime: one wgpu device per process.
//!
//! [`Gpu::shared`] creates the instance, picks an adapter and opens the
//! device once per process (once per test binary) and hands out a
//! `&'static Gpu`. Any adapter works: a hardware GPU is preferred, else a
//! CPU Vulkan driver (Mesa's lavapipe), which is what CI uses. The
//! environment variable `MDAS_ADAPTER` (a case-insensitive substring of the
//! adapter name) overrides the choice; `WGPU_BACKEND` restricts backends.
//!
//! The device is opened with the adapter's own limits and with the
//! optional features the kernels can use when present ([`Capabilities`]):
//! timestamp queries (per-pass GPU timings, else wall clock with a device
//! sync, see [`profiler`]), subgroups, f32 atomics and 64-bit integer
//! atomics. Kernels must work without any of them.
//!
//! Every piece of GPU work that can fail validation runs inside
//! [`Gpu::scoped`], which turns a wgpu validation, out-of-memory or internal
//! error into a Rust error instead of a zeroed read-back.
//!
//! Beside the runtime: [`buffer`] (uploads and read-backs), [`shader`]
//! (WGSL assembly, layout entries), [`profiler`] (timestamps) and
//! [`radix_sort`], the one general-purpose kernel (a stable key-value sort
//! the light tree uses; MDAS's scan is specific to its allocation and
//! stays with it).

pub mod buffer;
pub mod profiler;
pub mod radix_sort;
pub mod shader;

use anyhow::{anyhow, bail, Context, Result};
use std::sync::{Arc, Mutex, OnceLock};

pub use buffer::Readback;
pub use profiler::Profiler;

/// Optional device features in use (all have fallbacks).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Capabilities {
    /// `TIMESTAMP_QUERY`: GPU timings per compute pass.
    pub timestamps: bool,
    /// `SUBGROUP`: subgroup built-ins in compute shaders.
    pub subgroups: bool,
    /// `SHADER_FLOAT32_ATOMIC`: atomicAdd on storage f32 (not deterministic).
    pub float32_atomics: bool,
    /// `SHADER_INT64_ATOMIC_ALL_OPS`: 64-bit integer atomics.
    pub int64_atomics: bool,
}

/// Instance, adapter, device and queue, with what they support.
pub struct Gpu {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub caps: Capabilities,
    /// Errors raised outside any error scope, surfaced by [`Gpu::scoped`].
    uncaptured: Arc<Mutex<Vec<String>>>,
    /// Layouts and pipelines already built ([`Gpu::bind_group_layout`],
    /// [`Gpu::compute_pipeline`]).
    pub(crate) kernels: Mutex<shader::KernelCache>,
    /// Whether uniform buffers are bound as read-only storage buffers
    /// (`var<uniform>` declared `var<storage, read>`, layouts and usages
    /// to match): on a CPU adapter. Lavapipe (Mesa 22.3, Debian 12's)
    /// inlines the values of uniforms that decide a branch or a loop and
    /// does so again, with a full shader compile, every time a pipeline
    /// with such uniforms is bound: every MDAS iteration rebound and
    /// recompiled its kernels (about 15 ms for an evaluate pass of a
    /// motion-blur scene). Storage buffers are never inlined.
    pub uniforms_as_storage: bool,
}

static SHARED: OnceLock<std::result::Result<Gpu, String>> = OnceLock::new();

impl Gpu {
    /// The process-wide GPU, created on first use. An error (no adapter,
    /// device request refused) is returned to every caller.
    pub fn shared() -> Result<&'static Gpu> {
        SHARED
            .get_or_init(|| Gpu::new().map_err(|e| format!("{e:#}")))
            .as_ref()
            .map_err(|e| anyhow!("{e}"))
    }

    fn new() -> Result<Gpu> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        let adapter = pick_adapter(adapters)?;
        let info = adapter.get_info();

        let available = adapter.features();
        let mut wanted = wgpu::Features::empty();
        let mut caps = Capabilities::default();
        let mut want = |f: wgpu::Features, flag: &mut bool| {
            if available.contains(f) {
                wanted |= f;
                *flag = true;
            }
        };
        want(wgpu::Features::TIMESTAMP_QUERY, &mut caps.timestamps);
        want(wgpu::Features::SUBGROUP, &mut caps.subgroups);
        want(
            wgpu::Features::SHADER_FLOAT32_ATOMIC,
            &mut caps.float32_atomics,
        );
        if available.contains(wgpu::Features::SHADER_INT64) {
            want(
                wgpu::Features::SHADER_INT64 | wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS,
                &mut caps.int64_atomics,
            );
        }

        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("mdas.device"),
            required_features: wanted,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .with_context(|| format!("cannot open a device on adapter '{}'", info.name))?;

        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            sink.lock().unwrap().push(e.to_string());
        }));

        let uniforms_as_storage = info.device_type == wgpu::DeviceType::Cpu;
        Ok(Gpu {
            instance,
            adapter,
            device,
            queue,
            info,
            limits,
            caps,
            uncaptured,
            kernels: Mutex::default(),
            uniforms_as_storage,
        })
    }

    /// Runs `f` inside validation, out-of-memory and internal error scopes
    /// and returns the first error any of them caught.
    pub fn scoped<T>(&self, what: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let result = f();
        let errors = [validation.pop(), oom.pop(), internal.pop()]
            .into_iter()
            .filter_map(pollster::block_on)
            .map(|e| e.to_string())
            .chain(self.uncaptured.lock().unwrap().drain(..))
            .collect::<Vec<_>>();
        if let Some(first) = errors.first() {
            bail!("GPU error during {what}: {first}");
        }
        result
    }

    /// Blocks until all submitted work has finished.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| anyhow!("waiting for the GPU failed: {e}"))
    }

    /// Largest single storage buffer binding, in bytes.
    pub fn max_binding_bytes(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// Splits `n` workgroups into a 2D dispatch within the per-dimension
    /// limit. Kernels recover the linear index as `id.x + id.y * (nx * wg)`.
    pub fn dispatch_dims(&self, n: u32) -> (u32, u32) {
        let max = self.limits.max_compute_workgroups_per_dimension.max(1);
        if n <= max {
            (n.max(1), 1)
        } else {
            let y = n.div_ceil(max);
            (n.div_ceil(y), y)
        }
    }

    /// The facts of [`Gpu::describe`] as JSON (`mdas info --json`).
    pub fn summary(&self) -> serde_json::Value {
        let i = &self.info;
        let l = &self.limits;
        serde_json::json!({
            "version": env!("CARGO_PKG_VERSION"),
            "adapter": i.name,
            "device_type": format!("{:?}", i.device_type),
            "backend": format!("{:?}", i.backend),
            "driver": i.driver,
            "driver_info": i.driver_info,
            "features_in_use": {
                "timestamps": self.caps.timestamps,
                "subgroups": self.caps.subgroups,
                "subgroup_size": [i.subgroup_min_size, i.subgroup_max_size],
                "float32_atomics": self.caps.float32_atomics,
                "int64_atomics": self.caps.int64_atomics,
            },
            "limits": {
                "max_buffer_size": l.max_buffer_size,
                "max_storage_buffer_binding_size": l.max_storage_buffer_binding_size,
                "max_storage_buffers_per_shader_stage": l.max_storage_buffers_per_shader_stage,
                "max_compute_workgroups_per_dimension": l.max_compute_workgroups_per_dimension,
                "max_compute_invocations_per_workgroup": l.max_compute_invocations_per_workgroup,
                "max_compute_workgroup_storage_size": l.max_compute_workgroup_storage_size,
            },
        })
    }

    /// A multi-line description for `mdas info`.
    pub fn describe(&self) -> String {
        let i = &self.info;
        let l = &self.limits;
        let yes = |b: bool| if b { "yes" } else { "no (fallback)" };
        format!(
            "adapter:      {} ({:?})\n\
             backend:      {:?}\n\
             driver:       {} {}\n\
             features in use:\n  timestamps:      {}\n  subgroups:       {} (size {}..{})\n  f32 atomics:     {}\n  int64 atomics:   {}\n\
             limits:\n  max buffer size:                 {} MiB\n  max storage binding:             {} MiB\n  storage buffers per stage:       {}\n  workgroups per dimension:        {}\n  invocations per workgroup:       {}\n  workgroup storage:               {} KiB",
            i.name,
            i.device_type,
            i.backend,
            i.driver,
            i.driver_info,
            yes(self.caps.timestamps),
            yes(self.caps.subgroups),
            i.subgroup_min_size,
            i.subgroup_max_size,
            yes(self.caps.float32_atomics),
            yes(self.caps.int64_atomics),
            l.max_buffer_size >> 20,
            l.max_storage_buffer_binding_size >> 20,
            l.max_storage_buffers_per_shader_stage,
            l.max_compute_workgroups_per_dimension,
            l.max_compute_invocations_per_workgroup,
            l.max_compute_workgroup_storage_size >> 10,
        )
    }
}

/// Hardware first (discrete, integrated, virtual), then CPU drivers.
fn pick_adapter(adapters: Vec<wgpu::Adapter>) -> Result<wgpu::Adapter> {
    if adapters.is_empty() {
        let known = |name: &str| {
            let known = [
                "vulkan", "vk", "metal", "mtl", "dx12", "d3d12", "gl", "gles", "opengl",
            ];
            known.contains(&name.trim().to_ascii_lowercase().as_str())
        };
        let backend = std::env::var("WGPU_BACKEND").ok();
        if let Some(backend) = backend.as_ref().filter(|b| !b.split(',').all(known)) {
            bail!(
                "no GPU adapter found with WGPU_BACKEND={backend:?}: wgpu knows the backends \
                 vulkan, metal, dx12 and gl (a comma-separated list), and this build has \
                 vulkan, metal and dx12; unset WGPU_BACKEND to use any of them"
            );
        }
        // Only backends this build lacks (gl): a Vulkan driver may well be
        // installed, so do not tell the user to install one (issue 54
        // item 8).
        let built = ["vulkan", "vk", "metal", "mtl", "dx12", "d3d12"];
        if let Some(backend) = backend.filter(|b| {
            !b.split(',')
                .any(|n| built.contains(&n.trim().to_ascii_lowercase().as_str()))
        }) {
            bail!(
                "no GPU adapter found with WGPU_BACKEND={backend:?}: this build has the \
                 vulkan, metal and dx12 backends only; unset WGPU_BACKEND (or set it to \
                 vulkan) to use them"
            );
        }
        bail!(
            "no GPU adapter found. Install a Vulkan driver: on Debian/Ubuntu \
             `apt-get install mesa-vulkan-drivers` gives the lavapipe CPU driver \
             (`make run` and `make test` do this for you)"
        );
    }
    if let Ok(wanted) = std::env::var("MDAS_ADAPTER") {
        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        return adapters
            .into_iter()
            .find(|a| {
                a.get_info()
                    .name
                    .to_lowercase()
                    .contains(&wanted.to_lowercase())
            })
            .ok_or_else(|| {
                anyhow!(
                    "MDAS_ADAPTER='{wanted}' matches none of: {}",
                    names.join(", ")
                )
            });
    }
    let rank = |a: &wgpu::Adapter| {
        let info = a.get_info();
        let device = match info.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        };
        // Prefer Vulkan among equals: it is the backend CI exercises.
        let backend = if info.backend == wgpu::Backend::Vulkan {
            0
        } else {
            1
        };
        (device, backend)
    };
    Ok(adapters.into_iter().min_by_key(rank).expect("non-empty"))
}
