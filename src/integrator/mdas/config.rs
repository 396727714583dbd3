//! Capacities and the storage layout of one render.
//!
//! Everything that can be checked without the integrand is checked by
//! [`validate`] (called from [`super::Mdas::new`]); [`Config::new`] adds the
//! checks that need the dimension count and the film, and derives the
//! buffer sizes. [`Config::check_device`] pages the arrays that grow with
//! the budget ([`super::pages`]) and compares them with the adapter's
//! limits before any GPU work starts.
//!
//! ## Capacities
//!
//! With C = 2^(d·b + 2e) cells, l initial samples per cell and a budget of
//! N = round(spp × pixels) samples, the run never holds more than N samples
//! (the last iteration is trimmed to the budget, see `adapt.wgsl`). A split
//! leaves h = ⌊(m+1)/2⌋ and m + 1 − h ≥ h samples in its children, leaves
//! never lose samples, and an unsplit cell keeps its l, so
//! N ≥ C·min(l, h) + (L − C)·h, i.e. the leaf count is bounded by
//! L ≤ C + (N − C·min(l, h)) / h. Both bounds are theorems of the
//! algorithm, so the kernels need no overflow checks.

use super::gpu_params::{STATS_PER_INVOCATION, WG};
use super::pages::{Pages, BASE_STORAGE_BINDINGS, PAGED_ARRAYS};
use super::params::{
    validate, InitialOffsets, MdasParams, Reconstruction, SplitRule, MORTON_BITS_MAX,
};
use super::MAX_ITERATIONS_DEFAULT;
use crate::film::Film;
use crate::gpu::shader::Wgsl;
use crate::gpu::Gpu;
use crate::integrand::{point_wgsl, MAX_DIMS};
use crate::wgsl_file;
use anyhow::{bail, Result};
/// Sample indices live in 27 bits of a leaf header (the rest: a 4-bit
/// count and the collapsed flag).
pub const SAMPLE_LIMIT: u64 = super::words::leaf::INDEX_MASK as u64;
/// Pixels one reconstruction invocation splats per dispatch.
pub const PIXELS_PER_PASS: u32 = 16384;
/// Under [`Reconstruction::Sampled`] and [`Reconstruction::Shrinkage`], the
/// factor on the weight of a leaf's
/// part of a pixel where the leaf has no sample (2⁻¹⁶): the pixel is
/// estimated from the leaves that sampled it, and falls back to the
/// overlap-weighted leaf means only where no leaf did. With the plain
/// weight a leaf straddling a lamp's edge put its mean on the dark pixel
/// beside it: MDAS/Halton RelMSE 60–140× on a small lamp in view
/// (BENCHMARKS.md, issue 48). Small enough to vanish beside a sampled
/// part, large enough for the fixed-point sums to keep 44 bits of weight.
pub const UNSAMPLED_WEIGHT: f32 = 1.0 / 65536.0;
/// Under [`Reconstruction::Shrinkage`], the κ of a leaf whose pixels differ
/// by no more than their samples' noise (`leaf_kappa` in
/// `wgsl/mdas/reconstruct.wgsl`): the leaf mean then weighs as 10⁶ samples,
/// so a pixel's value is the leaf mean to f32 precision, as with the box.
pub const SHRINK_KAPPA_MAX: f32 = 1e6;
/// Under [`Reconstruction::Shrinkage`], how far the leaf mean may move a
/// pixel's estimate: to within this factor of the mean of the leaf's own
/// samples in the pixel, per channel (a limited-translation estimator,
/// Efron & Morris 1972, bounded relatively because RelMSE weighs an error
/// by 1/value²: a pixel whose samples read 0 keeps 0).
pub const SHRINK_RATIO: f32 = 2.0;

/// One render's derived sizes.
#[derive(Clone, Debug)]
pub struct Config {
    pub params: MdasParams,
    pub dims: u32,
    pub film: Film,
    /// C = 2^(d·b + 2e).
    pub cells: u32,
    /// C·l.
    pub initial_samples: u32,
    /// N = round(spp × pixels).
    pub budget: u32,
    /// Bound on the leaf count (module docs).
    pub leaf_capacity: u32,
    pub coord_words: u32,
    pub sample_stride: u32,
    pub leaf_stride: u32,
    pub max_iterations: u32,
    /// Reconstruction dispatches needed to cover the widest leaf.
    pub reconstruct_passes: u32,
    /// How the per-sample and per-leaf arrays are split across bindings
    /// ([`Config::paged`]; one binding each as made by [`Config::new`]).
    pub pages: Pages,
    /// Samples one invocation of the evaluate pass takes, in a loop (1 as
    /// made by [`Config::new`]; [`super::Mdas::config_for`] sets the
    /// adapter's, as Halton's: 8 on a CPU adapter, 1 on a GPU). Invocation
    /// i of T evaluates new samples i, i + T, i + 2T, …, so neighbouring
    /// invocations still take neighbouring samples. The samples and their
    /// values are the same either way.
    pub eval_per_invocation: u32,
    /// Whether the compiler may unroll `decide`'s loops over a leaf's
    /// samples, the candidates and the axes (true as made by
    /// [`Config::new`]; [`super::Mdas::config_for`] sets false on a CPU
    /// adapter). Unrolled, a GPU keeps the leaf's arrays in registers; on
    /// lavapipe the unrolled count kernel was rebuilt at every dispatch
    /// (~7 ms a dispatch at m = 8, BENCHMARKS.md "Test suite time") —
    /// since uniforms are bound as storage there
    /// ([`crate::gpu::Gpu::uniforms_as_storage`]) it no longer is, and
    /// either setting costs the same. The image is the same either way.
    pub unroll_loops: bool,
}

