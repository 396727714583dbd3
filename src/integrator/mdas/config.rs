//! Parameter validation, capacities and the storage layout of one render.
//!
//! Everything that can be checked without the integrand is checked by
//! [`validate`] (called from [`super::Mdas::new`]); [`Config::new`] adds the
//! checks that need the dimension count and the film, and derives the
//! buffer sizes. [`Config::check_device`] compares them with the adapter's
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
use super::MAX_ITERATIONS_DEFAULT;
use crate::film::Film;
use crate::gpu::shader::Wgsl;
use crate::gpu::Gpu;
use crate::integrand::{point_wgsl, MAX_DIMS};
use crate::wgsl_file;
use anyhow::{bail, Result};

/// Parameters of the MDAS integrator (paper §5.1). A scene file's missing
/// keys come from [`MdasParams::for_film`]; `Default` is a film-agnostic
/// starting point for code (its 2^(d + 16)-cell initial grid needs a film
/// of 256×256 pixels or more at a few spp).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct MdasParams {
    pub bits_per_dim: u32,
    pub extra_image_bits: u32,
    pub initial_samples_per_cell: u32,
    pub scale_factor: f32,
    pub alpha: f32,
    pub candidates: u32,
    pub max_samples_per_leaf: u32,
    /// ε of the contrast error E = V·(ε + c) (eq. 4; [`EPSILON`]).
    pub epsilon: f32,
    /// How a full leaf picks its split axis ([`SplitRule`]).
    pub split: SplitRule,
    /// How leaves become pixels ([`Reconstruction`]).
    pub reconstruction: Reconstruction,
    /// κ of [`Reconstruction::Pixel`]: the weight, in samples, of the
    /// leaf's mean in each pixel's estimate ([`PIXEL_PRIOR`]).
    pub pixel_prior: f32,
    /// The paced selection: the share of the samples left that each
    /// iteration aims to place (0: the paper's rule, [`AUTO_PACE`]).
    pub pace: f32,
    pub spp: f32,
    pub seed: u32,
    /// Whether the initial grid (b, e, l) is chosen when the render starts,
    /// from its film and budget ([`MdasParams::resolved`]), rather than
    /// taken from `bits_per_dim`, `extra_image_bits` and
    /// `initial_samples_per_cell`: true for a scene whose `[mdas]` table
    /// gives none of the three ([`MdasParams::for_film`]), false once any
    /// of them is set (in the table, by a flag or a `tune` grid).
    pub auto_grid: bool,
}

impl Default for MdasParams {
    fn default() -> Self {
        MdasParams {
            bits_per_dim: 1,
            extra_image_bits: 8,
            initial_samples_per_cell: 1,
            scale_factor: 1.0,
            alpha: 0.25,
            candidates: 4,
            max_samples_per_leaf: 4,
            epsilon: EPSILON,
            split: SplitRule::Extent,
            reconstruction: Reconstruction::Pixel,
            pixel_prior: PIXEL_PRIOR,
            pace: 0.0,
            spp: 8.0,
            seed: 0,
            auto_grid: false,
        }
    }
}

/// How a full leaf picks the axis of its median split (the plane is the
/// median of its samples and the candidate along that axis either way;
/// only axes where the median separates them are eligible).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SplitRule {
    /// The paper's: the largest extent, film axes scaled by sf × size.
    #[default]
    Extent,
    /// The axis whose two halves' existing samples differ most in mean
    /// value (the sum of the three channels, finite samples only; an axis
    /// with no finite sample on one side scores 0), the scaled extent
    /// breaking ties — so a flat leaf splits as with `Extent`. Not in the
    /// paper or its code: it aims at film-space edges and temporal or lens
    /// features without per-scene sf tuning.
    Contrast,
    /// `Contrast` with the leaf's most outlying existing sample left out
    /// of the two halves' means: the finite sample whose channel sum lies
    /// farthest from the mean of the finite ones (the first on ties), when
    /// at least three are finite. One lucky sample (a rare bright path)
    /// then cannot steer the split: under `Contrast` it always lands on the
    /// side with fewer samples, whose region is sampled more densely from
    /// then on, so the lucky value is diluted while the leaves that missed
    /// keep their dark estimates — a dark bias (Kirk & Arvo 1991). A
    /// feature that two samples see still steers it. On `cornell_pt` at
    /// α = 0 it cut the bias from −0.6 % to −0.04 % (BENCHMARKS.md,
    /// issue 11). Not in the paper or its code.
    Trimmed,
}

