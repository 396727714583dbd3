//! Power sampling: lights chosen with probability `I_i / Σ I` through a
//! Vose alias table (one random number, O(1); pbrt-v4's `PowerLightSampler`
//! with the scalar intensity of `src/lights/mod.rs` in place of power).
//!
//! Table: `q_i` and `alias_i` per light. With `t = u·N` (f32),
//! `i = min(floor(t), N − 1)` and `v = t − i`: light `i` if `v < q_i`, else
//! `alias_i`. The probabilities are computed in f64 and stored as f32.
//! Zero-intensity lights have `q = 0` and are nobody's alias, so they are
//! never chosen; entries with `q = 1` alias themselves, so a `v` that
//! rounds up to 1 still picks them.

use crate::lights::sampler::{LightSample, LightSampler};
use crate::lights::{importance::Shading, LightPrim};
use bytemuck::{Pod, Zeroable};

/// One alias-table entry (8 bytes, uploaded as is).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AliasEntry {
    /// Probability of keeping this entry's own light.
    pub q: f32,
    /// The light taken otherwise.
    pub alias: u32,
}

/// Power sampler over `N` lights.
#[derive(Clone, Debug, PartialEq)]
pub struct PowerSampler {
    /// Empty when `Σ I = 0` (no light can be sampled).
    pub table: Vec<AliasEntry>,
    /// `I_i / Σ I` per light (f32; zeros when `Σ I = 0`).
    pub pmf: Vec<f32>,
}

impl PowerSampler {
    pub fn new(prims: &[LightPrim]) -> Self {
        Self::from_weights(&prims.iter().map(|p| p.intensity()).collect::<Vec<_>>())
    }

    /// The alias table of non-negative weights (Vose's method in f64).
    pub fn from_weights(weights: &[f32]) -> Self {
        let n = weights.len();
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        if n == 0 || total <= 0.0 {
            return PowerSampler {
                table: Vec::new(),
                pmf: vec![0.0; n],
            };
        }
        let pmf64: Vec<f64> = weights.iter().map(|&w| w as f64 / total).collect();
        let mut scaled: Vec<f64> = pmf64.iter().map(|p| p * n as f64).collect();
        let mut table = vec![AliasEntry::default(); n];
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        while !small.is_empty() && !large.is_empty() {
            let (s, l) = (small.pop().unwrap(), *large.last().unwrap());
            table[s] = AliasEntry {
                q: scaled[s] as f32,
                alias: l as u32,
            };
            scaled[l] = (scaled[l] + scaled[s]) - 1.0;
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // Leftovers have scaled ≈ 1 up to rounding: keep themselves, except
        // zero-weight lights, which must stay unreachable.
        let any_live = weights.iter().position(|&w| w > 0.0).unwrap() as u32;
        for i in small.into_iter().chain(large) {
            table[i] = if weights[i] > 0.0 {
                AliasEntry {
                    q: 1.0,
                    alias: i as u32,
                }
            } else {
                AliasEntry {
                    q: 0.0,
                    alias: any_live,
                }
            };
        }
        PowerSampler {
            table,
            pmf: pmf64.iter().map(|&p| p as f32).collect(),
        }
    }
}

impl LightSampler for PowerSampler {
    fn sample(&self, _s: &Shading, u: f32) -> Option<LightSample> {
        let n = self.table.len() as u32;
        if n == 0 {
            return None;
        }
        let t = u * n as f32;
        let i = (t.floor() as u32).min(n - 1);
        let v = t - i as f32;
        let e = self.table[i as usize];
        let light = if v < e.q { i } else { e.alias };
        Some(LightSample {
            light,
            pmf: self.pmf[light as usize] as f64,
        })
    }

    fn pmf(&self, _s: &Shading, light: u32) -> f64 {
        self.pmf.get(light as usize).map_or(0.0, |&p| p as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact probability the table gives each light, in f64.
    fn table_probabilities(t: &PowerSampler) -> Vec<f64> {
        let n = t.table.len();
        let mut p = vec![0.0; n];
        for (i, e) in t.table.iter().enumerate() {
            p[i] += e.q as f64 / n as f64;
            p[e.alias as usize] += (1.0 - e.q as f64) / n as f64;
        }
        p
    }

    #[test]
    fn table_reproduces_the_weights() {
        let w = [0.0, 1.0, 3.0, 0.0, 0.5, 2.5, 1e-7];
        let t = PowerSampler::from_weights(&w);
        let total: f64 = w.iter().map(|&x| x as f64).sum();
        for (p, &x) in table_probabilities(&t).iter().zip(&w) {
            assert!((p - x as f64 / total).abs() < 1e-7, "{p} vs {x}");
        }
        for (i, e) in t.table.iter().enumerate() {
            assert!(w[e.alias as usize] > 0.0 || e.q == 1.0 && e.alias == i as u32);
        }
        assert!(PowerSampler::from_weights(&[0.0, 0.0]).table.is_empty());
    }
}
