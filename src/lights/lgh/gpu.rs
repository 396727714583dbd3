//! The lighting grid hierarchy built on the GPU per frame
//! (`wgsl/lights/lgh_build.wgsl`; rules and CPU oracle: [`super::lgh`]).
//!
//! The grid (bounds, level count, `h_1`) is computed on the host from the
//! frame's lights, which the host holds anyway (profiler phase
//! `lgh.grid`, wall clock); everything else runs on the GPU in one batch:
//! `lgh.keys` (level-1 cell of each light), `lgh.sort` (stable radix sort
//! of (cell, id)), `lgh.cells` (clear, then each cell's range),
//! `lgh.level1` and `lgh.levels` (the gathers). Buffers:
//!
//! * `index` (u32): the vertex index of every level ([`super::lgh::EMPTY`]
//!   or a grid light), then (start, end) of each level-1 cell, then the
//!   light ids sorted by cell — bound as `light_index` for shading;
//! * `lights`: the grid lights, compacted by an atomic counter (their
//!   order varies from run to run, their values and the index's meaning do
//!   not: shading reads them through the index only).

use super::{self as lgh, GridLight, LghGrid, LghParams};
use crate::gpu::buffer::STORAGE;
use crate::gpu::radix_sort::RadixSort;
use crate::gpu::shader::{bind_buffers, storage_entry, uniform_entry, Wgsl};
use crate::gpu::{Gpu, Profiler};
use crate::kernel_base::RAY_ITERATIONS;
use crate::lights::light_params::{LightParams, SamplerBuffers};
use crate::lights::tree::gpu_build;
use crate::lights::{LightPrim, KIND_TRIANGLE};
use crate::wgsl_file;
use anyhow::{bail, Context, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Invocations per workgroup of the build kernels.
const WG: u32 = 128;

/// lavapipe stops every loop of an invocation after 65,535 iterations in all
/// (docs/conventions.md "Known pitfalls"): the gathers and the shading walk
/// stay below this on a CPU adapter, or the build is refused with the reason.
const CPU_LOOP_BUDGET: u64 = 60_000;

/// Profiler phases of a build, in order.
pub const PHASES: [&str; 6] = [
    "lgh.grid",
    "lgh.keys",
    "lgh.sort",
    "lgh.cells",
    "lgh.level1",
    "lgh.levels",
];

/// `LghBuildParams` of `wgsl/lights/lgh_build.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LghBuildParams {
    pub lo: [f32; 3],
    pub levels: u32,
    pub h1: f32,
    pub inv_h1: f32,
    pub n: u32,
    pub level: u32,
    pub cells_offset: u32,
    pub sorted_offset: u32,
    pub groups_x: u32,
    pub clear_len: u32,
}

/// A lighting grid hierarchy over one frame's lights, built on the GPU.
pub struct GpuLgh {
    pub grid: LghGrid,
    pub params: LghParams,
    /// Vertex index, cell ranges, sorted ids (module docs).
    pub index: wgpu::Buffer,
    /// Grid lights (first `counter` entries after a build).
    pub lights: wgpu::Buffer,
    /// The number of grid lights (one u32).
    pub counter: wgpu::Buffer,
    keys: wgpu::Buffer,
    ids: wgpu::Buffer,
    sorter: RadixSort,
    layout: wgpu::BindGroupLayout,
    keys_pipeline: wgpu::ComputePipeline,
    clear_pipeline: wgpu::ComputePipeline,
    cells_pipeline: wgpu::ComputePipeline,
    level1_pipeline: wgpu::ComputePipeline,
    level_pipeline: wgpu::ComputePipeline,
    light_count: u32,
    /// Emissive triangles among the lights (not grid lights).
    triangles: u32,
    /// Loop iterations of one shading walk ([`Self::loop_iterations`]).
    walk: u64,
    /// Host time of the grid computation, ms.
    grid_ms: f64,
}

/// The WGSL the build kernels and shading share: the light structs and
/// `lights/lgh_light.wgsl`.
pub fn light_wgsl() -> Wgsl {
    gpu_build::prim_wgsl().part(wgsl_file!("lights/lgh_light.wgsl"))
}

impl GpuLgh {
    /// The build kernels' WGSL.
    pub fn source() -> Wgsl {
        light_wgsl()
            .constant("WG", WG)
            .part(wgsl_file!("lights/lgh_build.wgsl"))
    }