impl SplitRule {
    pub const ALL: [SplitRule; 3] = [SplitRule::Extent, SplitRule::Contrast, SplitRule::Trimmed];

    pub fn name(self) -> &'static str {
        match self {
            SplitRule::Extent => "extent",
            SplitRule::Contrast => "contrast",
            SplitRule::Trimmed => "trimmed",
        }
    }

    /// Whether the rule looks at sample values (`SPLIT_CONTRAST` in WGSL).
    pub fn uses_values(self) -> bool {
        self != SplitRule::Extent
    }
}

impl std::str::FromStr for SplitRule {
    type Err = String;
    fn from_str(s: &str) -> Result<SplitRule, String> {
        SplitRule::ALL
            .into_iter()
            .find(|r| r.name() == s)
            .ok_or_else(|| {
                format!("unknown split rule '{s}', expected 'extent', 'contrast' or 'trimmed'")
            })
    }
}

impl std::fmt::Display for SplitRule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How the leaves' samples become pixel values. `Pixel` is the default
/// ([`MdasParams::default`], scene files): at equal samples it cut MDAS's
/// RelMSE by up to 2.2× on the six paper stand-ins whose leaves are wider
/// than a pixel and tied on the others, but where the only feature is
/// smooth in film space the box's averaging wins (`scenes/tests/
/// shadow_edge.toml`, a 6-pixel penumbra: 0.80 × Halton's RelMSE against
/// 1.00; BENCHMARKS.md, "Per-pixel reconstruction").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Reconstruction {
    /// The paper's eq. 7: each leaf splats its mean f̄ over every pixel
    /// its film projection overlaps, weighted by the overlap. A leaf
    /// wider than a pixel spreads one value across the film-space edges
    /// inside it.
    Box,
    /// Each pixel p a leaf overlaps gets (Σ_{s in p} f_s + κ·f̄)/(n_p + κ)
    /// instead of f̄: the mean of the leaf's n_p finite samples whose film
    /// position lies in p, pulled toward the leaf mean by κ pseudo-samples
    /// (`pixel_prior`; f̄ alone where n_p = 0). A leaf's samples are
    /// uniform in it (up to best-candidate placement), so those in p are
    /// uniform in the leaf's part of p:
    /// the estimate of that part no longer borrows the values of the
    /// leaf's other pixels, at the cost of fewer samples per value. Not
    /// in the paper or its code; κ → ∞ is `Box`.
    #[default]
    Pixel,
    /// `Pixel`, except that a leaf's part of a pixel where the leaf has no
    /// sample enters that pixel with [`UNSAMPLED_WEIGHT`] × its overlap
    /// instead of its full overlap: each pixel is estimated from the
    /// samples that landed in it, and falls back to the overlap-weighted
    /// leaf means only where no leaf placed a sample. A leaf straddling
    /// an edge then moves no value onto a pixel it did not sample — the
    /// failure of `Pixel` on small bright emitters (a lamp's leaf mean
    /// spread onto the black pixels beside it). Biased toward the sampled
    /// parts of a pixel where a pixel is only partly sampled. The default
    /// of [`MdasParams::for_film`] (with κ = 0). Not in the paper or its
    /// code.
    Sampled,
}

impl Reconstruction {
    pub const ALL: [Reconstruction; 3] = [
        Reconstruction::Box,
        Reconstruction::Pixel,
        Reconstruction::Sampled,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Reconstruction::Box => "box",
            Reconstruction::Pixel => "pixel",
            Reconstruction::Sampled => "sampled",
        }
    }
}

impl std::str::FromStr for Reconstruction {
    type Err = String;
    fn from_str(s: &str) -> Result<Reconstruction, String> {
        Reconstruction::ALL
            .into_iter()
            .find(|r| r.name() == s)
            .ok_or_else(|| {
                format!("unknown reconstruction '{s}', expected 'box', 'pixel' or 'sampled'")
            })
    }
}

