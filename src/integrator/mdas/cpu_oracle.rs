//! CPU port of one adaptive iteration (`error.wgsl`'s formula and
//! `adapt.wgsl`'s decisions and writes), operation for operation in the
//! same f32 arithmetic and the same hashes, so tests can check that the
//! GPU builds the same leaves and samples ([`step`]). The GPU's own errors
//! and E_max from the snapshot drive the decisions; [`leaf_error`]
//! recomputes them independently for comparison.

use super::debug::Snapshot;
use super::params::SplitRule;
use super::words::leaf::{self, COLLAPSED_BIT, DIRTY};

pub use crate::rng::{hash3, hash_u32};

/// `leaf_key` of `wgsl/mdas/common.wgsl`.
pub fn leaf_key(seed: u32, leaf: u32, iteration: u32) -> u32 {
    hash3(leaf, iteration, seed)
}

/// `draw` of `wgsl/mdas/common.wgsl`.
pub fn draw(key: u32, stream: u32) -> u32 {
    hash_u32(key.wrapping_add(stream.wrapping_mul(0x9e3779b9)))
}

fn draw_open(key: u32, stream: u32) -> f32 {
    ((draw(key, stream) >> 8) as f32 + 0.5) * (1.0 / 16777216.0)
}

/// Candidate c of a leaf (`candidate` in `adapt.wgsl`).
fn candidate(key: u32, c: u32, bounds: &[(u32, u32)]) -> Vec<u32> {
    let words = (bounds.len() as u32).div_ceil(2);
    bounds
        .iter()
        .enumerate()
        .map(|(a, &(lo, hi))| {
            let r = draw(key, 1 + c * words + a as u32 / 2);
            let r16 = if a % 2 == 1 { r >> 16 } else { r & 0xffff };
            lo + ((r16 * (hi - lo)) >> 16)
        })
        .collect()
}

fn ldexp(x: f32, e: i32) -> f32 {
    x * (e as f32).exp2()
}

fn axis_quantum(s: &Snapshot, axis: u32) -> f32 {
    let side = match axis {
        0 => s.params.scale_factor * s.film.width as f32,
        1 => s.params.scale_factor * s.film.height as f32,
        _ => 1.0,
    };
    ldexp(side, -((16 + s.axis_bits(axis)) as i32))
}

/// The contrast error of leaf k as `error.wgsl` computes it.
pub fn leaf_error(s: &Snapshot, k: u32) -> f32 {
    let leaf = s.leaf(k);
    let list = s.leaf_samples(k);
    let finite: Vec<[f32; 3]> = list
        .iter()
        .map(|&i| s.value(i))
        .filter(|v| v.iter().all(|c| c.is_finite()))
        .collect();
    let mut contrast = 0.0f32;
    if !finite.is_empty() {
        let inv_n = 1.0 / finite.len() as f32;
        let mut mean = [0.0f32; 3];
        for v in &finite {
            for c in 0..3 {
                mean[c] += v[c] * inv_n;
            }
        }
        let mut dev = [0.0f32; 3];
        for v in &finite {
            for c in 0..3 {
                dev[c] += (v[c] - mean[c]).abs() * inv_n;
            }
        }
        for c in 0..3 {
            let a = mean[c].abs();
            if dev[c] > 0.0 {
                contrast += if dev[c] >= 2.0 * a { 2.0 } else { dev[c] / a };
            }
        }
        contrast *= 1.0 / 3.0;
    }
    let mut volume = 1.0f32;
    for axis in 0..s.dims {
        let (lo, hi) = leaf.bounds[axis as usize];
        volume *= ldexp((hi - lo) as f32, -((16 + s.axis_bits(axis)) as i32));
    }
    let e = volume * (s.epsilon + contrast);
    if e.is_finite() {
        e
    } else {
        volume * (s.epsilon + 2.0)
    }
}

/// A leaf's decision in one iteration (`decide` in `adapt.wgsl`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Decision {
    pub selected: bool,
    pub split: bool,
    pub collapse: bool,
    pub axis: u32,
    pub plane: u32,
    pub cand: Vec<u32>,
}

