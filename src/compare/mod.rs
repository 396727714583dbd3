//! Equal-time comparison of integrators (the experiment of the MDAS paper,
//! §5, with pixel-adaptive Halton as a third method, [`adaptive`]): timing with warm-up and medians, budget matching, interleaved
//! timing rounds with a time fit and statistics over seeds ([`intervals`],
//! [`seeds`]), `mdas compare` ([`experiment`]) with its report
//! ([`report`], provenance in `crate::provenance`), its files
//! ([`outputs`]: images, RelMSE and FLIP heat maps, density map, the
//! [`figure`]), light
//! samplers against each other (`mdas compare --samplers`, [`samplers`]), and
//! `mdas sweep` ([`sweep`]) with its CSV and log–log plot, `mdas tune`
//! ([`tune`]): MDAS over a grid of parameters, and `mdas bench`
//! ([`phases`]): MDAS's phases against Halton at equal samples.

pub mod adaptive;
pub mod csv_table;
pub mod equal_time;
pub mod experiment;
pub mod figure;
pub mod heatmap;
pub mod inputs;
pub mod intervals;
pub mod merge;
pub mod outputs;
pub mod phases;
pub mod plot;
pub mod progress;
pub mod report;
pub mod samplers;
pub mod search_report;
pub mod seeds;
pub mod sweep;
pub mod timing;
pub mod tune;
pub mod tune_report;

pub use equal_time::{
    halton_at_equal_time, measure, search_equal_time, EqualTime, HaltonRun, Measured,
};
pub use experiment::{compare, compare_integrand, compare_with};
pub use inputs::{Budget, CompareSpec, ReferenceSource, Setup, Subject};
pub use report::{Report, REPORT_SCHEMA_VERSION};
pub use samplers::{compare_samplers, SamplersSpec};
pub use sweep::{sweep_integrand, SweepSpec};
pub use tune::{tune_integrand, TuneSpec};