impl std::fmt::Display for Reconstruction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl MdasParams {
    /// The defaults of a scene file's `[mdas]` table: the initial grid
    /// chosen per render from the film and the budget (`auto_grid`, see
    /// [`auto_grid`]; the b, e and l stored here are its choice at the
    /// default 8 spp), α = [`AUTO_ALPHA`] with the paced selection
    /// (`pace` = [`AUTO_PACE`]), the `Sampled` reconstruction
    /// with κ = 0 (each pixel from its own samples), and the rest as
    /// [`Default`]. On scenes nobody tuned these replaced a grid of cells
    /// two pixels wide holding 1 spp or less, with the `Pixel`
    /// reconstruction (κ = 1), which lost to Halton 1.4–60× at equal
    /// samples (BENCHMARKS.md, issue 48).
    pub fn for_film(film: Film) -> MdasParams {
        MdasParams {
            auto_grid: true,
            alpha: AUTO_ALPHA,
            reconstruction: Reconstruction::Sampled,
            pixel_prior: 0.0,
            pace: AUTO_PACE,
            ..MdasParams::default()
        }
        .resolved(film)
    }

    /// These parameters with the initial grid chosen for `film` at their
    /// budget when `auto_grid` is set ([`auto_grid`]); unchanged otherwise.
    pub fn resolved(self, film: Film) -> MdasParams {
        if !self.auto_grid {
            return self;
        }
        let (e, l) = auto_grid(film, self.spp);
        MdasParams {
            bits_per_dim: 0,
            extra_image_bits: e,
            initial_samples_per_cell: l,
            max_samples_per_leaf: self.max_samples_per_leaf.max(l + 1),
            ..self
        }
    }
}

/// The share of the budget an automatic initial grid aims to spend on its
/// stratified initial samples ([`auto_grid`]); the rest is value-driven.
/// On three scenes nobody tuned (motion blur, a small lamp in view, an
/// indirectly lit room; 128×96, 8 and 32 spp) every step from 2/3 to 1
/// lowered the RelMSE, by up to 1.6× (BENCHMARKS.md, issue 48): the
/// stratified grid carries most of MDAS's gain there, and 1/6 is kept for
/// the value-driven samples, which pay on the scenes with features to find.
pub const AUTO_INITIAL_SHARE: f64 = 5.0 / 6.0;
/// α of a scene without an `[mdas]` table ([`MdasParams::for_film`]).
/// A larger α sends the value-driven samples to the leaves of highest
/// error: on the battery's 32 generated scenes at 8 spp (BENCHMARKS.md,
/// issue 48) the geometric mean of MDAS/Halton's RelMSE was 1.07 at the
/// paper's usual 1/4, 0.88 at 1, 0.83 at 4 — but under the paper's rule a
/// large α takes few leaves per iteration, so many iterations run (46 at
/// α = 4 on one scene), each paying every pass's fixed cost. With the
/// paced selection ([`AUTO_PACE`]) α = 2 gives 0.87 in a few iterations:
/// at equal time 1.34 against α = 1/4's 1.33 (the same battery, lavapipe).
pub const AUTO_ALPHA: f32 = 2.0;
/// `pace` of a scene without an `[mdas]` table ([`MdasParams::for_film`]).
///
/// The paper selects a leaf with probability (E/E_max)^α, so the number of
/// leaves an iteration takes follows the errors' spread: few at a large α,
/// and a render of many small iterations (each paying every pass's fixed
/// cost). With `pace` = s > 0 the probability is min(1, c·(E/E_max)^α), the
/// factor c ≥ 1 fed back per iteration (plan.wgsl) so that an iteration
/// places about s of the samples left (at least s/4 of the value-driven
/// samples): the same order of leaves, in a few large iterations. A
/// departure from the paper. 1/2 at α = 2 (above); 1/4 took more
/// iterations for no accuracy at α = 4 (0.83 either way, equal time 1.58
/// against 1.46).
pub const AUTO_PACE: f32 = 0.5;
/// Largest `pace`: an iteration may aim to place every sample left.
pub const MAX_PACE: f32 = 1.0;
/// Fewest samples per cell an automatic grid accepts before it takes a
/// coarser one, down to cells a pixel wide ([`auto_grid`]).
pub const AUTO_MIN_SAMPLES_PER_CELL: u32 = 4;
/// Most samples per cell of an automatic grid.
pub const AUTO_MAX_SAMPLES_PER_CELL: u32 = 8;

