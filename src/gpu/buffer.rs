//! Labelled buffer creation with size checks, and read-back.

use super::Gpu;
use anyhow::{anyhow, bail, Result};
use wgpu::util::DeviceExt;

/// Usage of a storage buffer that kernels write and the host may read.
pub const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

impl Gpu {
    /// Fails with a clear message when `bytes` exceeds what one storage
    /// binding can hold on this adapter.
    pub fn check_binding_size(&self, label: &str, bytes: u64) -> Result<()> {
        check_binding_size_in(&self.limits, label, bytes)
    }

    /// A storage buffer initialised from `data`. An empty slice still
    /// gives a bindable buffer: one zeroed element (at least 16 bytes),
    /// since a WGSL array binding needs room for one element.
    pub fn buffer_from<T: bytemuck::Pod>(
        &self,
        label: &str,
        data: &[T],
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        self.check_binding_size(label, bytes.len() as u64)?;
        let min_len = std::mem::size_of::<T>().max(16).next_multiple_of(4);
        let padded;
        let contents = if bytes.len() < min_len {
            let mut v = bytes.to_vec();
            v.resize(min_len, 0);
            padded = v;
            &padded[..]
        } else {
            bytes
        };
        Ok(self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            }))
    }

    /// A zero-initialised buffer of `bytes` (at least 16).
    pub fn buffer_zeroed(
        &self,
        label: &str,
        bytes: u64,
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer> {
        self.check_binding_size(label, bytes)?;
        Ok(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16).next_multiple_of(4),
            usage,
            mapped_at_creation: false,
        }))
    }

    /// A uniform buffer holding one `T`.
    pub fn uniform<T: bytemuck::Pod>(&self, label: &str, value: &T) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::bytes_of(value),
                usage: self.uniform_usage() | wgpu::BufferUsages::COPY_DST,
            })
    }

    /// The usage of a buffer bound as a uniform buffer: UNIFORM, and
    /// STORAGE where uniforms are bound as storage buffers
    /// ([`Gpu::uniforms_as_storage`]).
    pub fn uniform_usage(&self) -> wgpu::BufferUsages {
        if self.uniforms_as_storage {
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE
        } else {
            wgpu::BufferUsages::UNIFORM
        }
    }

    /// Copies `count` elements of `T` from the start of `buffer` to the host.
    /// Blocks until the GPU is done.
    pub fn read_buffer<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        count: usize,
    ) -> Result<Vec<T>> {
        let mut readback = Readback::new(self, buffer, count)?;
        self.queue.submit([readback.encode(self)]);
        readback.finish(self)
    }
}

/// A pending copy of a buffer's first `count` elements into a mappable
/// staging buffer, so the copy can ride in the same submission as the
/// kernels that produce the data.
pub struct Readback<T> {
    source: wgpu::Buffer,
    staging: wgpu::Buffer,
    count: usize,
    _t: std::marker::PhantomData<T>,
}

impl<T: bytemuck::Pod> Readback<T> {
    pub fn new(gpu: &Gpu, source: &wgpu::Buffer, count: usize) -> Result<Self> {
        let bytes = (count * std::mem::size_of::<T>()) as u64;
        if bytes > source.size() {
            bail!(
                "read-back of {bytes} bytes from a {}-byte buffer",
                source.size()
            );
        }
        let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("mdas.readback"),
            size: bytes.max(4).next_multiple_of(4),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(Readback {
            source: source.clone(),
            staging,
            count,
            _t: Default::default(),
        })
    }

    /// A command buffer with just the copy.
    pub fn encode(&mut self, gpu: &Gpu) -> wgpu::CommandBuffer {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        self.record(&mut encoder);
        encoder.finish()
    }

    /// Records the copy into an existing encoder.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        let bytes = (self.count * std::mem::size_of::<T>()) as u64;
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(
                &self.source,
                0,
                &self.staging,
                0,
                bytes.next_multiple_of(4).min(self.source.size()),
            );
        }
    }

    /// Waits for the copy and returns the data.
    pub fn finish(self, gpu: &Gpu) -> Result<Vec<T>> {
        if self.count == 0 {
            return Ok(Vec::new());
        }
        let slice = self.staging.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        gpu.wait()?;
        rx.recv()
            .map_err(|_| anyhow!("buffer map callback never ran"))?
            .map_err(|e| anyhow!("mapping a read-back buffer failed: {e}"))?;
        let view = slice
            .get_mapped_range()
            .map_err(|e| anyhow!("mapped range unavailable: {e:?}"))?;
        let bytes = &view[..self.count * std::mem::size_of::<T>()];
        let out = bytemuck::pod_collect_to_vec(bytes);
        drop(view);
        self.staging.unmap();
        Ok(out)
    }
}

/// [`Gpu::check_binding_size`] against `limits` (a test can pass tighter
/// limits than its adapter's).
pub fn check_binding_size_in(limits: &wgpu::Limits, label: &str, bytes: u64) -> Result<()> {
    let max = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    if bytes > max {
        bail!(
            "'{label}' needs {:.1} MiB but this adapter allows {:.1} MiB per storage buffer; \
             reduce the resolution, spp or scene size",
            bytes as f64 / 1048576.0,
            max as f64 / 1048576.0
        );
    }
    Ok(())
}
