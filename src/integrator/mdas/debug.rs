//! Read-back state of a render, for invariant and oracle tests
//! ([`super::Mdas::render_observed`]). Decodes the storage layout of
//! `wgsl/mdas/common.wgsl`.

use super::{MdasParams, Reconstruction};
use crate::film::Film;

use super::words::leaf::{self, COLLAPSED_BIT};
pub use super::words::leaf::{DIRTY, INDEX_MASK};

/// The state after an error pass (errors current, `emax_bits` set), or
/// after the last iteration (`is_final`: errors of changed leaves DIRTY).
#[derive(Clone, Debug)]
pub struct Snapshot {
    pub iteration: u32,
    pub is_final: bool,
    pub params: MdasParams,
    pub dims: u32,
    pub film: Film,
    pub budget: u32,
    pub leaf_count: u32,
    pub sample_count: u32,
    pub emax_bits: u32,
    pub inv_alpha: f32,
    /// 1/c of the paced selection in this iteration (1: the paper's rule).
    pub inv_pace: f32,
    pub select_all: bool,
    pub epsilon: f32,
    /// Raw words: `leaf_count × (3 + dims + m − 1)`: cell, header, error
    /// (slot m after a trimmed last iteration), the box, slots 1 … m − 1.
    pub leaves: Vec<u32>,
    /// Raw coordinate words: `sample_count × ⌈dims/2⌉`.
    pub samples: Vec<u32>,
    /// Per sample: 3 f32 bits.
    pub values: Vec<u32>,
}

/// One decoded leaf.
#[derive(Clone, Debug, PartialEq)]
pub struct Leaf {
    pub cell: u32,
    /// The leaf's sample indices in slot order (`count` of them).
    pub samples: Vec<u32>,
    pub count: u32,
    pub collapsed: bool,
    /// The error word: error bits, DIRTY, or, in a leaf of m + 1 samples
    /// after a trimmed last iteration, the index of its sample m.
    pub error_bits: u32,
    /// Per axis: [lo, hi) in quanta of the cell (0..=65536).
    pub bounds: Vec<(u32, u32)>,
}

impl Snapshot {
    pub fn leaf_stride(&self) -> usize {
        2 + self.dims as usize + self.params.max_samples_per_leaf as usize
    }

    /// Word of slot i ≥ 1 in a leaf record (slot 0 is in the header's
    /// low bits, slot m in the error word).
    pub fn slot_word(&self, i: usize) -> usize {
        if i == self.params.max_samples_per_leaf as usize {
            2
        } else {
            2 + self.dims as usize + i
        }
    }

    pub fn sample_stride(&self) -> usize {
        self.dims.div_ceil(2) as usize
    }

    pub fn leaf(&self, k: u32) -> Leaf {
        let w = &self.leaves[k as usize * self.leaf_stride()..][..self.leaf_stride()];
        let count = leaf::count(w[1]);
        Leaf {
            cell: w[0],
            samples: (0..count as usize)
                .map(|i| match i {
                    0 => w[1] & INDEX_MASK,
                    _ => w[self.slot_word(i)],
                })
                .collect(),
            count,
            collapsed: w[1] & COLLAPSED_BIT != 0,
            error_bits: w[2],
            bounds: (0..self.dims as usize)
                .map(|a| (w[3 + a] & 0xffff, (w[3 + a] >> 16) + 1))
                .collect(),
        }
    }

    pub fn sample_q(&self, s: u32, axis: u32) -> u32 {
        let w = self.samples[s as usize * self.sample_stride() + axis as usize / 2];
        (w >> (16 * (axis % 2))) & 0xffff
    }

    pub fn value(&self, s: u32) -> [f32; 3] {
        std::array::from_fn(|c| f32::from_bits(self.values[3 * s as usize + c]))
    }

    /// The samples of leaf k, in slot order.
    pub fn leaf_samples(&self, k: u32) -> Vec<u32> {
        self.leaf(k).samples
    }

    /// Cell-coordinate bits along `axis`.
    pub fn axis_bits(&self, axis: u32) -> u32 {
        self.params.bits_per_dim
            + if axis < 2 {
                self.params.extra_image_bits
            } else {
                0
            }
    }