/// The initial grid `(e, l)` (with b = 0) of a render of `film` at `spp`
/// when `auto_grid` is set ([`MdasParams::resolved`], which also raises
/// m to l + 1, so that an initial cell takes a value-driven sample before
/// it splits): the finest film grid — down from one level finer than a pixel
/// (cells at most half a pixel wide on the longer axis) — whose cells each
/// take [`AUTO_MIN_SAMPLES_PER_CELL`] initial samples within
/// [`AUTO_INITIAL_SHARE`] of the budget N, with l = ⌊share · N / 4^e⌋
/// samples per cell (at most [`AUTO_MAX_SAMPLES_PER_CELL`]). Where no such
/// grid is finer than a pixel, the pixel-fine grid with l ≥ 1 if the budget
/// allows, else the finest coarser grid with l ≥ 1. A pixel-fine grid keeps
/// a cell's samples from being reconstructed into pixels they never
/// touched (small bright features), and the large initial share keeps
/// value-driven selection — where MDAS's bias and its losses on untuned
/// scenes came from — to the rest of the budget.
pub fn auto_grid(film: Film, spp: f32) -> (u32, u32) {
    let pixels = f64::from(film.width) * f64::from(film.height);
    let budget = (f64::from(spp) * pixels).round().max(1.0);
    let longer = f64::from(film.width.max(film.height).max(1));
    let pixel_fine = (longer.log2().ceil() as u32).min(12);
    let per_cell = |e: u32| (AUTO_INITIAL_SHARE * budget / 4f64.powi(e as i32)).floor();
    let pick = |e: u32, l: f64| (e, (l as u32).min(AUTO_MAX_SAMPLES_PER_CELL));
    for e in (pixel_fine..=pixel_fine + 1).rev() {
        let l = per_cell(e);
        if l >= f64::from(AUTO_MIN_SAMPLES_PER_CELL) {
            return pick(e, l);
        }
    }
    for e in (0..=pixel_fine).rev() {
        let l = per_cell(e);
        if l >= 1.0 {
            return pick(e, l);
        }
    }
    (0, 1)
}

/// Sample indices live in 27 bits of a leaf header (the rest: a 4-bit
/// count and the collapsed flag).
pub const SAMPLE_LIMIT: u64 = super::words::leaf::INDEX_MASK as u64;
/// Widest Morton code: every cell is a leaf and holds at least one sample.
pub const MORTON_BITS_MAX: u32 = 27;
/// A leaf's count has 4 bits and may reach m + 1 after the trimmed last
/// iteration.
pub const MAX_SAMPLES_PER_LEAF: u32 = super::words::leaf::COUNT_MASK - 1;
pub const MAX_CANDIDATES: u32 = 64;
pub const MAX_ALPHA: f32 = 64.0;
/// Pixels one reconstruction invocation splats per dispatch.
pub const PIXELS_PER_PASS: u32 = 16384;
/// The default ε of the contrast error (eq. 4; `epsilon` in `[mdas]`,
/// `--epsilon`): a leaf of constant value keeps
/// E = V·ε > 0, so every leaf can still be selected (the paper gives no
/// value). Leaves whose samples all missed a small feature look constant;
/// the smaller ε, the more rarely they are revisited and the more the
/// estimate is biased low (tests/mdas_quality.rs: a 4%-thick slab read
/// 0.36 of its true mean with ε = 1e-3 and 0.61 with 1e-2 at α = ¼), while a
/// larger ε spends more samples on flat regions (1e-2 still halves Halton's
/// RelMSE on a sharp edge). The contrast c is in [0, 2] (the mean over RGB
/// of each channel's mean|f − f̄|/|f̄|, clamped), so ε ≫ 2 makes selection
/// follow the leaf volume alone. The paper's code uses 1e-5 (on a
/// contrast summed over channels).
pub const EPSILON: f32 = 1e-2;
/// Largest ε accepted.
pub const MAX_EPSILON: f32 = 1e6;
/// The default κ of [`Reconstruction::Pixel`] (`pixel_prior`): the leaf
/// mean counts as one sample in each pixel's estimate (κ = 1 had the
/// lowest RelMSE, or within its interval of it, among 0, ½, 1 and 2 on
/// six scenes: BENCHMARKS.md).
pub const PIXEL_PRIOR: f32 = 1.0;
/// Under [`Reconstruction::Sampled`], the factor on the weight of a leaf's
/// part of a pixel where the leaf has no sample (2⁻¹⁶): the pixel is
/// estimated from the leaves that sampled it, and falls back to the
/// overlap-weighted leaf means only where no leaf did. With the plain
/// weight a leaf straddling a lamp's edge put its mean on the dark pixel
/// beside it: MDAS/Halton RelMSE 60–140× on a small lamp in view
/// (BENCHMARKS.md, issue 48). Small enough to vanish beside a sampled
/// part, large enough for the fixed-point sums to keep 44 bits of weight.
pub const UNSAMPLED_WEIGHT: f32 = 1.0 / 65536.0;
/// Largest κ accepted (beyond it `Pixel` equals `Box` to f32 precision).
pub const MAX_PIXEL_PRIOR: f32 = 1e6;