impl Config {
    pub fn new(params: MdasParams, dims: u32, film: Film, max_iterations: u32) -> Result<Config> {
        validate(&params)?;
        let params = params.resolved(film);
        if !(3..=MAX_DIMS).contains(&dims) {
            bail!("MDAS supports integrands of 3..={MAX_DIMS} dimensions (film included); this one has {dims}");
        }
        let pixels = film.width as u64 * film.height as u64;
        if pixels == 0 {
            bail!("empty film {}×{}", film.width, film.height);
        }
        let (b, e) = (params.bits_per_dim, params.extra_image_bits);
        let morton_bits = dims * b + 2 * e;
        if morton_bits > MORTON_BITS_MAX {
            bail!(
                "the initial grid needs a Morton code of d·b + 2e = {dims}·{b} + 2·{e} = {morton_bits} bits; at most {MORTON_BITS_MAX} are supported: lower bits_per_dim or extra_image_bits"
            );
        }
        let cells = 1u64 << morton_bits;
        let l = params.initial_samples_per_cell as u64;
        let initial = cells * l;
        let budget = (params.spp as f64 * pixels as f64).round() as u64;
        if budget < initial {
            bail!(
                "the budget spp × pixels = {} × {pixels} = {budget} samples is below the {initial} initial samples (2^{morton_bits} cells × {l}); raise spp or lower bits_per_dim, extra_image_bits or initial_samples_per_cell",
                params.spp
            );
        }
        if budget > SAMPLE_LIMIT {
            // As f64: a huge spp saturates the u64 (it printed as
            // 18446744073709551615; issue 54 item 8).
            let exact = params.spp as f64 * pixels as f64;
            bail!("the budget spp × pixels = {} × {pixels} = {exact:e} samples exceeds the {SAMPLE_LIMIT} MDAS can index; lower spp or the resolution", params.spp);
        }
        let m = params.max_samples_per_leaf as u64;
        let h = m.div_ceil(2);
        let leaf_capacity = cells + (budget - cells * l.min(h)) / h;
        let coord_words = dims.div_ceil(2);
        // Widest leaf: an initial cell, misaligned with the pixel grid.
        let cover = |side: u32| (side as u64).div_ceil(1 << (b + e)).min(side as u64 - 1) + 1;
        let widest = cover(film.width) * cover(film.height);
        Ok(Config {
            params,
            dims,
            film,
            cells: cells as u32,
            initial_samples: initial as u32,
            budget: budget as u32,
            leaf_capacity: leaf_capacity as u32,
            coord_words,
            sample_stride: coord_words,
            leaf_stride: 3,
            max_iterations: if max_iterations == 0 {
                MAX_ITERATIONS_DEFAULT
            } else {
                max_iterations
            },
            reconstruct_passes: widest.div_ceil(PIXELS_PER_PASS as u64) as u32,
            pages: Pages {
                shift: 31,
                count: [1; 4],
            },
            eval_per_invocation: 1,
            unroll_loops: true,
        })
    }

    pub fn pixels(&self) -> u64 {
        self.film.width as u64 * self.film.height as u64
    }

    /// Cell, header and error: 12 bytes per leaf.
    pub fn leaves_bytes(&self) -> u64 {
        self.leaf_capacity as u64 * self.leaf_stride as u64 * 4
    }

    /// Words per leaf in the boxes buffer: d box words, slots 1 … m − 1
    /// (slot 0 is in the header, slot m in the error word).
    pub fn box_stride(&self) -> u32 {
        self.dims + self.params.max_samples_per_leaf - 1
    }

    /// Box (one word per axis) and sample slots 1 … m − 1: 4(d + m − 1)
    /// bytes per leaf.
    pub fn boxes_bytes(&self) -> u64 {
        self.leaf_capacity as u64 * self.box_stride() as u64 * 4
    }

