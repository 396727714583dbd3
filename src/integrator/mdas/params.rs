//! The MDAS parameters: [`MdasParams`], their defaults and their one
//! registry, [`PARAMS`].
//!
//! Each `[mdas]` key is one [`Param`] row: its name, kind, range, the
//! default of a scene without the key, a doc line, and whether `mdas tune`
//! may vary it. The scene file's `[mdas]` table, the MDAS flags of the CLI
//! (`--alpha`, …, with their `--help`), [`validate`], `tune`'s grid keys
//! and the `[mdas]` table `tune` prints are all read from it, so a new
//! parameter is a field of [`MdasParams`] and a row here (and the kernels
//! that read it). `docs/scene-format.md`'s table is checked against it by
//! a unit test.

use crate::film::Film;

/// Parameters of the MDAS integrator (paper §5.1). A scene file's missing
/// keys come from [`MdasParams::for_film`]; `Default` is a film-agnostic
/// starting point for code (its 2^(d + 16)-cell initial grid needs a film
/// of 256×256 pixels or more at a few spp).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
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
    /// Where the initial samples sit inside their strata
    /// ([`InitialOffsets`]).
    pub initial_offsets: InitialOffsets,
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
            initial_offsets: InitialOffsets::Random,
            spp: 8.0,
            seed: 0,
            auto_grid: false,
        }
    }
}

/// How a full leaf picks the axis of its median split (the plane is the
/// median of its samples and the candidate along that axis either way;
/// only axes where the median separates them are eligible).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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

    /// The names, in the order of [`SplitRule::ALL`].
    pub const NAMES: [&'static str; 3] = ["extent", "contrast", "trimmed"];

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// Whether the rule looks at sample values (`SPLIT_CONTRAST` in WGSL).
    pub fn uses_values(self) -> bool {
        self != SplitRule::Extent
    }
}

impl std::str::FromStr for SplitRule {
    type Err = String;
    fn from_str(s: &str) -> Result<SplitRule, String> {
        let key = param("split").expect("a registry row");
        key.parse(s).map(|i| SplitRule::ALL[i as usize])
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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
    /// of [`MdasParams::for_film`] (with κ = 0) until `Shrinkage`. Not in
    /// the paper or its code.
    Sampled,
    /// `Sampled` with each leaf's own κ, estimated from its samples
    /// (empirical Bayes; `pixel_prior` is not used): a one-way analysis of
    /// variance of the leaf's finite samples by pixel gives the pooled
    /// within-pixel variance σ² and the variance τ² of the pixels' true
    /// means inside the leaf, and κ = σ²/τ² — the weight that minimises
    /// the expected squared error of a pixel's estimate when its mean is
    /// drawn around the leaf's with variance τ² (James–Stein shrinkage).
    /// Pixels that differ by more than their samples' noise keep their
    /// own samples (a lamp's edge: κ → 0); pixels that differ by no more
    /// share the leaf mean ([`super::config::SHRINK_KAPPA_MAX`]: the box).
    /// Where it cannot be estimated (all samples in one pixel, or one
    /// sample per pixel) κ = 0. The shrunk value stays within
    /// [`super::config::SHRINK_RATIO`] of the pixel's own samples' mean,
    /// per channel (a pixel whose samples read 0 keeps 0). A fixed κ > 0
    /// cut the RelMSE by 1.5–2× on motion blur and soft shadows and
    /// multiplied it by 10²–10³ on a lamp in view; this rule cut it by 8 %
    /// on 32 generated scenes, on 26 of them (BENCHMARKS.md, "Shrinkage
    /// toward the leaf mean"). The default of [`MdasParams::for_film`].
    /// Not in the paper or its code.
    Shrinkage,
}

impl Reconstruction {
    pub const ALL: [Reconstruction; 4] = [
        Reconstruction::Box,
        Reconstruction::Pixel,
        Reconstruction::Sampled,
        Reconstruction::Shrinkage,
    ];

