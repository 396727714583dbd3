//! A budget search as `report.json` records it (`equal_time.halton`,
//! `equal_time.mdas`, `equal_time.adaptive.search`, each sampler's
//! `search`): its bracketing runs and the RelMSE at the target.

use super::equal_time::{interpolate_log_log, EqualTime, HaltonRun};
use serde::Serialize;

/// A run of a budget search, as reported.
#[derive(Clone, Debug, Serialize)]
pub struct BracketRun {
    pub spp: u32,
    pub samples: u64,
    pub time_ms: f64,
    pub relmse: f64,
    pub mse: f64,
}

impl From<&HaltonRun> for BracketRun {
    fn from(r: &HaltonRun) -> Self {
        BracketRun {
            spp: r.spp,
            samples: r.measured.render.samples,
            time_ms: r.measured.total_ms(),
            relmse: r.error.relmse,
            mse: r.error.mse,
        }
    }
}

/// A method's budget search at the target time.
#[derive(Clone, Debug, Serialize)]
pub struct SearchReport {
    /// The time the search looked for (mode `"mdas"`: MDAS's first timed
    /// run; the equal-time target itself comes from the interleaved rounds).
    pub target_ms: f64,
    /// Largest spp measured at or below the target time.
    pub lo: BracketRun,
    /// Smallest spp measured above it (= `lo` when the target lies outside
    /// what the search can reach).
    pub hi: BracketRun,
    /// Whether the target lies within [lo, hi] in time.
    pub bracketed: bool,
    /// RelMSE at exactly the target time, interpolated log–log between lo
    /// and hi.
    pub relmse: f64,
    /// MSE at exactly the target time, interpolated the same way.
    pub mse: f64,
    /// `"lo"` or `"hi"`: the run nearer in time, whose image is written.
    pub image_run: String,
}

impl SearchReport {
    pub fn new(eq: &EqualTime) -> SearchReport {
        let t = eq.target_ms;
        let (lo, hi) = (eq.lo.measured.total_ms(), eq.hi.measured.total_ms());
        SearchReport {
            target_ms: t,
            lo: (&eq.lo).into(),
            hi: (&eq.hi).into(),
            bracketed: lo <= t && t <= hi,
            relmse: eq.relmse,
            mse: interpolate_log_log(t, (lo, eq.lo.error.mse), (hi, eq.hi.error.mse)),
            image_run: if (t - lo).abs() <= (hi - t).abs() {
                "lo"
            } else {
                "hi"
            }
            .into(),
        }
    }
}