    pub fn samples_bytes(&self) -> u64 {
        self.budget as u64 * self.sample_stride as u64 * 4
    }

    /// RGB bits: 12 bytes per sample.
    pub fn values_bytes(&self) -> u64 {
        self.budget as u64 * 12
    }

    pub fn partials_bytes(&self) -> u64 {
        (self.leaf_capacity as u64).div_ceil(WG as u64) * 8
    }

    /// Fixed-point accumulators: 3 colours + weight, 64 bits each.
    pub fn accum_bytes(&self) -> u64 {
        self.pixels() * 32
    }

    /// Whether the accumulators fit in the coordinate buffer's first
    /// page, which no kernel reads after the last placement
    /// (spp·⌈d/2⌉ ≥ 8 on one page).
    /// `Reconstruction::Pixel` reads the coordinates while it splats, so
    /// its accumulators get their own buffer.
    pub fn accum_in_samples(&self) -> bool {
        self.params.reconstruction == Reconstruction::Box
            && self.page_bytes(1, 0) >= self.accum_bytes()
    }

    pub const COUNTERS_BYTES: u64 = 4 * super::counter::LEN as u64;
    pub const STATE_BYTES: u64 = 4 * super::state::LEN as u64;
    /// Indirect arguments: two dispatches of three words (plan.wgsl).
    pub const ARGS_BYTES: u64 = super::plan::ARGS_BYTES;

    /// Every buffer the render allocates (the figure in `Render::gpu_bytes`).
    pub fn gpu_bytes(&self) -> u64 {
        let accum = if self.accum_in_samples() {
            16
        } else {
            self.accum_bytes()
        };
        self.leaves_bytes()
            + self.boxes_bytes()
            + self.samples_bytes()
            + self.values_bytes()
            + self.partials_bytes()
            + accum
            + Self::COUNTERS_BYTES
            + Self::STATE_BYTES
            + Self::ARGS_BYTES
            + std::mem::size_of::<super::gpu_params::GpuParams>() as u64
    }

    /// What every MDAS kernel's WGSL starts from: [`Config::constants`],
    /// the integrand point, random numbers, warps, Morton codes and
    /// `mdas/common.wgsl` (each kernel module's `source` adds its file).
    pub fn base_wgsl(&self) -> Wgsl {
        point_wgsl()
            .include(&self.constants())
            .part(wgsl_file!("shared/rng.wgsl"))
            .part(wgsl_file!("shared/sampling.wgsl"))
            .part(wgsl_file!("shared/morton.wgsl"))
            .part(("mdas/pages.wgsl (generated)", self.pages.wgsl()))
            .part(wgsl_file!("mdas/common.wgsl"))
    }

    /// The generated WGSL constants every MDAS kernel is compiled with.
    pub fn constants(&self) -> Wgsl {
        let indices = super::counter::ALL.iter().chain(super::state::ALL);
        let counters = indices.fold(Wgsl::new(), |w, &(name, index)| {
            w.constant(name, index as u32)
        });
        let counters = super::words::leaf::ALL
            .iter()
            .fold(counters, |w, &(name, value)| w.constant(name, value));
        counters
            .constant("DIMS", self.dims)
            .constant("BITS_PER_DIM", self.params.bits_per_dim)
            .constant("EXTRA_BITS", self.params.extra_image_bits)
            .constant("SAMPLES_PER_CELL", self.params.initial_samples_per_cell)
            .constant("MAX_PER_LEAF", self.params.max_samples_per_leaf)
            .constant("CANDIDATES", self.params.candidates)
            .constant("SPLIT_CONTRAST", self.params.split.uses_values() as u32)
            .constant(
                "SPLIT_TRIM",
                (self.params.split == SplitRule::Trimmed) as u32,
            )
            .constant(
                "RECONSTRUCT_PIXEL",
                (self.params.reconstruction != Reconstruction::Box) as u32,
            )
            .constant(
                "RECONSTRUCT_SAMPLED",
                self.params.reconstruction.skips_unsampled() as u32,
            )
            .constant_f32("UNSAMPLED_WEIGHT", UNSAMPLED_WEIGHT)
            .constant(
                "RECONSTRUCT_SHRINK",
                (self.params.reconstruction == Reconstruction::Shrinkage) as u32,
            )
            .constant_f32("SHRINK_KAPPA_MAX", SHRINK_KAPPA_MAX)
            .constant_f32("SHRINK_RATIO", SHRINK_RATIO)
            .constant(
                "INITIAL_KRONECKER",
                (self.params.initial_offsets == InitialOffsets::Kronecker) as u32,
            )
            .constant("EVAL_PER_INVOCATION", self.eval_per_invocation)
            .constant("UNROLL_LOOPS", self.unroll_loops as u32)
            .constant("COORD_WORDS", self.coord_words)
            .constant("SAMPLE_STRIDE", self.sample_stride)
            .constant("LEAF_STRIDE", self.leaf_stride)
            .constant("WG", WG)
            .constant("STATS_PER_INVOCATION", STATS_PER_INVOCATION)
            .constant("PIXELS_PER_PASS", PIXELS_PER_PASS)
    }
}