    /// Their one layout: parameters, the lights (read-only), keys, ids,
    /// index, grid lights, counter.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        let mut e = vec![uniform_entry(0), storage_entry(1, true)];
        e.extend((2..=6).map(|b| storage_entry(b, false)));
        e
    }

    /// Sizes the hierarchy for `prims` (the grid is theirs: module docs)
    /// and compiles the kernels. Fails with the reason when the adapter
    /// cannot hold it, or, on a CPU adapter, when a gather or the shading
    /// walk would pass lavapipe's loop cap.
    pub fn new(gpu: &Gpu, prims: &[LightPrim], params: &LghParams) -> Result<GpuLgh> {
        let start = std::time::Instant::now();
        let grid = LghGrid::new(prims, params.levels)?;
        let n = u32::try_from(prims.len())?;
        let c = grid.cells() as u64;
        let index_len = grid.index_len();
        let cells_offset = index_len;
        let sorted_offset = cells_offset + 2 * c.pow(3);
        let total = sorted_offset + n as u64;
        if total > u32::MAX as u64 {
            bail!("lgh: {total} index entries do not fit 32-bit offsets; lower lgh_levels");
        }
        // Grid lights: at most 8 per light of the level below, at most one
        // per vertex.
        let mut capacity = 0u64;
        let mut below = n as u64;
        for level in 1..=grid.levels {
            let here = (grid.res(level) as u64).pow(3).min(8 * below);
            capacity += here;
            below = here;
        }
        let capacity = capacity.max(1);
        // Name the key that sets the size (issue 54 item 8).
        let levels = || {
            format!(
                "[integrand] lgh_levels = {}: the grid hierarchy does not fit this adapter; \
                 lower lgh_levels",
                grid.levels
            )
        };
        gpu.check_binding_size("lgh index", 4 * total)
            .with_context(levels)?;
        gpu.check_binding_size("lgh grid lights", 64 * capacity)
            .with_context(levels)?;
        let cpu = gpu.info.device_type == wgpu::DeviceType::Cpu;
        let (walk, gather) = Self::loop_bounds(&grid, prims, params, cpu);
        if cpu {
            if gather > CPU_LOOP_BUDGET {
                bail!(
                    "lgh: {} lights share one level-1 cell, more than a vertex can gather on \
                     this CPU adapter (lavapipe ends loops after 65,535 iterations); raise \
                     lgh_levels (now {})",
                    gather / 8,
                    grid.levels
                );
            }
            let one = 2 * walk + RAY_ITERATIONS * (params.shadow_samples as u64 + 1);
            if one > CPU_LOOP_BUDGET {
                bail!(
                    "lgh: one evaluation may visit up to {walk} lights twice, more than this CPU \
                     adapter's loop cap allows (lavapipe ends loops after 65,535 iterations); \
                     lower lgh_alpha (now {}){}",
                    params.alpha,
                    if params.level0 {
                        " or turn lgh_level0 off"
                    } else {
                        ""
                    }
                );
            }
        }
        let grid_ms = start.elapsed().as_secs_f64() * 1e3;

        let source = Self::source();
        let layout = gpu.bind_group_layout("lgh.build.layout", &Self::layout_entries());
        let pipeline =
            |entry: &str| gpu.compute_pipeline(&format!("lgh.{entry}"), &source, entry, &[&layout]);
        let usage = STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
        let per_light = 4 * (n as u64).max(1);
        Ok(GpuLgh {
            grid,
            params: *params,
            index: gpu.buffer_zeroed("lgh.index", 4 * total.max(1), usage)?,
            lights: gpu.buffer_zeroed("lgh.lights", 64 * capacity, usage)?,
            counter: gpu.buffer_zeroed("lgh.counter", 4, usage)?,
            keys: gpu.buffer_zeroed("lgh.keys", per_light, usage)?,
            ids: gpu.buffer_zeroed("lgh.ids", per_light, usage)?,
            sorter: RadixSort::new(gpu, n.max(1))?,
            keys_pipeline: pipeline("lgh_keys")?,
            clear_pipeline: pipeline("lgh_clear")?,
            cells_pipeline: pipeline("lgh_cells")?,
            level1_pipeline: pipeline("lgh_level1")?,
            level_pipeline: pipeline("lgh_level")?,
            layout,
            light_count: n,
            triangles: prims.iter().filter(|l| l.kind == KIND_TRIANGLE).count() as u32,
            walk,
            grid_ms,
        })
    }

    /// The loop iterations of one shading walk and of the densest level-1
    /// vertex gather (the vertex boxes of every level and the level-0 cells
    /// with their lights; the 8 cells of a vertex). The densest cell is
    /// counted (a pass over the lights: ~85 ms for 1M on this VM) only
    /// when `count_cells` or level 0 needs it; else the gather bound is 0.
    fn loop_bounds(
        grid: &LghGrid,
        prims: &[LightPrim],
        params: &LghParams,
        count_cells: bool,
    ) -> (u64, u64) {
        let c = grid.cells();
        let mut densest = 0;
        if count_cells || params.level0 {
            let mut count = vec![0u64; (c as usize).pow(3)];
            for l in prims.iter().filter(|l| l.kind != KIND_TRIANGLE) {
                let (cell, _) = grid.cell_of(1, Vec3::from(l.p0));
                count[(cell[0] + c * (cell[1] + c * cell[2])) as usize] += 1;
            }
            densest = count.iter().copied().max().unwrap_or(0);
        }
        let side = (2.0 * (2.0 * params.alpha as f64 + 1.0)).floor() as u64 + 1;
        let mut walk: u64 = (1..=grid.levels)
            .map(|l| side.min(grid.res(l) as u64).pow(3))
            .sum();
        if params.level0 {
            let cells = ((2.0 * params.alpha as f64).floor() as u64 + 1).min(c as u64);
            walk += cells.pow(3) + (cells.pow(3) * densest).min(prims.len() as u64);
        }
        (walk, 8 * densest)
    }

    /// An upper bound on the loop iterations of one `lgh` evaluation: two
    /// walks, and a typical ray's traversal (a few hundred steps) for the
    /// camera ray and each shadow ray.
    pub fn loop_iterations(&self) -> u64 {
        2 * self.walk + RAY_ITERATIONS * (self.params.shadow_samples as u64 + 1)
    }

    pub fn light_count(&self) -> u32 {
        self.light_count
    }

    /// First `index` entry of the cell ranges.
    pub fn cells_offset(&self) -> u32 {
        self.grid.index_len() as u32
    }

    /// First `index` entry of the sorted ids.
    pub fn sorted_offset(&self) -> u32 {
        self.cells_offset() + 2 * self.grid.cells().pow(3)
    }

    /// Binds the hierarchy into the samplers' bindings for `params.count`
    /// lights: the grid lights (24), the index (18) and the `lgh_*`
    /// parameters.
    pub fn bind(&self, params: &mut LightParams, out: &mut SamplerBuffers) -> Result<()> {
        let n = params.count;
        if self.light_count != n {
            bail!(
                "grid hierarchy over {} lights for {n} lights",
                self.light_count
            );
        }
        self.set_light_params(params);
        out.index = Some(self.index.clone());
        out.lgh_lights = Some(self.lights.clone());
        Ok(())
    }

    /// Fills the `lgh_*` fields of the sampler parameters.
    pub fn set_light_params(&self, p: &mut LightParams) {
        p.lgh_lo = self.grid.lo.into();
        p.lgh_levels = self.grid.levels;
        p.lgh_h1 = self.grid.h1;
        p.lgh_inv_h1 = self.grid.inv_h1;
        p.lgh_alpha = self.params.alpha;
        p.lgh_level0 = self.params.level0 as u32;
        p.lgh_shadows = self.params.shadow_samples;
        p.lgh_cells_offset = self.cells_offset();
        p.lgh_sorted_offset = self.sorted_offset();
        p.lgh_triangles = self.triangles;
        p.lgh_soft2 = self.grid.soft2(self.params.clamp);
    }

    /// Builds the hierarchy from `prims` (the lights [`Self::new`] was
    /// sized for, uploaded), its phases timed by `profiler`.
    pub fn build(&self, gpu: &Gpu, prims: &wgpu::Buffer, profiler: &mut Profiler) -> Result<()> {
        let g = &self.grid;
        let n = self.light_count;
        let base = LghBuildParams {
            lo: g.lo.into(),
            levels: g.levels,
            h1: g.h1,
            inv_h1: g.inv_h1,
            n,
            level: 1,
            cells_offset: self.cells_offset(),
            sorted_offset: self.sorted_offset(),
            groups_x: 0,
            clear_len: self.sorted_offset(),
        };
        let group = |threads: u32, level: u32| -> (wgpu::BindGroup, (u32, u32)) {
            let dims = gpu.dispatch_dims(threads.div_ceil(WG).max(1));
            let params = LghBuildParams {
                level,
                groups_x: dims.0,
                ..base
            };
            let uniform = gpu.uniform("lgh.build.params", &params);
            let buffers = [
                &uniform,
                prims,
                &self.keys,
                &self.ids,
                &self.index,
                &self.lights,
                &self.counter,
            ];
            let bg = bind_buffers(gpu, "lgh.build.group", &self.layout, &buffers);
            (bg, dims)
        };
        let run = |pass: &mut wgpu::ComputePass<'_>,
                   pipeline: &wgpu::ComputePipeline,
                   (bg, dims): &(wgpu::BindGroup, (u32, u32))| {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bg, &[]);
            pass.dispatch_workgroups(dims.0, dims.1, 1);
        };
        let per_light = group(n, 1);
        let clear = group(self.sorted_offset(), 1);
        let level1 = group(g.res(1).pow(3), 1);
        let levels: Vec<_> = (2..=g.levels).map(|l| group(g.res(l).pow(3), l)).collect();
        profiler.wall_phase(PHASES[0], self.grid_ms);
        gpu.scoped("building the lighting grid hierarchy", || {
            let mut batch = profiler.batch("lgh.build");
            fn pass<'e>(
                encoder: &'e mut wgpu::CommandEncoder,
                timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
                label: &str,
            ) -> wgpu::ComputePass<'e> {
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(label),
                    timestamp_writes: timestamps,
                })
            }
            batch.phase(PHASES[1], |e, t| {
                e.clear_buffer(&self.counter, 0, None);
                let mut p = pass(e, t, PHASES[1]);
                if n > 0 {
                    run(&mut p, &self.keys_pipeline, &per_light);
                }
            })?;
            let mut sorted = Ok(());
            // One bit more than the cells need: triangles sort past them.
            let bits = 3 * (g.levels - 1) + 1;
            batch.phase(PHASES[2], |e, t| {
                sorted = self.sorter.sort(gpu, e, t, &self.keys, &self.ids, n, bits);
            })?;
            sorted?;
            batch.encoder().copy_buffer_to_buffer(
                &self.ids,
                0,
                &self.index,
                4 * self.sorted_offset() as u64,
                4 * n as u64,
            );
            batch.phase(PHASES[3], |e, t| {
                let mut p = pass(e, t, PHASES[3]);
                run(&mut p, &self.clear_pipeline, &clear);
                if n > 0 {
                    run(&mut p, &self.cells_pipeline, &per_light);
                }
            })?;
            batch.phase(PHASES[4], |e, t| {
                let mut p = pass(e, t, PHASES[4]);
                run(&mut p, &self.level1_pipeline, &level1);
            })?;
            batch.phase(PHASES[5], |e, t| {
                let mut p = pass(e, t, PHASES[5]);
                for l in &levels {
                    run(&mut p, &self.level_pipeline, l);
                }
            })?;
            batch.submit();
            Ok(())
        })
    }

    /// Reads the build back: the vertex index of every level, the cell
    /// ranges, the sorted ids, and the grid lights (for tests).
    pub fn read(&self, gpu: &Gpu) -> Result<(lgh::Lgh, u32)> {
        let index: Vec<u32> = gpu.read_buffer(
            &self.index,
            self.sorted_offset() as usize + self.light_count as usize,
        )?;
        let count = gpu.read_buffer::<u32>(&self.counter, 1)?[0];
        let cap = (self.lights.size() / 64) as usize;
        let lights: Vec<GridLight> = gpu.read_buffer(&self.lights, cap)?;
        let vertex_len = self.cells_offset() as usize;
        let cells = index[vertex_len..self.sorted_offset() as usize]
            .chunks(2)
            .map(|p| [p[0], p[1]])
            .collect();
        Ok((
            lgh::Lgh {
                grid: self.grid,
                lights,
                index: index[..vertex_len].to_vec(),
                cells,
                sorted: index[self.sorted_offset() as usize..].to_vec(),
            },
            count,
        ))
    }
}
