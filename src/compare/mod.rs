//! Equal-time comparison of integrators (the experiment of the MDAS paper,
//! §5): timing with warm-up and medians, and Halton budget matching.

pub mod equal_time;

pub use equal_time::{halton_at_equal_time, measure, EqualTime, HaltonRun, Measured};