    pub fn cell_coords(&self, cell: u32) -> Vec<u32> {
        super::morton::morton_decode(
            cell,
            self.dims,
            self.params.bits_per_dim,
            self.params.extra_image_bits,
        )
    }

    /// Leaf k's box in the normalized domain [0, 1]^d (exact in f64).
    pub fn leaf_box(&self, k: u32) -> Vec<(f64, f64)> {
        let leaf = self.leaf(k);
        let cell = self.cell_coords(leaf.cell);
        (0..self.dims)
            .map(|a| {
                let scale = (-((16 + self.axis_bits(a)) as f64)).exp2();
                let (lo, hi) = leaf.bounds[a as usize];
                let origin = cell[a as usize] as f64 * 65536.0;
                ((origin + lo as f64) * scale, (origin + hi as f64) * scale)
            })
            .collect()
    }

    /// Normalized volume of leaf k.
    pub fn leaf_volume(&self, k: u32) -> f64 {
        self.leaf_box(k).iter().map(|(lo, hi)| hi - lo).product()
    }

    /// Sample s's point in the normalized domain (its quantum's centre),
    /// given its leaf's cell.
    pub fn sample_point(&self, s: u32, cell: u32) -> Vec<f64> {
        let c = self.cell_coords(cell);
        (0..self.dims)
            .map(|a| {
                let scale = (-((16 + self.axis_bits(a)) as f64)).exp2();
                (c[a as usize] as f64 * 65536.0 + self.sample_q(s, a) as f64 + 0.5) * scale
            })
            .collect()
    }

    /// Samples per pixel (row-major, `film.width × film.height`): each
    /// leaf's samples spread over the pixels its film projection overlaps,
    /// in proportion to the overlap area — the density the reconstruction
    /// (eq. 7) sees, as in the paper's sample-density figures. Sums to the
    /// samples held by the leaves.
    pub fn sample_density(&self) -> Vec<f32> {
        let (w, h) = (self.film.width as usize, self.film.height as usize);
        let mut density = vec![0.0f64; w * h];
        for k in 0..self.leaf_count {
            let count = self.leaf(k).count;
            if count == 0 {
                continue;
            }
            let b = self.leaf_box(k);
            let (x0, x1) = (b[0].0 * w as f64, b[0].1 * w as f64);
            let (y0, y1) = (b[1].0 * h as f64, b[1].1 * h as f64);
            let per_area = count as f64 / ((x1 - x0) * (y1 - y0));
            for j in (y0.floor() as usize)..(y1.ceil() as usize).min(h) {
                let oy = (y1.min(j as f64 + 1.0) - y0.max(j as f64)).max(0.0);
                for i in (x0.floor() as usize)..(x1.ceil() as usize).min(w) {
                    let ox = (x1.min(i as f64 + 1.0) - x0.max(i as f64)).max(0.0);
                    density[j * w + i] += per_area * ox * oy;
                }
            }
        }
        density.into_iter().map(|d| d as f32).collect()
    }

    /// Raster coordinate of sample s along film axis 0 or 1, in the
    /// f32 arithmetic of `sample_raster` (`wgsl/mdas/common.wgsl`), so
    /// that the pixel it falls in is the kernels' own.
    pub fn sample_raster(&self, s: u32, cell: u32, axis: u32) -> f32 {
        let c = self.cell_coords(cell)[axis as usize];
        let q = self.sample_q(s, axis);
        // 2^−(16 + bits), exactly (bits ≤ 32, a normal f32).
        let scale = f32::from_bits((127 - 16 - self.axis_bits(axis)) << 23);
        let x = ((c as f32 * 65536.0 + (q as f32 + 0.5)) * scale).min(1.0 - f32::EPSILON / 2.0);
        let size = if axis == 0 {
            self.film.width
        } else {
            self.film.height
        } as f32;
        (x * size).min(f32::from_bits(size.to_bits() - 1))
    }