/// A parameter out of its range: the `[mdas]` key it names and why.
/// The scene file positions it at that key; elsewhere it reads as a
/// plain message.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{key} = {value}: {why}")]
pub struct ParamError {
    pub key: &'static str,
    pub value: String,
    pub why: String,
}

/// Checks the parameters that do not depend on the integrand: the one
/// validator of every `[mdas]` value (the scene file calls it too).
pub fn validate(p: &MdasParams) -> Result<(), ParamError> {
    let fail = |key: &'static str, value: &dyn std::fmt::Display, why: String| {
        Err(ParamError {
            key,
            value: value.to_string(),
            why,
        })
    };
    let m = p.max_samples_per_leaf;
    if !(2..=MAX_SAMPLES_PER_LEAF).contains(&m) {
        return fail("max_samples_per_leaf", &m, format!("must be in 2..={MAX_SAMPLES_PER_LEAF} (a full leaf of m samples plus one splits at its object median)"));
    }
    let l = p.initial_samples_per_cell;
    if l == 0 || l > m {
        return fail(
            "initial_samples_per_cell",
            &l,
            format!("must be in 1..=max_samples_per_leaf ({m})"),
        );
    }
    if p.candidates == 0 || p.candidates > MAX_CANDIDATES {
        return fail(
            "candidates",
            &p.candidates,
            format!("must be in 1..={MAX_CANDIDATES}"),
        );
    }
    if !(p.alpha.is_finite() && (0.0..=MAX_ALPHA).contains(&p.alpha)) {
        return fail(
            "alpha",
            &p.alpha,
            format!("must be a number in [0, {MAX_ALPHA}]"),
        );
    }
    if !(p.epsilon.is_finite() && p.epsilon > 0.0 && p.epsilon <= MAX_EPSILON) {
        return fail(
            "epsilon",
            &p.epsilon,
            format!("must be a number in (0, {MAX_EPSILON}]"),
        );
    }
    if !(p.pixel_prior.is_finite() && (0.0..=MAX_PIXEL_PRIOR).contains(&p.pixel_prior)) {
        return fail(
            "pixel_prior",
            &p.pixel_prior,
            format!("must be a number in [0, {MAX_PIXEL_PRIOR}]"),
        );
    }
    if !(p.pace.is_finite() && (0.0..=MAX_PACE).contains(&p.pace)) {
        return fail(
            "pace",
            &p.pace,
            format!("must be a number in [0, {MAX_PACE}]"),
        );
    }
    if !(p.scale_factor.is_finite() && p.scale_factor > 0.0) {
        return fail(
            "scale_factor",
            &p.scale_factor,
            "must be a positive number".into(),
        );
    }
    if !(p.spp.is_finite() && p.spp > 0.0) {
        return fail("spp", &p.spp, "must be a positive number".into());
    }
    // u64: 2·(b + e) of two u32s must not wrap (4294967295 printed 0).
    let morton = 2 * (u64::from(p.bits_per_dim) + u64::from(p.extra_image_bits));
    if p.bits_per_dim > 16 || p.extra_image_bits > 16 || morton > u64::from(MORTON_BITS_MAX) {
        let key = if p.bits_per_dim > p.extra_image_bits {
            "bits_per_dim"
        } else {
            "extra_image_bits"
        };
        return fail(
            key,
            &if key == "bits_per_dim" { p.bits_per_dim } else { p.extra_image_bits },
            format!(
                "with bits_per_dim = {} and extra_image_bits = {} the film axes alone need 2·(b + e) = {morton} Morton bits, at most {MORTON_BITS_MAX}",
                p.bits_per_dim, p.extra_image_bits
            ),
        );
    }
    Ok(())
}

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

