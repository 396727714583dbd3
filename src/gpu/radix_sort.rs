//! Stable GPU LSD radix sort of `(u32 key, u32 value)` pairs:
//! `wgsl/gpu/radix_sort.wgsl`. The light tree sorts its lights by
//! (Morton code, light id) with it (real-time stochastic lightcuts §4 uses a
//! bitonic sort; any stable sort of the codes with the ids as values gives
//! the same order).
//!
//! # Algorithm
//!
//! Keys are sorted by their low `key_bits` bits, [`RADIX_BITS`] bits per
//! pass from the least significant digit up (30-bit Morton codes: 8
//! passes). Each pass is a *reduce-then-scan* over tiles of [`TILE`] keys,
//! three dispatches in one compute pass:
//!
//! 1. `histogram` — one workgroup per tile counts the tile's keys of each
//!    digit into `hist[d · tiles + tile]` (digit-major, so one exclusive
//!    scan of the whole array would give every (digit, tile) its output
//!    offset).
//! 2. `scan_digits` — one workgroup per digit scans its row of tile
//!    counts in place (exclusive) and stores the row total. The scatter
//!    adds the totals of the smaller digits (at most 15 additions).
//! 3. `scatter` — one workgroup per tile ranks each key among the tile's
//!    keys with the same digit and writes key and value to
//!    `base[d] + hist[d · tiles + tile] + rank`. Invocation `t` owns the
//!    `ITEMS` consecutive keys `[t·ITEMS, (t+1)·ITEMS)` of the tile, counts
//!    them per digit into a shared `RADIX × WG` table, and an exclusive
//!    scan of that table in digit-major order gives every (digit,
//!    invocation) the number of tile keys before it with a smaller digit or
//!    the same digit and a smaller position. Walking its keys in order with
//!    that entry as a running counter gives each key its stable rank.
//!
//! Passes ping-pong between the caller's buffers and the sorter's own; an
//! odd pass count ends with a copy back, so the caller's buffers always hold
//! the result.
//!
//! # Determinism and correctness on every driver
//!
//! No invocation waits for another workgroup (docs/conventions.md "Known
//! pitfalls": lavapipe gives wrong answers with spin-waits, so no decoupled
//! look-back), there are no
//! atomics whose order matters (the only atomics are the tile's digit
//! counts, and integer additions commute), and each output position is a
//! function of the input alone: the sort is stable and gives the same
//! bytes on every run. No loop runs more than `max(2·ITEMS, 2·⌈tiles /
//! SCAN_WG⌉)` times per invocation (lavapipe's 65,535-iteration cap: fine
//! for 2^31 keys). Large inputs use 2D dispatches ([`Gpu::dispatch_dims`]).

use super::shader::{storage_entry, uniform_entry, Wgsl};
use super::Gpu;
use crate::wgsl_file;
use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};

/// Bits per pass.
pub const RADIX_BITS: u32 = 4;
/// Digits per pass.
pub const RADIX: u32 = 1 << RADIX_BITS;
/// Invocations per histogram and scatter workgroup.
pub const WG: u32 = 128;
/// Consecutive keys per invocation.
pub const ITEMS: u32 = 16;
/// Keys per tile (one histogram or scatter workgroup).
pub const TILE: u32 = WG * ITEMS;
/// Invocations of a `scan_digits` workgroup.
const SCAN_WG: u32 = 256;
/// Passes of a full 32-bit sort.
const MAX_PASSES: u32 = 32 / RADIX_BITS;

/// Per-pass uniform (`Params` in the WGSL; public for
/// `tests/shader_interfaces.rs`, which compares the two layouts).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Params {
    pub n: u32,
    pub shift: u32,
    pub mask: u32,
    pub tiles: u32,
    pub groups_x: u32,
    pub _pad: [u32; 3],
}

/// Pipelines and scratch buffers for sorting up to `capacity` pairs.
pub struct RadixSort {
    capacity: u32,
    layout: wgpu::BindGroupLayout,
    histogram: wgpu::ComputePipeline,
    scan_digits: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    keys_tmp: wgpu::Buffer,
    values_tmp: wgpu::Buffer,
    hist: wgpu::Buffer,
}

/// Number of passes for `key_bits` bits.
pub fn passes(key_bits: u32) -> u32 {
    key_bits.div_ceil(RADIX_BITS)
}

impl RadixSort {
    /// The WGSL of the three sort kernels.
    pub fn source() -> Wgsl {
        Wgsl::new()
            .constant("RADIX", RADIX)
            .constant("WG", WG)
            .constant("ITEMS", ITEMS)
            .constant("TILE", TILE)
            .constant("SCAN_WG", SCAN_WG)
            .part(wgsl_file!("gpu/radix_sort.wgsl"))
    }