    /// The image the reconstruction kernel (`wgsl/mdas/reconstruct.wgsl`)
    /// makes from these leaves, in f64: for each leaf with finite samples
    /// and each pixel its film box overlaps, the overlap area × the
    /// non-film volume times the leaf's value for that pixel — its mean
    /// f̄ (`Box`), or (Σ_{s in p} f_s + κ·f̄)/(n_p + κ) over its finite
    /// samples in the pixel (`Pixel` and `Sampled`; where there are none,
    /// f̄, with the weight scaled by [`super::config::UNSAMPLED_WEIGHT`]
    /// under `Sampled`) — divided
    /// by the pixel's weight sum; NaN where no leaf has a finite sample.
    pub fn reconstruct(&self) -> Vec<[f64; 3]> {
        let (w, h) = (self.film.width as usize, self.film.height as usize);
        let mut sums = vec![[0.0f64; 4]; w * h];
        let kappa = self.params.pixel_prior as f64;
        for k in 0..self.leaf_count {
            let Some(mean) = self.leaf_mean(k) else {
                continue;
            };
            let cell = self.leaf(k).cell;
            let finite: Vec<(usize, [f32; 3])> = self
                .leaf_samples(k)
                .into_iter()
                .map(|s| {
                    let i = self.sample_raster(s, cell, 0) as usize;
                    let j = self.sample_raster(s, cell, 1) as usize;
                    (j * w + i, self.value(s))
                })
                .filter(|(_, v)| v.iter().all(|c| c.is_finite()))
                .collect();
            let leaf_kappa = (self.params.reconstruction == Reconstruction::Shrinkage)
                .then(|| shrinkage_kappa(&finite));
            let b = self.leaf_box(k);
            let nonfilm: f64 = b[2..].iter().map(|(lo, hi)| hi - lo).product();
            let (x0, x1) = (b[0].0 * w as f64, b[0].1 * w as f64);
            let (y0, y1) = (b[1].0 * h as f64, b[1].1 * h as f64);
            for j in (y0.floor() as usize)..(y1.ceil() as usize).min(h) {
                let oy = y1.min(j as f64 + 1.0) - y0.max(j as f64);
                for i in (x0.floor() as usize)..(x1.ceil() as usize).min(w) {
                    let ox = x1.min(i as f64 + 1.0) - x0.max(i as f64);
                    if ox <= 0.0 || oy <= 0.0 {
                        continue;
                    }
                    let mut weight = ox * oy * nonfilm;
                    let mut value = mean;
                    if self.params.reconstruction != Reconstruction::Box {
                        let own: Vec<&[f32; 3]> = finite
                            .iter()
                            .filter(|(p, _)| *p == j * w + i)
                            .map(|(_, v)| v)
                            .collect();
                        if own.is_empty() {
                            if self.params.reconstruction.skips_unsampled() {
                                weight *= super::config::UNSAMPLED_WEIGHT as f64;
                            }
                        } else {
                            let n = own.len() as f64;
                            let kappa = leaf_kappa.unwrap_or(kappa);
                            value = std::array::from_fn(|c| {
                                let sum = own.iter().map(|v| v[c] as f64).sum::<f64>();
                                let shrunk = (sum + kappa * mean[c]) / (n + kappa);
                                if leaf_kappa.is_some() {
                                    let ratio = super::config::SHRINK_RATIO as f64;
                                    let (a, b) = (sum / n * ratio, sum / n / ratio);
                                    shrunk.clamp(a.min(b), a.max(b))
                                } else {
                                    shrunk
                                }
                            });
                        }
                    }
                    let sum = &mut sums[j * w + i];
                    for c in 0..3 {
                        sum[c] += weight * value[c];
                    }
                    sum[3] += weight;
                }
            }
        }
        sums.into_iter()
            .map(|s| {
                if s[3] > 0.0 {
                    [s[0] / s[3], s[1] / s[3], s[2] / s[3]]
                } else {
                    [f64::NAN; 3]
                }
            })
            .collect()
    }

    /// Mean of the finite values of leaf k (None without any).
    pub fn leaf_mean(&self, k: u32) -> Option<[f64; 3]> {
        let finite: Vec<[f32; 3]> = self
            .leaf_samples(k)
            .iter()
            .map(|&s| self.value(s))
            .filter(|v| v.iter().all(|c| c.is_finite()))
            .collect();
        if finite.is_empty() {
            return None;
        }
        let n = finite.len() as f64;
        Some(std::array::from_fn(|c| {
            finite.iter().map(|v| v[c] as f64).sum::<f64>() / n
        }))
    }
}