pub fn decide(s: &Snapshot, k: u32) -> Decision {
    let mut d = Decision::default();
    let leaf = s.leaf(k);
    if leaf.collapsed {
        return d;
    }
    let (seed, it) = (s.params.seed, s.iteration);
    let mut selected = leaf.error_bits == s.emax_bits || s.select_all;
    if !selected {
        let xi = draw_open(leaf_key(seed, k, it), 0);
        selected = f32::from_bits(leaf.error_bits)
            >= f32::from_bits(s.emax_bits) * (xi * s.inv_pace).powf(s.inv_alpha);
    }
    if !selected {
        return d;
    }
    let dims = s.dims;
    let quantum: Vec<f32> = (0..dims).map(|a| axis_quantum(s, a)).collect();
    let list = s.leaf_samples(k);
    let mut best = -1.0f32;
    for c in 0..s.params.candidates {
        let q = candidate(leaf_key(seed, k, it), c, &leaf.bounds);
        let mut nearest = 3.0e38f32;
        for &i in &list {
            let mut dist = 0.0f32;
            for a in 0..dims {
                let t = (q[a as usize] as f32 - s.sample_q(i, a) as f32) * quantum[a as usize];
                dist += t * t;
            }
            nearest = nearest.min(dist);
        }
        if nearest > best {
            best = nearest;
            d.cand = q;
        }
    }
    if leaf.count >= s.params.max_samples_per_leaf {
        let n = leaf.count as usize + 1;
        let half = n / 2;
        let mut best_extent = -1.0f32;
        let mut best_contrast = -1.0f32;
        for a in 0..dims {
            let mut v: Vec<u32> = list.iter().map(|&i| s.sample_q(i, a)).collect();
            v.push(d.cand[a as usize]);
            v.sort_unstable();
            if v[half - 1] < v[half] {
                let (lo, hi) = leaf.bounds[a as usize];
                let extent = (hi - lo) as f32 * quantum[a as usize];
                let plane = (v[half - 1] + v[half]).div_ceil(2);
                let contrast = match s.params.split {
                    SplitRule::Extent => 0.0,
                    SplitRule::Contrast => side_contrast(s, &list, None, a, plane),
                    SplitRule::Trimmed => side_contrast(s, &list, outlier(s, &list), a, plane),
                };
                if contrast > best_contrast || (contrast == best_contrast && extent > best_extent) {
                    best_contrast = contrast;
                    best_extent = extent;
                    d.axis = a;
                    d.plane = plane;
                }
            }
        }
        if best_extent < 0.0 {
            d.collapse = true;
            return d;
        }
        d.split = true;
    }
    d.selected = true;
    d
}

/// The sample the trimmed split rule leaves out, as `adapt.wgsl` picks it:
/// among the finite samples (at least three), the first whose channel sum
/// lies farthest from their mean (sample 0 of `list` when every distance
/// is NaN, as the kernel's strict comparison leaves it).
fn outlier(s: &Snapshot, list: &[u32]) -> Option<usize> {
    let sums: Vec<Option<f32>> = list
        .iter()
        .map(|&i| {
            let v = s.value(i);
            v.iter().all(|c| c.is_finite()).then(|| v[0] + v[1] + v[2])
        })
        .collect();
    let n = sums.iter().flatten().count();
    if n < 3 {
        return None;
    }
    let mean = sums.iter().flatten().fold(0.0f32, |a, &v| a + v) / n as f32;
    let (mut worst, mut j) = (-1.0f32, 0);
    for (i, v) in sums.iter().enumerate() {
        if let Some(v) = v {
            let d = (v - mean).abs();
            if d > worst {
                worst = d;
                j = i;
            }
        }
    }
    Some(j)
}

/// |mean below `plane` − mean above| along `axis` of the finite samples'
/// channel sums, but for `list[skip]` (0 when a side has none), as
/// `adapt.wgsl` computes it.
fn side_contrast(s: &Snapshot, list: &[u32], skip: Option<usize>, axis: u32, plane: u32) -> f32 {
    let (mut sum, mut n) = ([0.0f32; 2], [0u32; 2]);
    for (k, &i) in list.iter().enumerate() {
        let v = s.value(i);
        if v.iter().all(|c| c.is_finite()) && Some(k) != skip {
            let side = (s.sample_q(i, axis) >= plane) as usize;
            sum[side] += v[0] + v[1] + v[2];
            n[side] += 1;
        }
    }
    if n[0] > 0 && n[1] > 0 {
        (sum[0] / n[0] as f32 - sum[1] / n[1] as f32).abs()
    } else {
        0.0
    }
}