/// The arrays that grow with the budget, in the order of their extra
/// pages' bindings: name in WGSL and the binding of page 0.
pub const PAGED_ARRAYS: [(&str, u32); 4] =
    [("leaves", 1), ("samples", 2), ("values", 3), ("boxes", 7)];
/// Binding of the first extra page (bindings 0–8 are the base layout).
pub const FIRST_EXTRA_BINDING: u32 = 9;
/// Storage buffers of the base layout (bindings 1–8).
pub const BASE_STORAGE_BINDINGS: u32 = 8;

/// Pages of the arrays in [`PAGED_ARRAYS`]: each array's words are split
/// into pages of 2^shift words, one storage binding each, so that the
/// capacity is the device's memory rather than its largest storage
/// binding (lavapipe: 128 MiB, which held `cornell_pt` at 1024² to 8 spp).
/// Kernels reach them through `leaves_get(i)` / `leaves_set(i, v)` and the
/// like ([`Pages::wgsl`]); an array on one page compiles to plain indexing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Pages {
    /// log2 of the words per page.
    pub shift: u32,
    /// Pages of leaves, samples, values and boxes.
    pub count: [u32; 4],
}

impl Pages {
    /// Pages beyond the first of each array (bindings from
    /// [`FIRST_EXTRA_BINDING`] on).
    pub fn extra(&self) -> u32 {
        self.count.iter().map(|c| c - 1).sum()
    }

    /// Words per page.
    pub fn words(&self) -> u64 {
        1u64 << self.shift
    }

    /// The declarations of the paged arrays and their accessors
    /// (`wgsl/mdas/common.wgsl` explains the layout). An array on one page
    /// is indexed directly; on several, `i >> shift` picks the binding and
    /// `i & (2^shift − 1)` the word in it. Words are addressed one by one,
    /// so a record may straddle two pages.
    pub fn wgsl(&self) -> String {
        use std::fmt::Write;
        let mut out = String::new();
        let mut binding = FIRST_EXTRA_BINDING;
        for (&(name, first), &count) in PAGED_ARRAYS.iter().zip(&self.count) {
            let decl = |out: &mut String, b: u32, n: &str| {
                writeln!(
                    out,
                    "@group(0) @binding({b}) var<storage, read_write> {n}: array<u32>;"
                )
                .unwrap();
            };
            decl(&mut out, first, name);
            if count == 1 {
                writeln!(out, "fn {name}_get(i: u32) -> u32 {{ return {name}[i]; }}").unwrap();
                writeln!(out, "fn {name}_set(i: u32, v: u32) {{ {name}[i] = v; }}").unwrap();
                continue;
            }
            for page in 1..count {
                decl(&mut out, binding, &format!("{name}_{page}"));
                binding += 1;
            }
            let mask = (1u64 << self.shift) - 1;
            let shift = self.shift;
            for (sig, op) in [
                (format!("fn {name}_get(i: u32) -> u32"), "return {a}[o];"),
                (format!("fn {name}_set(i: u32, v: u32)"), "{a}[o] = v;"),
            ] {
                writeln!(
                    out,
                    "{sig} {{\n    let o = i & {mask}u;\n    switch (i >> {shift}u) {{"
                )
                .unwrap();
                for page in 1..count {
                    let body = op.replace("{a}", &format!("{name}_{page}"));
                    writeln!(out, "        case {page}u: {{ {body} }}").unwrap();
                }
                let body = op.replace("{a}", name);
                writeln!(out, "        default: {{ {body} }}\n    }}\n}}").unwrap();
            }
        }
        out
    }
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
                (self.params.reconstruction == Reconstruction::Sampled) as u32,
            )
            .constant_f32("UNSAMPLED_WEIGHT", UNSAMPLED_WEIGHT)
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