    /// Their one layout: the pass's parameters, keys and values in
    /// (read-only), keys and values out and the tile histograms.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        vec![
            uniform_entry(0),
            storage_entry(1, true),
            storage_entry(2, true),
            storage_entry(3, false),
            storage_entry(4, false),
            storage_entry(5, false),
        ]
    }

    /// Compiles the kernels and allocates scratch for `capacity` pairs
    /// (two `capacity`-element u32 buffers and `16 · ⌈capacity / 2048⌉ + 16`
    /// tile counts).
    pub fn new(gpu: &Gpu, capacity: u32) -> Result<RadixSort> {
        let tiles = capacity.div_ceil(TILE).max(1);
        let (_, gy) = gpu.dispatch_dims(tiles);
        if gy > gpu.limits.max_compute_workgroups_per_dimension {
            bail!("radix sort capacity {capacity} needs more workgroups ({tiles}) than this adapter can dispatch");
        }
        let source = Self::source();
        let layout = gpu.bind_group_layout("lights.radix_sort.layout", &Self::layout_entries());
        let pipeline = |entry: &str| {
            gpu.compute_pipeline(
                &format!("lights.radix_sort.{entry}"),
                &source,
                entry,
                &[&layout],
            )
        };
        let usage = super::buffer::STORAGE;
        let bytes = 4 * capacity as u64;
        Ok(RadixSort {
            capacity,
            histogram: pipeline("histogram")?,
            scan_digits: pipeline("scan_digits")?,
            scatter: pipeline("scatter")?,
            layout,
            keys_tmp: gpu.buffer_zeroed("lights.radix_sort.keys_tmp", bytes, usage)?,
            values_tmp: gpu.buffer_zeroed("lights.radix_sort.values_tmp", bytes, usage)?,
            hist: gpu.buffer_zeroed(
                "lights.radix_sort.hist",
                4 * (RADIX as u64 * tiles as u64 + RADIX as u64),
                usage,
            )?,
        })
    }

    /// Largest `n` that [`RadixSort::sort`] accepts.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Records a stable sort of the first `n` pairs of `keys` / `values`
    /// by `key & (2^key_bits − 1)` into `encoder`, as one compute pass
    /// (given `timestamps`, for [`crate::gpu::Profiler::phase`]) followed,
    /// when the pass count `⌈key_bits / 4⌉` is odd, by a copy back (then
    /// both buffers need `COPY_DST`). The result is in `keys` / `values`
    /// once the encoder's commands have run. Key bits above `key_bits`
    /// travel with their keys but do not take part in the order. `n ≤ 1`
    /// or `key_bits == 0` records an empty pass.
    #[allow(clippy::too_many_arguments)]
    pub fn sort(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
        keys: &wgpu::Buffer,
        values: &wgpu::Buffer,
        n: u32,
        key_bits: u32,
    ) -> Result<()> {
        if n > self.capacity {
            bail!(
                "radix sort of {n} pairs exceeds its capacity of {}; create the sorter with a larger capacity",
                self.capacity
            );
        }
        if key_bits > 32 {
            bail!("radix sort key_bits = {key_bits}; keys have 32 bits");
        }
        for (name, b) in [("keys", keys), ("values", values)] {
            if b.size() < 4 * n as u64 {
                bail!(
                    "radix sort: the {name} buffer holds {} bytes, {n} pairs need {}",
                    b.size(),
                    4 * n as u64
                );
            }
            if !b.usage().contains(wgpu::BufferUsages::STORAGE) {
                bail!("radix sort: the {name} buffer lacks STORAGE usage");
            }
        }
        let passes = if n <= 1 { 0 } else { passes(key_bits) };
        if passes % 2 == 1 {
            for (name, b) in [("keys", keys), ("values", values)] {
                if !b.usage().contains(wgpu::BufferUsages::COPY_DST) {
                    bail!("radix sort: an odd pass count ({passes}) copies back into {name}, which lacks COPY_DST usage");
                }
            }
        }

        let tiles = n.div_ceil(TILE).max(1);
        let (gx, gy) = gpu.dispatch_dims(tiles);
        // Either alignment: the slices may be bound as storage
        // (`Gpu::uniforms_as_storage`).
        let stride = (std::mem::size_of::<Params>() as u64).next_multiple_of(
            gpu.limits
                .min_uniform_buffer_offset_alignment
                .max(gpu.limits.min_storage_buffer_offset_alignment) as u64,
        );
        let mut params = vec![0u8; (stride * MAX_PASSES as u64) as usize];
        for p in 0..passes {
            let shift = p * RADIX_BITS;
            let bits = RADIX_BITS.min(key_bits - shift);
            let value = Params {
                n,
                shift,
                mask: (1u32 << bits) - 1,
                tiles,
                groups_x: gx,
                _pad: [0; 3],
            };
            let at = (stride * p as u64) as usize;
            params[at..at + std::mem::size_of::<Params>()]
                .copy_from_slice(bytemuck::bytes_of(&value));
        }
        let params =
            gpu.buffer_from::<u8>("lights.radix_sort.params", &params, gpu.uniform_usage())?;
        let groups: Vec<wgpu::BindGroup> = (0..passes)
            .map(|p| {
                let (src, dst) = if p % 2 == 0 {
                    ((keys, values), (&self.keys_tmp, &self.values_tmp))
                } else {
                    ((&self.keys_tmp, &self.values_tmp), (keys, values))
                };
                let entries = [
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &params,
                            offset: stride * p as u64,
                            size: wgpu::BufferSize::new(std::mem::size_of::<Params>() as u64),
                        }),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: src.0.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: src.1.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: dst.0.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: dst.1.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: self.hist.as_entire_binding(),
                    },
                ];
                gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("lights.radix_sort.pass"),
                    layout: &self.layout,
                    entries: &entries,
                })
            })
            .collect();

        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("lights.radix_sort"),
                timestamp_writes: timestamps,
            });
            for group in &groups {
                pass.set_bind_group(0, group, &[]);
                pass.set_pipeline(&self.histogram);
                pass.dispatch_workgroups(gx, gy, 1);
                pass.set_pipeline(&self.scan_digits);
                pass.dispatch_workgroups(RADIX, 1, 1);
                pass.set_pipeline(&self.scatter);
                pass.dispatch_workgroups(gx, gy, 1);
            }
        }
        if passes % 2 == 1 {
            let bytes = 4 * n as u64;
            encoder.copy_buffer_to_buffer(&self.keys_tmp, 0, keys, 0, bytes);
            encoder.copy_buffer_to_buffer(&self.values_tmp, 0, values, 0, bytes);
        }
        Ok(())
    }
}
