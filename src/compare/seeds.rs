//! Statistics over independent seeds: a method rendered K times with
//! different seeds gives K images, from which the error is split into bias
//! and noise (Kirk & Arvo 1991: an adaptive method can be biased, so one
//! image cannot tell the two apart).
//!
//! For images x_s (s = 1..K), their per-pixel mean m and the reference r,
//! over the pixels finite in every image and the three channels:
//!
//! ```text
//! MSE_s        = mean_pc (x_spc − r_pc)²
//! mse_bias2    = mean_pc (m_pc − r_pc)²
//! mse_variance = mean_pc 1/K Σ_s (x_spc − m_pc)²
//! mean_s MSE_s = mse_bias2 + mse_variance          (exactly, by algebra)
//! relative_bias_c = Σ_p m_pc / Σ_p r_pc − 1        (per channel)
//! ```
//!
//! `mse_variance` uses 1/K, not 1/(K − 1), so that the split adds up to
//! the mean MSE; it underestimates the variance by (K − 1)/K, and the bias
//! term contains the rest (and the reference's own noise). The intervals are
//! Student-t intervals of the mean over seeds (K − 1 degrees of freedom),
//! which assume the per-seed values are independent and roughly normal; for
//! ratios of means [`bootstrap_ci95`] resamples both sides.

use crate::metrics;
use anyhow::{bail, Result};
use serde::Serialize;

/// Two-sided 95% quantile of Student's t with `dof` degrees of freedom,
/// tabulated to 30 and rounded up in the third decimal; above 30 the value
/// at 30 (2.043 ≥ every later quantile), so the interval is never narrower
/// than exact.
pub fn t_quantile_95(dof: usize) -> f64 {
    const T: [f64; 30] = [
        12.707, 4.303, 3.183, 2.777, 2.571, 2.447, 2.365, 2.307, 2.263, 2.229, 2.201, 2.179, 2.161,
        2.145, 2.132, 2.120, 2.110, 2.101, 2.094, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.049, 2.046, 2.043,
    ];
    match dof {
        0 => f64::INFINITY,
        d => T[d.min(30) - 1],
    }
}

/// Mean and 95% interval of independent values (Student t); with one
/// value the interval is unbounded.
pub fn mean_ci95(values: &[f64]) -> (f64, [f64; 2]) {
    let k = values.len();
    let mean = values.iter().sum::<f64>() / k.max(1) as f64;
    if k < 2 {
        return (mean, [f64::NEG_INFINITY, f64::INFINITY]);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
    let half = t_quantile_95(k - 1) * (var / k as f64).sqrt();
    (mean, [mean - half, mean + half])
}

/// Reads back an interval of [`mean_ci95`] as a record wrote it: JSON has
/// no infinities, so one seed's (−∞, +∞) is written `[null, null]`; a null
/// lower bound reads back as −∞ and a null upper bound as +∞, which write
/// back as the same nulls (issue 67, hostile inputs class 5: parts of
/// `--seeds 1` could not be merged). For
/// `#[serde(deserialize_with = "...")]`.
pub fn de_interval<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    let [lo, hi]: [Option<f64>; 2] = serde::Deserialize::deserialize(d)?;
    Ok([lo.unwrap_or(f64::NEG_INFINITY), hi.unwrap_or(f64::INFINITY)])
}

/// [`de_interval`] per channel.
pub fn de_intervals3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[[f64; 2]; 3], D::Error> {
    let v: [[Option<f64>; 2]; 3] = serde::Deserialize::deserialize(d)?;
    Ok(v.map(|[lo, hi]| [lo.unwrap_or(f64::NEG_INFINITY), hi.unwrap_or(f64::INFINITY)]))
}