/// The κ of [`Reconstruction::Shrinkage`] for a leaf's finite samples
/// (pixel, value), as `leaf_kappa` in `wgsl/mdas/reconstruct.wgsl`: σ²/τ²
/// from a one-way analysis of variance of the channel sums (scaled by
/// their largest magnitude) grouped by pixel; `SHRINK_KAPPA_MAX` where
/// τ² ≤ 0 (or every value is 0), 0 where it cannot be estimated (one
/// pixel, or one sample per pixel).
pub fn shrinkage_kappa(samples: &[(usize, [f32; 3])]) -> f64 {
    let max = super::config::SHRINK_KAPPA_MAX as f64;
    let sums: Vec<f64> = samples
        .iter()
        .map(|(_, v)| v.iter().map(|&c| c as f64).sum())
        .collect();
    let big = sums.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if big == 0.0 {
        return max;
    }
    let v: Vec<f64> = sums.iter().map(|s| s / big).collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let mut pixels: Vec<usize> = samples.iter().map(|(p, _)| *p).collect();
    pixels.sort_unstable();
    pixels.dedup();
    let (mut within, mut between, mut sum_n2) = (0.0, 0.0, 0.0);
    for &p in &pixels {
        let group: Vec<f64> = samples
            .iter()
            .zip(&v)
            .filter(|((q, _), _)| *q == p)
            .map(|(_, &x)| x)
            .collect();
        let count = group.len() as f64;
        let group_mean = group.iter().sum::<f64>() / count;
        within += group.iter().map(|x| (x - group_mean).powi(2)).sum::<f64>();
        between += count * (group_mean - mean).powi(2);
        sum_n2 += count * count;
    }
    let groups = pixels.len() as f64;
    if pixels.len() < 2 || n <= groups {
        return 0.0;
    }
    let sigma2 = within / (n - groups);
    let n0 = (n - sum_n2 / n) / (groups - 1.0);
    let tau2 = (between / (groups - 1.0) - sigma2) / n0;
    if tau2 <= 0.0 {
        max
    } else {
        (sigma2 / tau2).min(max)
    }
}

#[cfg(test)]
mod tests {
    use super::shrinkage_kappa;
    use crate::integrator::mdas::config::SHRINK_KAPPA_MAX;

    fn samples(groups: &[(usize, &[f32])]) -> Vec<(usize, [f32; 3])> {
        groups
            .iter()
            .flat_map(|&(p, vs)| vs.iter().map(move |&v| (p, [v, 0.0, 0.0])))
            .collect()
    }

    /// κ = σ²/τ² by hand: pixel 0 reads {1, 3}, pixel 1 {5, 7} (scaled by
    /// 1/7): σ² = 4/49/2, n₀ = 2, τ² = (16/49 − 2/49)/2 = 7/49, κ = 2/7.
    #[test]
    fn shrinkage_kappa_is_the_anova_ratio() {
        let k = shrinkage_kappa(&samples(&[(0, &[1.0, 3.0]), (1, &[5.0, 7.0])]));
        assert!((k - 2.0 / 7.0).abs() < 1e-12, "{k}");
    }

    /// A lamp's edge (pixels that differ, each constant) keeps each
    /// pixel's own samples; pixels no more different than their noise
    /// share the leaf mean; one pixel, one sample per pixel and all zeros
    /// are the documented edge cases.
    #[test]
    fn shrinkage_kappa_limits() {
        let max = SHRINK_KAPPA_MAX as f64;
        assert_eq!(
            shrinkage_kappa(&samples(&[(0, &[60.0, 60.0]), (1, &[0.0, 0.0])])),
            0.0
        );
        assert_eq!(
            shrinkage_kappa(&samples(&[(0, &[1.0, 3.0]), (1, &[3.0, 1.0])])),
            max
        );
        assert_eq!(shrinkage_kappa(&samples(&[(0, &[1.0, 3.0, 9.0])])), 0.0);
        assert_eq!(
            shrinkage_kappa(&samples(&[(0, &[1.0]), (1, &[3.0]), (2, &[5.0])])),
            0.0
        );
        assert_eq!(
            shrinkage_kappa(&samples(&[(0, &[0.0, 0.0]), (1, &[0.0])])),
            max
        );
    }
}