    /// The names, in the order of [`Reconstruction::ALL`].
    pub const NAMES: [&'static str; 4] = ["box", "pixel", "sampled", "shrinkage"];

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// Whether a leaf's unsampled part of a pixel counts only where no leaf
    /// sampled it ([`super::config::UNSAMPLED_WEIGHT`]).
    pub fn skips_unsampled(self) -> bool {
        matches!(self, Reconstruction::Sampled | Reconstruction::Shrinkage)
    }
}

impl std::str::FromStr for Reconstruction {
    type Err = String;
    fn from_str(s: &str) -> Result<Reconstruction, String> {
        let key = param("reconstruction").expect("a registry row");
        key.parse(s).map(|i| Reconstruction::ALL[i as usize])
    }
}

impl std::fmt::Display for Reconstruction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Where each initial sample sits inside its stratum. A cell's l initial
/// samples are a Latin hypercube: along every axis they take the l equal
/// strata of the cell once each, in a random order (`initial.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InitialOffsets {
    /// A uniform offset per sample and axis, independent across samples
    /// and cells.
    #[default]
    Random,
    /// On every axis past the film, one offset per cell and axis, shared
    /// by the cell's samples: the cell's point frac(c·α_a + s_a) of a
    /// Kronecker sequence over the cell index c (α_a = frac(√p_a) for the
    /// a-th prime, s_a uniform per render), so that the cells of a pixel,
    /// neighbours in Morton order, spread their strata over the time,
    /// lens and light axes instead of placing them independently: a
    /// randomized quasi-Monte Carlo placement, uniform for each cell and
    /// so unbiased. The film axes keep independent offsets (the cells
    /// already stratify them; shared film offsets gave one seed of a
    /// path-traced scene a 10× RelMSE at a light's edge). Not in the paper
    /// or its code. BENCHMARKS.md, "Kronecker offsets for the initial samples".
    Kronecker,
}

impl InitialOffsets {
    pub const ALL: [InitialOffsets; 2] = [InitialOffsets::Random, InitialOffsets::Kronecker];
    /// The names, in the order of [`InitialOffsets::ALL`].
    pub const NAMES: [&'static str; 2] = ["random", "kronecker"];

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

impl std::str::FromStr for InitialOffsets {
    type Err = String;
    fn from_str(s: &str) -> Result<InitialOffsets, String> {
        let key = param("initial_offsets").expect("a registry row");
        key.parse(s).map(|i| InitialOffsets::ALL[i as usize])
    }
}

impl std::fmt::Display for InitialOffsets {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl MdasParams {
    /// The defaults of a scene file's `[mdas]` table: the initial grid
    /// chosen per render from the film and the budget (`auto_grid`, see
    /// [`auto_grid`]; the b, e and l stored here are its choice at the
    /// default 8 spp), α = [`AUTO_ALPHA`] with the paced selection
    /// (`pace` = [`AUTO_PACE`]), the `Shrinkage` reconstruction (each
    /// pixel from its own samples, shrunk toward its leaf's mean as far as
    /// the leaf's samples say its pixels agree), and the rest as
    /// [`Default`]. On scenes nobody tuned these replaced a grid of cells
    /// two pixels wide holding 1 spp or less, with the `Pixel`
    /// reconstruction (κ = 1), which lost to Halton 1.4–60× at equal
    /// samples (BENCHMARKS.md, issue 48).
    /// The values are [`PARAMS`]' `scene_default`s.
    pub fn for_film(film: Film) -> MdasParams {
        let mut p = MdasParams::default();
        for param in &PARAMS {
            if let Some(v) = param.scene_default {
                param.set(&mut p, v);
            }
        }
        MdasParams {
            auto_grid: true,
            ..p
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

/// Widest Morton code: every cell is a leaf and holds at least one sample.
pub const MORTON_BITS_MAX: u32 = 27;
/// A leaf's count has 4 bits and may reach m + 1 after the trimmed last
/// iteration.
pub const MAX_SAMPLES_PER_LEAF: u32 = super::words::leaf::COUNT_MASK - 1;
pub const MAX_CANDIDATES: u32 = 64;
pub const MAX_ALPHA: f32 = 64.0;
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

/// What a parameter's values are. Every value travels as an f64 (exact
/// for u32 and f32); a rule as the index of its name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A whole number (a u32 field).
    Int,
    /// A finite number (an f32 field).
    Number,
    /// One of these names (an enum field).
    Rule(&'static [&'static str]),
}

/// One end of a parameter's range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum End {
    Closed(f64),
    Open(f64),
    Unbounded,
}

/// One `[mdas]` key ([`PARAMS`]).
#[derive(Clone, Copy, Debug)]
pub struct Param {
    /// The `[mdas]` key; the flag is `--` and the key with `-` for `_`.
    pub key: &'static str,
    pub kind: Kind,
    pub min: End,
    pub max: End,
    /// The value of a scene whose `[mdas]` table leaves the key out
    /// ([`MdasParams::for_film`]); `None`: chosen per render (the
    /// automatic initial grid, [`auto_grid`]).
    pub scene_default: Option<f64>,
    /// What it does, in a line or two (the flag's `--help`).
    pub doc: &'static str,
    /// Whether `mdas tune`'s grid may vary it and the rendering commands
    /// take a flag for it (`spp` and `seed` have their commands' own).
    pub tunable: bool,
    /// Part of the initial grid (b, e, l): setting it fixes the grid
    /// (`auto_grid` off).
    pub grid: bool,
    get: fn(&MdasParams) -> f64,
    set: fn(&mut MdasParams, f64),
}

macro_rules! field {
    ($f:ident, f32) => {
        (
            |p: &MdasParams| f64::from(p.$f),
            |p: &mut MdasParams, v: f64| p.$f = v as f32,
        )
    };
    ($f:ident, u32) => {
        (
            |p: &MdasParams| f64::from(p.$f),
            |p: &mut MdasParams, v: f64| p.$f = v as u32,
        )
    };
    ($f:ident, $rule:ident) => {
        (
            |p: &MdasParams| $rule::ALL.iter().position(|&r| r == p.$f).unwrap_or(0) as f64,
            |p: &mut MdasParams, v: f64| p.$f = $rule::ALL[(v as usize).min($rule::ALL.len() - 1)],
        )
    };
}

macro_rules! param {
    ($key:ident: $ty:ident, $kind:expr, [$min:expr, $max:expr], $default:expr, tunable $tunable:expr, grid $grid:expr, $doc:expr) => {{
        let (get, set) = field!($key, $ty);
        Param {
            key: stringify!($key),
            kind: $kind,
            min: $min,
            max: $max,
            scene_default: $default,
            doc: $doc,
            tunable: $tunable,
            grid: $grid,
            get,
            set,
        }
    }};
}

use End::{Closed, Open, Unbounded};

/// Every `[mdas]` key, in the order of the docs' table.
pub const PARAMS: [Param; 15] = [
    param!(bits_per_dim: u32, Kind::Int, [Closed(0.0), Closed((MORTON_BITS_MAX / 2) as f64)], None, tunable true, grid true,
        "Morton bits per dimension of the initial grid (b); 2·(b + e) ≤ 27"),
    param!(extra_image_bits: u32, Kind::Int, [Closed(0.0), Closed((MORTON_BITS_MAX / 2) as f64)], None, tunable true, grid true,
        "Extra Morton bits of the two film axes (e); without it a scene's e is lowered by round(log2(1/F)) at --scale F"),
    param!(initial_samples_per_cell: u32, Kind::Int, [Closed(1.0), Closed(MAX_SAMPLES_PER_LEAF as f64)], None, tunable true, grid true,
        "Samples per initial grid cell (l), at most max_samples_per_leaf"),
    param!(scale_factor: f32, Kind::Number, [Open(0.0), Unbounded], Some(1.0), tunable true, grid false,
        "The film axes measure sf × their size in pixels (other axes 1) when a split picks the longest axis"),
    param!(alpha: f32, Kind::Number, [Closed(0.0), Closed(MAX_ALPHA as f64)], Some(AUTO_ALPHA as f64), tunable true, grid false,
        "Exponent α of the stochastic leaf selection (E/E_max)^α ≥ ξ; 0 selects every leaf"),
    param!(pace: f32, Kind::Number, [Closed(0.0), Closed(MAX_PACE as f64)], Some(AUTO_PACE as f64), tunable true, grid false,
        "The paced selection (not in the paper): the share of the samples left each adaptive iteration aims to place; 0 is the paper's rule"),
    param!(candidates: u32, Kind::Int, [Closed(1.0), Closed(MAX_CANDIDATES as f64)], Some(4.0), tunable true, grid false,
        "Best-candidate tries per inserted sample"),
    param!(max_samples_per_leaf: u32, Kind::Int, [Closed(2.0), Closed(MAX_SAMPLES_PER_LEAF as f64)], Some(4.0), tunable true, grid false,
        "Samples a leaf holds before it splits at its median (m; with an automatic grid at least l + 1)"),
    param!(epsilon: f32, Kind::Number, [Open(0.0), Closed(MAX_EPSILON as f64)], Some(EPSILON as f64), tunable true, grid false,
        "The ε of the contrast error E = V·(ε + c), c in [0, 2]: larger is less adaptive and less biased"),
    param!(split: SplitRule, Kind::Rule(&SplitRule::NAMES), [Unbounded, Unbounded], Some(0.0), tunable true, grid false,
        "Split axis of a full leaf: extent (the paper's largest scaled extent), contrast (where the halves' means differ most) or trimmed (contrast without the leaf's most outlying sample)"),
    param!(reconstruction: Reconstruction, Kind::Rule(&Reconstruction::NAMES), [Unbounded, Unbounded], Some(3.0), tunable true, grid false,
        "How leaves become pixels: box (the paper's eq. 7), pixel (each pixel from the leaf's samples in it, blended with the leaf mean by pixel_prior), sampled (pixel, a leaf's unsampled part of a pixel counting only where no leaf sampled it) or shrinkage (sampled with each leaf's κ estimated from its samples)"),
    param!(pixel_prior: f32, Kind::Number, [Closed(0.0), Closed(MAX_PIXEL_PRIOR as f64)], Some(0.0), tunable true, grid false,
        "The κ of the pixel and sampled reconstructions: the leaf mean's weight in samples (larger is closer to box)"),
    param!(initial_offsets: InitialOffsets, Kind::Rule(&InitialOffsets::NAMES), [Unbounded, Unbounded], Some(1.0), tunable true, grid false,
        "Where the initial samples sit in their strata: random (independently) or kronecker (past the film axes, one offset per cell from a Kronecker sequence over the cells; not in the paper)"),
    param!(spp: f32, Kind::Number, [Open(0.0), Unbounded], Some(8.0), tunable false, grid false,
        "Budget, samples per pixel on average (may be fractional)"),
    param!(seed: u32, Kind::Int, [Closed(0.0), Closed(u32::MAX as f64)], Some(0.0), tunable false, grid false,
        "Random seed"),
];

/// The row of `key`.
pub fn param(key: &str) -> Option<&'static Param> {
    PARAMS.iter().find(|p| p.key == key)
}

/// The keys, as `'a', 'b', …` for messages.
pub fn key_list(tunable_only: bool) -> String {
    PARAMS
        .iter()
        .filter(|p| p.tunable || !tunable_only)
        .map(|p| format!("'{}'", p.key))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A bound as the docs and messages write it (1e6 rather than 1000000).
fn bound(x: f64) -> String {
    if x.abs() >= 1e5 && x.fract() == 0.0 && x != u32::MAX as f64 {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

impl Param {
    /// The value in `p`.
    pub fn get(&self, p: &MdasParams) -> f64 {
        (self.get)(p)
    }

    /// `p` with this parameter set to `v` (already checked:
    /// [`Param::check`]); a grid key fixes the grid.
    pub fn set(&self, p: &mut MdasParams, v: f64) {
        if self.grid {
            p.auto_grid = false;
        }
        (self.set)(p, v)
    }

    /// The default of a scene without the key, as the docs write it.
    pub fn default_text(&self) -> String {
        self.scene_default
            .map_or_else(|| "automatic".into(), |v| self.format(v))
    }

    /// The flag of this key: `--` and the key with `-` for `_`.
    pub fn flag(&self) -> String {
        format!("--{}", self.key.replace('_', "-"))
    }

    /// The valid values, as the docs' table writes them:
    /// `integer 2..=14`, `number in [0, 64]`, `number > 0`, or the names.
    pub fn range_text(&self) -> String {
        match (self.kind, self.min, self.max) {
            (Kind::Rule(names), ..) => names
                .iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(", "),
            (Kind::Int, Closed(lo), Closed(hi)) => format!("integer {}..={}", bound(lo), bound(hi)),
            (Kind::Number, Open(lo), Unbounded) => format!("number > {}", bound(lo)),
            (Kind::Number, Closed(lo), Unbounded) => format!("number ≥ {}", bound(lo)),
            (_, min, max) => {
                let lo = match min {
                    Closed(x) => format!("[{}", bound(x)),
                    Open(x) => format!("({}", bound(x)),
                    Unbounded => "(-∞".into(),
                };
                let hi = match max {
                    Closed(x) => format!("{}]", bound(x)),
                    Open(x) => format!("{})", bound(x)),
                    Unbounded => "∞)".into(),
                };
                format!("number in {lo}, {hi}")
            }
        }
    }

    /// Whether `v` is a valid value, and why not.
    pub fn check(&self, v: f64) -> Result<(), String> {
        let within = |v: f64| {
            let above = match self.min {
                Closed(lo) => v >= lo,
                Open(lo) => v > lo,
                Unbounded => true,
            };
            let below = match self.max {
                Closed(hi) => v <= hi,
                Open(hi) => v < hi,
                Unbounded => true,
            };
            v.is_finite() && above && below
        };
        let ok = match self.kind {
            Kind::Int => v.fract() == 0.0 && within(v),
            Kind::Number => within(v),
            Kind::Rule(names) => v.fract() == 0.0 && v >= 0.0 && (v as usize) < names.len(),
        };
        if ok {
            return Ok(());
        }
        Err(match self.kind {
            Kind::Int => format!("must be in {}", &self.range_text()["integer ".len()..]),
            Kind::Number if self.range_text() == "number > 0" => "must be a positive number".into(),
            Kind::Number => format!("must be a {}", self.range_text()),
            Kind::Rule(_) => format!("must be one of {}", self.range_text()),
        })
    }

    /// Whether `v` is a value of this kind at all, its range aside: a
    /// whole number that fits a u32, a rule's index, or a finite number.
    /// The readers of flags and `tune` grids check it before [`Param::set`]
    /// (which casts); the range is [`validate`]'s.
    pub fn check_kind(&self, v: f64) -> Result<(), String> {
        let ok = match self.kind {
            Kind::Int => v.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(&v),
            Kind::Rule(names) => v.fract() == 0.0 && v >= 0.0 && (v as usize) < names.len(),
            Kind::Number => v.is_finite(),
        };
        if ok {
            Ok(())
        } else {
            Err(match self.kind {
                Kind::Int => "must be a whole number ≥ 0".to_string(),
                Kind::Rule(_) => format!("must be one of {}", self.range_text()),
                Kind::Number => "must be a finite number".to_string(),
            })
        }
    }

    /// `s` as a value of this parameter: a rule's name (as its index) or a
    /// finite number.
    pub fn parse(&self, s: &str) -> Result<f64, String> {
        let s = s.trim();
        match self.kind {
            Kind::Rule(names) => names
                .iter()
                .position(|&n| n == s)
                .map(|i| i as f64)
                .ok_or_else(|| {
                    format!(
                        "unknown {} '{s}', expected {}",
                        self.noun(),
                        quoted_or(names)
                    )
                }),
            _ => s
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("'{s}' is not a finite number")),
        }
    }

    /// `v` as written in a table or a label: a rule's name, or the number
    /// as its field holds it.
    pub fn format(&self, v: f64) -> String {
        match self.kind {
            Kind::Rule(names) => names
                .get(v as usize)
                .map_or_else(|| format!("{v}"), |n| (*n).into()),
            Kind::Int => format!("{v}"),
            Kind::Number => format!("{}", v as f32),
        }
    }

    /// `v` as a TOML value (a number as its f32 prints, so 0.1 stays 0.1).
    pub fn toml(&self, v: f64) -> toml::Value {
        match self.kind {
            Kind::Rule(_) => toml::Value::String(self.format(v)),
            Kind::Int => toml::Value::Integer(v as i64),
            Kind::Number => toml::Value::Float(self.format(v).parse().unwrap_or(v)),
        }
    }

    /// What a rule of this key is called in messages.
    fn noun(&self) -> &'static str {
        match self.key {
            "split" => "split rule",
            key => key,
        }
    }
}

/// `'a', 'b' or 'c'`.
fn quoted_or(names: &[&str]) -> String {
    let q: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
    match q.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => q.join(""),
    }
}

/// Checks the parameters that do not depend on the integrand: the one
/// validator of every `[mdas]` value (the scene file calls it too). Each
/// value against its [`PARAMS`] range, then the ranges that join two
/// keys.
pub fn validate(p: &MdasParams) -> Result<(), ParamError> {
    let fail = |key: &'static str, value: String, why: String| Err(ParamError { key, value, why });
    for param in &PARAMS {
        let v = param.get(p);
        if let Err(why) = param.check(v) {
            return fail(param.key, param.format(v), why);
        }
    }
    let (l, m) = (p.initial_samples_per_cell, p.max_samples_per_leaf);
    if l > m {
        return fail(
            "initial_samples_per_cell",
            l.to_string(),
            format!("must be in 1..=max_samples_per_leaf ({m})"),
        );
    }
    let morton = 2 * (p.bits_per_dim + p.extra_image_bits);
    if morton > MORTON_BITS_MAX {
        let (key, value) = if p.bits_per_dim > p.extra_image_bits {
            ("bits_per_dim", p.bits_per_dim)
        } else {
            ("extra_image_bits", p.extra_image_bits)
        };
        return fail(
            key,
            value.to_string(),
            format!(
                "with bits_per_dim = {} and extra_image_bits = {} the film axes alone need 2·(b + e) = {morton} Morton bits, at most {MORTON_BITS_MAX}",
                p.bits_per_dim, p.extra_image_bits
            ),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests;
