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
                            if self.params.reconstruction == Reconstruction::Sampled {
                                weight *= super::config::UNSAMPLED_WEIGHT as f64;
                            }
                        } else {
                            let n = own.len() as f64;
                            value = std::array::from_fn(|c| {
                                (own.iter().map(|v| v[c] as f64).sum::<f64>() + kappa * mean[c])
                                    / (n + kappa)
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