/// One method over K seeds (module docs). Serialized into a method's
/// report entry, whose own `relmse`, `mse` and `seeds` stand for the
/// fields skipped here.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SeedStats {
    #[serde(skip)]
    pub seeds: usize,
    /// Each seed's RelMSE.
    pub relmse_per_seed: Vec<f64>,
    /// Mean over seeds, and its 95% interval.
    #[serde(skip)]
    pub relmse: f64,
    pub relmse_ci95: [f64; 2],
    /// Per channel: the mean image's sum over the reference's, minus 1.
    pub relative_bias: [f64; 3],
    /// Per channel: 95% interval of the relative bias over seeds (each
    /// seed's image sum over the reference's, minus 1).
    pub relative_bias_ci95: [[f64; 2]; 3],
    /// Mean over seeds of the MSE, and its split.
    #[serde(skip)]
    pub mse: f64,
    pub mse_bias2: f64,
    pub mse_variance: f64,
    /// Mean over seeds of the MAE.
    #[serde(skip)]
    pub mae: f64,
    /// Pixels left out because some seed's value there is not finite.
    pub excluded_pixels: u64,
}

#[cfg(test)]
impl SeedStats {
    /// Seed statistics with these per-seed RelMSEs and the rest zero (unit
    /// tests of the ratio intervals).
    pub(crate) fn with_relmse(per_seed: &[f64]) -> SeedStats {
        let r = mean(per_seed);
        SeedStats {
            seeds: per_seed.len(),
            relmse_per_seed: per_seed.to_vec(),
            relmse: r,
            relmse_ci95: [r, r],
            relative_bias: [0.0; 3],
            relative_bias_ci95: [[0.0; 2]; 3],
            mse: 0.0,
            mse_bias2: 0.0,
            mse_variance: 0.0,
            mae: 0.0,
            excluded_pixels: 0,
        }
    }
}

impl SeedStats {
    /// The statistics of `images` (one per seed, each the reference's size).
    pub fn new(images: &[&[[f32; 3]]], reference: &[[f32; 3]]) -> Result<SeedStats> {
        if images.is_empty() {
            bail!("no images to take seed statistics of");
        }
        let k = images.len();
        let mut relmse_per_seed = Vec::with_capacity(k);
        let mut mae_sum = 0.0;
        for image in images {
            let e = metrics::compare(image, reference)?;
            relmse_per_seed.push(e.relmse);
            mae_sum += e.mae;
        }
        let n = reference.len();
        let finite = |p: usize| images.iter().all(|im| im[p].iter().all(|v| v.is_finite()));
        let (mut bias2, mut var, mut used) = (0.0f64, 0.0f64, 0u64);
        let mut ref_sum = [0.0f64; 3];
        let mut seed_sum = vec![[0.0f64; 3]; k];
        for p in 0..n {
            if !finite(p) {
                continue;
            }
            used += 1;
            for c in 0..3 {
                let r = reference[p][c] as f64;
                let mean = images.iter().map(|im| im[p][c] as f64).sum::<f64>() / k as f64;
                bias2 += (mean - r).powi(2);
                var += images
                    .iter()
                    .map(|im| (im[p][c] as f64 - mean).powi(2))
                    .sum::<f64>()
                    / k as f64;
                ref_sum[c] += r;
                for (s, im) in images.iter().enumerate() {
                    seed_sum[s][c] += im[p][c] as f64;
                }
            }
        }
        let denom = (3 * used).max(1) as f64;
        let (relmse, relmse_ci95) = mean_ci95(&relmse_per_seed);
        let mut relative_bias = [0.0; 3];
        let mut relative_bias_ci95 = [[0.0; 2]; 3];
        for c in 0..3 {
            let per_seed: Vec<f64> = seed_sum
                .iter()
                .map(|s| relative(s[c], ref_sum[c]))
                .collect();
            let (mean, ci) = mean_ci95(&per_seed);
            relative_bias[c] = mean;
            relative_bias_ci95[c] = ci;
        }
        Ok(SeedStats {
            seeds: k,
            relmse_per_seed,
            relmse,
            relmse_ci95,
            relative_bias,
            relative_bias_ci95,
            mse: (bias2 + var) / denom,
            mse_bias2: bias2 / denom,
            mse_variance: var / denom,
            mae: mae_sum / k as f64,
            excluded_pixels: n as u64 - used,
        })
    }
}

/// `sum / reference − 1`, 0 when both are 0.
fn relative(sum: f64, reference: f64) -> f64 {
    if reference == 0.0 {
        if sum == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    } else {
        sum / reference - 1.0
    }
}

