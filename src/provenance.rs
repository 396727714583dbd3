//! What every record of a run holds so that it can be rerun and checked
//! (`report.json` of `compare`, `sweep.json`, `render --json`, the
//! reference cache's `.json` beside each EXR): the command line, the scene
//! file's SHA-256, the integrand and its dimensions, every MDAS parameter
//! as run (after `--scale` and the flags; absent for Halton-only runs),
//! the crate version and the git commit it was built from (when built from
//! a checkout), the adapter and its driver, and the time.

use crate::gpu::Gpu;
use crate::integrand::Integrand;
use crate::integrator::mdas::MdasParams;
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::Path;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// The process's arguments, program first.
    pub command_line: Vec<String>,
    /// SHA-256 of the scene file's bytes, hex; absent for an integrand
    /// built in code ([`Provenance::of_integrand`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[serde(default)]
    pub scene_sha256: Option<String>,
    /// The integrand's name and dimension count.
    pub integrand: String,
    pub dims: u32,
    /// MDAS's parameters as run (its seed is the first of its seeds);
    /// absent when the run has no MDAS render.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[serde(default)]
    pub mdas: Option<MdasParams>,
    pub version: String,
    /// `git rev-parse HEAD` at build time, when built from a checkout.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[serde(default)]
    pub git_commit: Option<String>,
    pub adapter: String,
    pub driver: String,
    pub driver_info: String,
    /// When the report was written, UTC, ISO 8601.
    pub timestamp_utc: String,
}

impl Provenance {
    pub fn new(
        gpu: &Gpu,
        scene: &Path,
        integrand: &dyn Integrand,
        mdas: Option<MdasParams>,
    ) -> Result<Provenance> {
        let bytes =
            std::fs::read(scene).with_context(|| format!("cannot read {}", scene.display()))?;
        let digest = Sha256::digest(&bytes);
        let mut p = Provenance::of_integrand(gpu, integrand, mdas);
        p.scene_sha256 = Some(digest.iter().map(|b| format!("{b:02x}")).collect());
        Ok(p)
    }

    /// The provenance of a run on an integrand built in code (no scene
    /// file to digest).
    pub fn of_integrand(
        gpu: &Gpu,
        integrand: &dyn Integrand,
        mdas: Option<MdasParams>,
    ) -> Provenance {
        Provenance {
            command_line: command_line(),
            scene_sha256: None,
            integrand: integrand.name().to_string(),
            dims: integrand.dims(),
            mdas,
            version: env!("CARGO_PKG_VERSION").into(),
            git_commit: option_env!("MDAS_GIT_COMMIT").map(String::from),
            adapter: gpu.info.name.clone(),
            driver: gpu.info.driver.clone(),
            driver_info: gpu.info.driver_info.clone(),
            timestamp_utc: utc_timestamp(std::time::SystemTime::now()),
        }
    }
}

/// This process's arguments, each as text: bytes that are not UTF-8 (a
/// file name on Unix may hold any) become U+FFFD. `std::env::args` panics
/// on them, and did so after a run had written its outputs (issue 67,
/// hostile inputs class 3).
fn command_line() -> Vec<String> {
    std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect()
}

/// One part of a run merged from parts (`mdas merge`): which part, the
/// command that rendered it and when.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartProvenance {
    /// Part I of N, as `I/N`.
    pub part: String,
    pub command_line: Vec<String>,
    pub timestamp_utc: String,
}

impl Provenance {
    /// The provenance of a merge of parts whose first part's provenance is
    /// `self`: this process's command line and time, the rest unchanged.
    pub fn merged(&self) -> Provenance {
        Provenance {
            command_line: command_line(),
            timestamp_utc: utc_timestamp(std::time::SystemTime::now()),
            ..self.clone()
        }
    }
}

/// `YYYY-MM-DDTHH:MM:SSZ` of a time (days to civil date: H. Hinnant's
/// algorithm, proleptic Gregorian).
pub fn utc_timestamp(t: std::time::SystemTime) -> String {
    let secs = t
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + (month <= 2) as i64;
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, UNIX_EPOCH};

    #[test]
    fn timestamps_of_known_instants() {
        let at = |s: u64| utc_timestamp(UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        assert_eq!(at(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(at(1_798_761_599), "2026-12-31T23:59:59Z");
        assert_eq!(at(4_107_542_400), "2100-03-01T00:00:00Z");
    }
}