/// The predicted state after one iteration: raw leaf words (slots
/// included) and sample coordinate words (values of new samples are not
/// predicted).
#[derive(Clone, Debug)]
pub struct Predicted {
    pub leaf_count: u32,
    pub sample_count: u32,
    pub leaves: Vec<u32>,
    pub samples: Vec<u32>,
    pub decisions: Vec<Decision>,
}

fn floor_mul_div(a: u32, b: u32, c: u32) -> u32 {
    (a as u64 * b as u64 / c as u64) as u32
}

/// One iteration from `before` (taken after the error pass).
pub fn step(before: &Snapshot) -> Predicted {
    let ls = before.leaf_stride();
    let ss = before.sample_stride();
    let decisions: Vec<Decision> = (0..before.leaf_count).map(|k| decide(before, k)).collect();
    let selected_total = decisions.iter().filter(|d| d.selected).count() as u32;
    let n = before.sample_count;
    let left = before.budget - n;
    let truncate = selected_total > left;
    let mut leaves = before.leaves.clone();
    let mut samples = before.samples.clone();
    let added = selected_total.min(left);
    samples.resize((n + added) as usize * ss, 0);
    let mut leaf_count = before.leaf_count;
    let mut rank = 0u32;
    let q_of = |samples: &Vec<u32>, s: u32, a: u32| {
        (samples[s as usize * ss + a as usize / 2] >> (16 * (a % 2))) & 0xffff
    };
    // The samples of the leaf record at `base`: slot 0 in the header, the
    // rest after the box (slots past the count keep stale words, as in the
    // kernel).
    let set_slots = |leaves: &mut Vec<u32>, base: usize, list: &[u32]| {
        leaves[base + 1] = leaf::header(list[0], list.len() as u32);
        for (i, &s) in list.iter().enumerate().skip(1) {
            leaves[base + before.slot_word(i)] = s;
        }
    };
    for (k, d) in decisions.iter().enumerate() {
        let base = k * ls;
        let h = leaves[base + 1];
        if d.collapse {
            leaves[base + 1] = h | COLLAPSED_BIT;
        }
        if !d.selected {
            continue;
        }
        let r = rank;
        rank += 1;
        // The decision was parked in the error word: recomputed next pass.
        leaves[base + 2] = DIRTY;
        let slot = if truncate {
            let (b, a) = (
                floor_mul_div(r, left, selected_total),
                floor_mul_div(r + 1, left, selected_total),
            );
            if a == b {
                continue;
            }
            n + a - 1
        } else {
            n + r
        };
        let mut words = vec![0u32; ss];
        for a in 0..before.dims {
            words[a as usize / 2] |= d.cand[a as usize] << (16 * (a % 2));
        }
        samples[slot as usize * ss..][..ss].copy_from_slice(&words);
        // The leaf's samples in slot order, then the new one.
        let mut order = before.leaf_samples(k as u32);
        order.push(slot);
        if !d.split || truncate {
            set_slots(&mut leaves, base, &order);
            continue;
        }
        // Split exactly as the kernel does: each side keeps the order.
        let (right_list, left_list): (Vec<u32>, Vec<u32>) = order
            .iter()
            .partition(|&&s| q_of(&samples, s, d.axis) >= d.plane);
        let right = leaf_count as usize;
        leaf_count += 1;
        leaves.resize(leaf_count as usize * ls, 0);
        let word = leaves[base + 3 + d.axis as usize];
        for a in 0..before.dims as usize {
            leaves[right * ls + 3 + a] = leaves[base + 3 + a];
        }
        let (lo, hi) = (word & 0xffff, (word >> 16) + 1);
        leaves[base + 3 + d.axis as usize] = lo | ((d.plane - 1) << 16);
        leaves[right * ls + 3 + d.axis as usize] = d.plane | ((hi - 1) << 16);
        set_slots(&mut leaves, base, &left_list);
        leaves[right * ls] = leaves[base];
        set_slots(&mut leaves, right * ls, &right_list);
        leaves[right * ls + 2] = DIRTY;
    }
    Predicted {
        leaf_count,
        sample_count: n + added,
        leaves,
        samples,
        decisions,
    }
}