/// splitmix64: the bootstrap's own deterministic random numbers.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform index below `n` (n ≥ 1).
    fn index(&mut self, n: usize) -> usize {
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64 * n as f64) as usize % n
    }

    /// A resample (with replacement) of `v`, into `out`.
    fn resample(&mut self, v: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend((0..v.len()).map(|_| v[self.index(v.len())]));
    }
}

/// The mean of `v`.
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Bootstrap replicates behind an interval of [`bootstrap_ci95`].
pub const BOOTSTRAP_REPLICATES: usize = 2000;

/// Percentile-bootstrap 95% interval of `statistic(resamples)`, where
/// `resamples[i]` resamples `groups[i]` with replacement, each group
/// independently (e.g. one method's per-seed RelMSEs, the other's, and the
/// timing rounds that set the equal-time target); the statistic reduces
/// each as the point estimate does (a mean, a minimum). Deterministic: a
/// fixed random stream.
pub fn bootstrap_ci95(groups: &[&[f64]], statistic: impl Fn(&[Vec<f64>]) -> f64) -> [f64; 2] {
    if groups.iter().any(|g| g.is_empty()) {
        return [f64::NAN, f64::NAN];
    }
    let mut rng = SplitMix(0x5EED_B007);
    let mut resamples = vec![Vec::new(); groups.len()];
    let mut values: Vec<f64> = (0..BOOTSTRAP_REPLICATES)
        .map(|_| {
            for (r, g) in resamples.iter_mut().zip(groups) {
                rng.resample(g, r);
            }
            statistic(&resamples)
        })
        .filter(|v| v.is_finite())
        .collect();
    if values.is_empty() {
        return [f64::NAN, f64::NAN];
    }
    values.sort_by(f64::total_cmp);
    // q ≤ 1 keeps the index at most len − 1.
    let at = |q: f64| values[(q * (values.len() - 1) as f64).round() as usize];
    [at(0.025), at(0.975)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One seed's interval, (−∞, +∞), is written as nulls and reads back
    /// as itself (issue 67, hostile inputs class 5).
    #[test]
    fn one_seed_intervals_read_back_as_written() {
        #[derive(Serialize, serde::Deserialize)]
        struct Row {
            #[serde(deserialize_with = "de_interval")]
            ci: [f64; 2],
            #[serde(deserialize_with = "de_intervals3")]
            ci3: [[f64; 2]; 3],
        }
        let (_, ci) = mean_ci95(&[0.5]);
        let row = Row {
            ci,
            ci3: [ci, [1.0, 2.0], ci],
        };
        let text = serde_json::to_string(&row).unwrap();
        assert_eq!(
            text,
            r#"{"ci":[null,null],"ci3":[[null,null],[1.0,2.0],[null,null]]}"#
        );
        let back: Row = serde_json::from_str(&text).unwrap();
        assert_eq!((back.ci, back.ci3), (row.ci, row.ci3));
        assert_eq!(serde_json::to_string(&back).unwrap(), text);
    }

    /// Deterministic normal deviates (Box–Muller on splitmix64).
    fn normals(seed: u64, n: usize) -> Vec<f64> {
        let mut rng = SplitMix(seed);
        let mut u = || ((rng.next() >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
        (0..n)
            .map(|_| (-2.0 * u().ln()).sqrt() * (std::f64::consts::TAU * u()).cos())
            .collect()
    }

    #[test]
    fn bias_and_variance_add_up_to_the_mean_mse() {
        let reference: Vec<[f32; 3]> = (0..50).map(|i| [i as f32 * 0.1, 1.0, 0.5]).collect();
        let noise = normals(3, 50 * 3 * 4);
        let images: Vec<Vec<[f32; 3]>> = (0..4)
            .map(|s| {
                reference
                    .iter()
                    .enumerate()
                    .map(|(p, r)| {
                        let e = |c: usize| 0.05 + 0.2 * noise[(s * 50 + p) * 3 + c] as f32;
                        [r[0] + e(0), r[1] + e(1), r[2] + e(2)]
                    })
                    .collect()
            })
            .collect();
        let views: Vec<&[[f32; 3]]> = images.iter().map(|v| v.as_slice()).collect();
        let s = SeedStats::new(&views, &reference).unwrap();
        let mean_mse = views
            .iter()
            .map(|im| metrics::compare(im, &reference).unwrap().mse)
            .sum::<f64>()
            / 4.0;
        assert!(
            (s.mse - mean_mse).abs() <= 1e-12 * mean_mse,
            "{} vs {mean_mse}",
            s.mse
        );
        assert!((s.mse_bias2 + s.mse_variance - s.mse).abs() <= 1e-15);
        // The constant offset 0.05 is bias: bias² ≥ 0.05² − noise of the mean.
        assert!(s.mse_bias2 > 0.0025 && s.mse_variance > 0.02, "{s:?}");
        assert_eq!(s.excluded_pixels, 0);
    }

    #[test]
    fn t_quantiles_and_mean_intervals_known_answers() {
        assert_eq!(t_quantile_95(0), f64::INFINITY);
        assert_eq!(t_quantile_95(1), 12.707);
        assert_eq!(t_quantile_95(2), 4.303);
        assert_eq!(t_quantile_95(30), 2.043);
        assert_eq!(t_quantile_95(31), 2.043);
        assert_eq!(t_quantile_95(1000), 2.043);
        // Mean 2, sample variance 1: half-width t(2)·√(1/3).
        let (m, [lo, hi]) = mean_ci95(&[1.0, 3.0, 2.0]);
        let half = 4.303 * (1.0f64 / 3.0).sqrt();
        assert_eq!(m, 2.0);
        assert!((lo - (2.0 - half)).abs() < 1e-12 && (hi - (2.0 + half)).abs() < 1e-12);
        assert_eq!(mean_ci95(&[5.0]), (5.0, [f64::NEG_INFINITY, f64::INFINITY]));
        assert_eq!(mean_ci95(&[]).1, [f64::NEG_INFINITY, f64::INFINITY]);
        assert_eq!(relative(3.0, 2.0), 0.5);
        assert_eq!(relative(0.0, 0.0), 0.0);
        assert_eq!(relative(1.0, 0.0), f64::INFINITY);
    }

    #[test]
    fn relative_bias_mae_and_relmse_intervals_known_answers() {
        // One pixel, reference (4, 4, 0); seeds (5, 6, 0) and (3, 7, 0).
        let reference = [[4.0f32, 4.0, 0.0]];
        let a = [[5.0f32, 6.0, 0.0]];
        let b = [[3.0f32, 7.0, 0.0]];
        let s = SeedStats::new(&[&a, &b], &reference).unwrap();
        assert_eq!(s.seeds, 2);
        // R: +¼ and −¼; G: +½ and +¾; B: 0 over 0.
        assert_eq!(s.relative_bias, [0.0, 0.625, 0.0]);
        // Half-width t(1)·√(s²/2): s² = 0.125 for R, 0.03125 for G.
        let half = [12.707 * 0.25, 12.707 * 0.125];
        for (c, h) in half.iter().enumerate() {
            let [lo, hi] = s.relative_bias_ci95[c];
            let m = s.relative_bias[c];
            assert!((lo - (m - h)).abs() < 1e-12, "{c}: {lo}");
            assert!((hi - (m + h)).abs() < 1e-12, "{c}: {hi}");
        }
        assert_eq!(s.relative_bias_ci95[2], [0.0, 0.0]);
        // MAE per seed (1 + 2 + 0)/3 and (1 + 3 + 0)/3.
        assert!((s.mae - 7.0 / 6.0).abs() < 1e-12, "{}", s.mae);
        let per_seed: Vec<f64> = [&a, &b]
            .iter()
            .map(|im| metrics::compare(&im[..], &reference).unwrap().relmse)
            .collect();
        assert_eq!(s.relmse_per_seed, per_seed);
        let (m, ci) = mean_ci95(&per_seed);
        assert_eq!((s.relmse, s.relmse_ci95), (m, ci));
        // Mean image (4, 6.5, 0): bias² (0 + 2.5² + 0)/3; spread ±1 and
        // ±½ about it: variance (1 + ¼ + 0)/3.
        assert!((s.mse_bias2 - 6.25 / 3.0).abs() < 1e-12);
        assert!((s.mse_variance - 1.25 / 3.0).abs() < 1e-12);
        assert!(SeedStats::new(&[], &reference).is_err());
    }

    #[test]
    fn non_finite_pixels_are_left_out_and_counted() {
        let reference = vec![[1.0f32; 3]; 4];
        let a = vec![[1.5f32; 3], [f32::NAN, 1.0, 1.0], [1.0; 3], [1.0; 3]];
        let b = vec![[0.5f32; 3], [1.0; 3], [1.0; 3], [1.0; 3]];
        let s = SeedStats::new(&[&a, &b], &reference).unwrap();
        assert_eq!(s.excluded_pixels, 1);
        // Pixel 0: mean 1 (no bias), spread ±0.5 → variance 0.25 over 3 of 9 terms.
        assert!((s.mse_variance - 0.25 / 3.0).abs() < 1e-12, "{s:?}");
        assert_eq!(s.mse_bias2, 0.0);
    }

    /// The Student-t interval of the mean covers the true mean in about
    /// 95% of repetitions: 1,000 repetitions of 3 normal values, coverage
    /// within 3 binomial standard deviations (√(0.95·0.05/1000) = 0.7%) of
    /// 95%.
    #[test]
    fn t_intervals_cover_the_mean_95_percent_of_the_time() {
        let x = normals(11, 3000);
        let covered = x
            .chunks(3)
            .filter(|v| {
                let (_, [lo, hi]) = mean_ci95(v);
                lo <= 0.0 && 0.0 <= hi
            })
            .count();
        assert!((929..=971).contains(&covered), "{covered} of 1000");
    }

    #[test]
    fn bootstrap_of_a_ratio_brackets_it_and_is_deterministic() {
        let a = [1.0, 1.2, 0.9, 1.1];
        let b = [2.0, 2.2, 1.8];
        let ratio = |m: &[Vec<f64>]| mean(&m[0]) / mean(&m[1]);
        let ci = bootstrap_ci95(&[&a, &b], ratio);
        let point = (4.2 / 4.0) / 2.0;
        assert!(ci[0] < point && point < ci[1], "{ci:?} vs {point}");
        assert_eq!(ci, bootstrap_ci95(&[&a, &b], ratio));
        assert!(bootstrap_ci95(&[&a, &[]], ratio)[0].is_nan());
        // The mean of 1..=10 (σ = √8.25): the percentile interval is close
        // to ±1.96·σ/√10 = ±1.78 about 5.5 (bootstrap standard error of
        // each end ≈ 0.1 at 2,000 replicates).
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        let [lo, hi] = bootstrap_ci95(&[&v], |m| mean(&m[0]));
        assert!(
            (3.4..=4.1).contains(&lo) && (6.9..=7.6).contains(&hi),
            "{lo} {hi}"
        );
        // Non-finite replicates are dropped, not ranked.
        let [lo, hi] = bootstrap_ci95(&[&[0.0, 1.0]], |m| 1.0 / mean(&m[0]));
        assert_eq!([lo, hi], [1.0, 2.0]);
        // The ends are the order statistics at round(q·(n − 1)) of the n
        // replicates: with the replicates 0, 1, …, 1999 (a counter, the
        // resamples ignored) those are round(49.975) = 50 and
        // round(1949.025) = 1949.
        let next = std::cell::Cell::new(0.0);
        let counter = |_: &[Vec<f64>]| {
            let v = next.get();
            next.set(v + 1.0);
            v
        };
        assert_eq!(bootstrap_ci95(&[&[1.0]], counter), [50.0, 1949.0]);
        assert_eq!(next.get(), BOOTSTRAP_REPLICATES as f64);
    }

    #[test]
    fn resampling_stream_is_splitmix64() {
        // splitmix64 (Steele, Lea & Flood 2014) from state 0: its published
        // first outputs.
        let mut rng = SplitMix(0);
        assert_eq!(rng.next(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(rng.next(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(rng.next(), 0x06C4_5D18_8009_454F);
        // Indices take the top 53 bits as a fraction of n: the bootstrap's
        // stream, 0x5EEDB007, below 1000 (computed independently from the
        // same recurrence in Python).
        let mut rng = SplitMix(0x5EED_B007);
        let idx: Vec<usize> = (0..4).map(|_| rng.index(1000)).collect();
        assert_eq!(idx, [447, 107, 675, 689]);
    }
}