/// The paging of a render and its checks against an adapter.
impl Config {
    /// Words of each array in [`PAGED_ARRAYS`].
    pub fn paged_words(&self) -> [u64; 4] {
        [
            self.leaves_bytes(),
            self.samples_bytes(),
            self.values_bytes(),
            self.boxes_bytes(),
        ]
        .map(|bytes| bytes / 4)
    }

    /// The same render with its arrays split into pages of at most
    /// `page_bytes` (rounded down to a power of two, at least 16 bytes).
    pub fn paged(mut self, page_bytes: u64) -> Config {
        let words = (page_bytes / 4).max(4);
        let shift = (63 - words.leading_zeros()).min(31);
        let count = self
            .paged_words()
            .map(|w| w.div_ceil(1u64 << shift).max(1) as u32);
        self.pages = Pages { shift, count };
        self
    }

    /// Bytes of page `page` of array `array` (an index into
    /// [`PAGED_ARRAYS`]): full pages, then the rest.
    pub fn page_bytes(&self, array: usize, page: u32) -> u64 {
        let words = self.paged_words()[array];
        let start = u64::from(page) * self.pages.words();
        words.saturating_sub(start).min(self.pages.words()) * 4
    }

    /// Paged for `limits` (pages of the largest storage binding, or of
    /// `max_page_bytes` if smaller) and checked against them: the
    /// configuration a render on that adapter uses.
    pub fn for_limits(self, limits: &wgpu::Limits, max_page_bytes: Option<u64>) -> Result<Config> {
        let binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            .min(max_page_bytes.unwrap_or(u64::MAX));
        let cfg = self.paged(binding);
        cfg.check_paged(limits)?;
        Ok(cfg)
    }

    /// Fails, before any GPU work, when the render cannot be laid out on
    /// the adapter ([`Config::check_limits`]).
    pub fn check_device(&self, gpu: &Gpu) -> Result<()> {
        self.check_limits(&gpu.limits)
    }

    /// Whether the render fits `limits` once paged for them
    /// ([`Config::for_limits`]): the arrays that grow with the budget take
    /// as many storage bindings as they need, up to the adapter's storage
    /// buffers per shader stage; the accumulators (32 B per pixel) and
    /// the scan totals must fit one binding each.
    pub fn check_limits(&self, limits: &wgpu::Limits) -> Result<()> {
        self.clone().for_limits(limits, None).map(|_| ())
    }

    fn check_paged(&self, limits: &wgpu::Limits) -> Result<()> {
        let capacity = || {
            format!(
                "MDAS capacity: {} samples ({} initial) and up to {} leaves of {}D do not fit this adapter",
                self.budget, self.initial_samples, self.leaf_capacity, self.dims
            )
        };
        let bindings = BASE_STORAGE_BINDINGS + self.pages.extra();
        let allowed = limits.max_storage_buffers_per_shader_stage;
        if bindings > allowed {
            let mib = |b: u64| b as f64 / 1048576.0;
            let [l, s, v, b] = self.paged_words().map(|w| mib(4 * w));
            bail!(
                "{}: leaves {l:.1} MiB, boxes {b:.1} MiB, sample coordinates {s:.1} MiB and values {v:.1} MiB \
                 in pages of {:.1} MiB need {bindings} storage buffers, and this adapter allows {allowed} per shader stage \
                 (the integrand's own buffers come on top); reduce the resolution or spp",
                capacity(),
                mib(4 * self.pages.words())
            );
        }
        let limit = |what: &str, bytes: u64| -> Result<()> {
            crate::gpu::buffer::check_binding_size_in(limits, what, bytes)
                .map_err(|e| e.context(capacity()))
        };
        for (i, (name, _)) in PAGED_ARRAYS.iter().enumerate() {
            limit(&format!("mdas.{name}"), self.page_bytes(i, 0))?;
        }
        limit("mdas.partials", self.partials_bytes())?;
        limit("mdas.accum", self.accum_bytes())?;
        let groups = (self.leaf_capacity as u64).div_ceil(WG as u64);
        let max_groups = limits.max_compute_workgroups_per_dimension as u64;
        if groups > max_groups * max_groups {
            bail!(
                "{} leaves need more workgroups than this adapter can dispatch",
                self.leaf_capacity
            );
        }
        Ok(())
    }
}
