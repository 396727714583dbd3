//! MDAS structure after every iteration: the leaves tile the domain, every
//! sample sits in exactly one leaf and inside its box, counts stay within
//! bounds, E_max bounds every error; a CPU port of one iteration
//! (`cpu_oracle`) builds exactly the GPU's leaves and samples; the image
//! conserves energy (Σ pixel × area = Σ leaves V·f̄).

mod common;
mod mdas_support;

use mdas::film::Film;
use mdas::integrator::mdas::cpu_oracle;
use mdas::integrator::mdas::debug::{Snapshot, DIRTY};
use mdas::integrator::mdas::{MdasParams, SplitRule};
use mdas_support::*;
use rand::{RngExt, SeedableRng};

/// Small problems covering d = 3, 4 and 8, l = 1 and 2, several integrands.
fn cases() -> Vec<(&'static str, u32, u32, Film, MdasParams)> {
    let mut v = vec![
        (
            "edge 3D",
            3,
            3,
            Film {
                width: 12,
                height: 8,
            },
            params(1, 2, 1, 10.0, 7),
        ),
        (
            "linear 4D l=2",
            0,
            4,
            Film {
                width: 6,
                height: 5,
            },
            params(1, 1, 2, 24.0, 3),
        ),
        (
            "slab 8D",
            4,
            8,
            Film {
                width: 4,
                height: 3,
            },
            params(0, 1, 1, 40.0, 5),
        ),
        (
            "nan 3D",
            1,
            3,
            Film {
                width: 5,
                height: 4,
            },
            params(1, 1, 1, 12.0, 9),
        ),
    ];
    let mut wide = params(1, 1, 3, 30.0, 11);
    wide.max_samples_per_leaf = 5;
    wide.alpha = 1.0;
    wide.scale_factor = 0.25;
    wide.candidates = 7;
    // Deep refinement at the slab's two edges (one cell, m = 8, α = 64,
    // ε = 10⁻²⁰, 600 samples): the straddling leaves split along u0 down
    // to boxes one quantum wide, where a median plane falls on a sample's
    // own quantum (which belongs to the right half). With m = 2 the
    // contrast rule ties on every axis and the boxes stayed ~400 quanta
    // wide.
    let mut deep = params(0, 0, 2, 600.0, 13);
    deep.max_samples_per_leaf = 8;
    deep.alpha = 64.0;
    deep.epsilon = 1e-20;
    deep.split = SplitRule::Contrast;
    v.push((
        "deep 3D",
        4,
        3,
        Film {
            width: 1,
            height: 1,
        },
        deep,
    ));
    v.push((
        "m=5 sf=1/4 α=1",
        3,
        4,
        Film {
            width: 7,
            height: 3,
        },
        wide,
    ));
    // The paced selection at a large α (few leaves would pass the paper's
    // rule per iteration; c raises them), on the edge (plan.wgsl).
    let mut paced = params(1, 2, 1, 10.0, 17);
    paced.alpha = 16.0;
    paced.pace = 0.25;
    v.push((
        "edge 3D paced α=16",
        3,
        3,
        Film {
            width: 12,
            height: 8,
        },
        paced,
    ));
    // The defaults of a scene without an [mdas] table: an automatic grid
    // (cells of one pixel, l = 5, m raised to 6), α = 1, the sampled
    // reconstruction; snapshots must read the resolved m.
    let film = Film {
        width: 12,
        height: 8,
    };
    v.push((
        "edge 3D defaults",
        3,
        3,
        film,
        MdasParams {
            spp: 8.0,
            seed: 5,
            ..MdasParams::for_film(film)
        },
    ));
    // The contrast and trimmed split rules on the edge (its halves
    // differ; a lone sample across it is what trimming leaves out), the
    // linear integrand (every axis has some contrast) and the NaN/Inf case
    // (non-finite samples left out of the halves' means and of the
    // outlier's choice).
    for (of, name, split) in [
        ("edge 3D", "edge 3D contrast", SplitRule::Contrast),
        ("linear 4D l=2", "linear 4D contrast", SplitRule::Contrast),
        ("nan 3D", "nan 3D contrast", SplitRule::Contrast),
        ("edge 3D", "edge 3D trimmed", SplitRule::Trimmed),
        ("linear 4D l=2", "linear 4D trimmed", SplitRule::Trimmed),
        ("nan 3D", "nan 3D trimmed", SplitRule::Trimmed),
    ] {
        let (_, case, dims, film, p) = *v.iter().find(|c| c.0 == of).expect("a listed case");
        v.push((name, case, dims, film, MdasParams { split, ..p }));
    }
    v
}

/// The trimmed rule's cases must exercise the trim: the edge and the
/// linear case end with other leaves than the contrast rule's runs (so the
/// oracle test compares a trim that happened, not two identical rules).
/// The NaN case's few splits come out the same under both rules.
#[test]
fn the_trimmed_split_changes_the_leaves() {
    let all = cases();
    for name in ["edge 3D", "linear 4D"] {
        let find = |rule: &str| {
            *all.iter()
                .find(|c| c.0.starts_with(name) && c.0.ends_with(rule))
                .expect("a listed case")
        };
        let leaves = |(_, case, dims, film, p): (&str, u32, u32, Film, MdasParams)| {
            let (_, snaps) = render_observed(case, dims, film, p);
            snaps.last().expect("a snapshot").leaves.clone()
        };
        assert!(
            leaves(find("contrast")) != leaves(find("trimmed")),
            "{name}: trimming changed no split"
        );
    }
}

fn check_invariants(name: &str, s: &Snapshot, m: u32) {
    let ctx = format!("{name}, iteration {} (final: {})", s.iteration, s.is_final);
    // Volumes sum to the domain volume 1 (every extent is dyadic; the f64
    // sum of ≤ 10⁴ products is exact to ~1e-12).
    let total: f64 = (0..s.leaf_count).map(|k| s.leaf_volume(k)).sum();
    assert!(
        (total - 1.0).abs() < 1e-9,
        "{ctx}: leaf volumes sum to {total}"
    );

    // Every sample in exactly one leaf, inside its box.
    let mut owner = vec![u32::MAX; s.sample_count as usize];
    for k in 0..s.leaf_count {
        let leaf = s.leaf(k);
        let max = if s.is_final { m + 1 } else { m };
        assert!(
            (1..=max).contains(&leaf.count),
            "{ctx}: leaf {k} holds {} samples",
            leaf.count
        );
        for smp in s.leaf_samples(k) {
            assert!(
                smp < s.sample_count,
                "{ctx}: leaf {k} lists sample {smp} of {}",
                s.sample_count
            );
            assert_eq!(
                owner[smp as usize],
                u32::MAX,
                "{ctx}: sample {smp} in leaves {} and {k}",
                owner[smp as usize]
            );
            owner[smp as usize] = k;
            for a in 0..s.dims {
                let (lo, hi) = leaf.bounds[a as usize];
                let q = s.sample_q(smp, a);
                assert!(
                    lo <= q && q < hi,
                    "{ctx}: sample {smp} axis {a} quantum {q} outside leaf {k} [{lo}, {hi})"
                );
            }
        }
    }
    assert!(
        owner.iter().all(|&o| o != u32::MAX),
        "{ctx}: a sample belongs to no leaf"
    );

    // The boxes tile the domain: random points lie in exactly one leaf.
    let boxes: Vec<Vec<(f64, f64)>> = (0..s.leaf_count).map(|k| s.leaf_box(k)).collect();
    let mut rng = rand::rngs::StdRng::seed_from_u64(s.iteration as u64);
    for _ in 0..300 {
        let p: Vec<f64> = (0..s.dims).map(|_| rng.random::<f64>()).collect();
        let inside = boxes
            .iter()
            .filter(|b| b.iter().zip(&p).all(|((lo, hi), x)| lo <= x && x < hi))
            .count();
        assert_eq!(inside, 1, "{ctx}: point {p:?} is in {inside} leaves");
    }

    if !s.is_final {
        // Errors are current, finite, non-negative; E_max is their maximum.
        let emax = f32::from_bits(s.emax_bits);
        let mut max_bits = 0;
        for k in 0..s.leaf_count {
            let leaf = s.leaf(k);
            assert_ne!(
                leaf.error_bits, DIRTY,
                "{ctx}: leaf {k} error not recomputed"
            );
            let e = f32::from_bits(leaf.error_bits);
            assert!(e.is_finite() && e >= 0.0, "{ctx}: leaf {k} error {e}");
            if !leaf.collapsed {
                assert!(e <= emax, "{ctx}: leaf {k} error {e} above E_max {emax}");
                max_bits = max_bits.max(leaf.error_bits);
                // The CPU formula agrees (f32 ops in the same order; the
                // GPU may round ldexp/division by a few ulps).
                let cpu = cpu_oracle::leaf_error(s, k);
                assert!(
                    (cpu - e).abs() <= 1e-5 * e.max(1e-30),
                    "{ctx}: leaf {k} error GPU {e} CPU {cpu}"
                );
            }
        }
        assert_eq!(
            max_bits, s.emax_bits,
            "{ctx}: E_max is not the largest error"
        );
    }
}

#[test]
fn invariants_hold_after_every_iteration() {
    for (name, case, dims, film, p) in cases() {
        let (r, snaps) = render_observed(case, dims, film, p);
        assert!(snaps.len() >= 3, "{name}: only {} snapshots", snaps.len());
        for s in &snaps {
            check_invariants(name, s, p.max_samples_per_leaf);
        }
        let last = snaps.last().unwrap();
        eprintln!(
            "{name}: {} iterations, {} leaves, {} samples",
            last.iteration, last.leaf_count, last.sample_count
        );
        assert_eq!(r.samples, last.sample_count as u64);
        // The budget is met exactly (no leaf collapses in these cases).
        assert_eq!(r.samples, last.budget as u64, "{name}");
    }
}

#[test]
fn cpu_oracle_builds_the_same_leaves_and_samples() {
    // Leaves of m + 1 samples after a trimmed last iteration: their last
    // slot lives in the error word, and the comparison must see some.
    let mut overfull = 0;
    // Splits whose plane is a sample's own quantum (that sample goes
    // right): the comparison must see some too.
    let mut on_plane = 0;
    for (name, case, dims, film, p) in cases() {
        let (_, snaps) = render_observed(case, dims, film, p);
        let mut splits = 0;
        for pair in snaps.windows(2) {
            let (before, after) = (&pair[0], &pair[1]);
            let ctx = format!("{name}, iteration {}", before.iteration);
            let predicted = cpu_oracle::step(before);
            for (k, d) in predicted.decisions.iter().enumerate() {
                if d.selected && d.split {
                    let axis = d.axis as usize;
                    on_plane += (d.cand[axis] == d.plane) as u32;
                    on_plane += before
                        .leaf_samples(k as u32)
                        .iter()
                        .filter(|&&i| before.sample_q(i, d.axis) == d.plane)
                        .count() as u32;
                }
            }
            splits += predicted
                .decisions
                .iter()
                .filter(|d| d.split && d.selected)
                .count();
            assert_eq!(
                predicted.sample_count, after.sample_count,
                "{ctx}: sample count"
            );
            assert_eq!(predicted.leaf_count, after.leaf_count, "{ctx}: leaf count");
            assert_eq!(
                predicted.samples, after.samples,
                "{ctx}: sample coordinates or lists differ"
            );
            // Decoded, so that slots past a leaf's count (stale words) are
            // not compared.
            let mut p_snap = after.clone();
            p_snap.leaves = predicted.leaves.clone();
            for k in 0..after.leaf_count {
                let (p, g) = (p_snap.leaf(k), after.leaf(k));
                overfull += (g.count > after.params.max_samples_per_leaf) as u32;
                assert_eq!(
                    (p.cell, &p.samples, p.collapsed),
                    (g.cell, &g.samples, g.collapsed),
                    "{ctx}: leaf {k} cell, samples (in slot order) or collapsed flag"
                );
                assert_eq!(p.bounds, g.bounds, "{ctx}: leaf {k} box");
                if p.error_bits != DIRTY {
                    assert_eq!(
                        p.error_bits, g.error_bits,
                        "{ctx}: unchanged leaf {k} had its error changed"
                    );
                } else if !after.is_final {
                    assert_ne!(
                        g.error_bits, DIRTY,
                        "{ctx}: changed leaf {k} error not recomputed"
                    );
                }
            }
        }
        assert!(
            splits > 0,
            "{name}: the oracle comparison never saw a split"
        );
    }
    assert!(overfull > 0, "no case filled a leaf's last slot");
    assert!(on_plane > 0, "no split plane fell on a sample");
}

/// Σ over pixels of value × area (= 1) equals Σ over leaves of V·f̄ with V in
/// raster units (normalized volume × W·H). Each splat term carries a few
/// f32 roundings (relative ≤ 8·2⁻²⁴), the weight normalisation divides by
/// Σw = 1 ± 1e-6, and pixels are f32: 1e-5 of Σ|V f̄| bounds the gap.
#[test]
fn reconstruction_conserves_energy() {
    let mut cases = cases();
    cases.push((
        "dynamic range",
        2,
        3,
        Film {
            width: 6,
            height: 5,
        },
        params(1, 1, 1, 16.0, 2),
    ));
    for (name, case, dims, film, p) in cases {
        // The box rule's invariant: `pixel` and `sampled` (the defaults'
        // case) weight a leaf's parts of a pixel by where its samples are,
        // and do not conserve Σ V·f̄.
        let p = MdasParams {
            reconstruction: mdas::integrator::mdas::Reconstruction::Box,
            ..p
        };
        let (r, snaps) = render_observed(case, dims, film, p);
        let s = snaps.last().unwrap();
        let area = (film.width * film.height) as f64;
        let (mut leaf_sum, mut leaf_abs) = ([0.0f64; 3], 0.0f64);
        for k in 0..s.leaf_count {
            if let Some(mean) = s.leaf_mean(k) {
                let v = s.leaf_volume(k) * area;
                for c in 0..3 {
                    leaf_sum[c] += v * mean[c];
                    leaf_abs += (v * mean[c]).abs();
                }
            }
        }
        if case == 1 {
            // Leaves without finite samples drop out and the rest are
            // renormalised: compare with the mean instead (every finite
            // sample is 1).
            assert!(
                r.image
                    .iter()
                    .all(|p| p.iter().all(|&c| (c - 1.0).abs() < 1e-6)),
                "{name}"
            );
            continue;
        }
        for c in 0..3 {
            let image_sum: f64 = r.image.iter().map(|p| p[c] as f64).sum();
            assert!(
                (image_sum - leaf_sum[c]).abs() <= 1e-5 * leaf_abs,
                "{name}: channel {c}: Σ pixels {image_sum} vs Σ leaves V·f̄ {}",
                leaf_sum[c]
            );
        }
    }
}

/// A leaf whose m + 1 samples (with the candidate) share one quantum on
/// every axis cannot be split at its object median: `decide` (CPU twin of
/// the kernel's) marks it collapsed and does not select it, and a
/// collapsed leaf is skipped from then on. Natural renders cannot reach
/// boxes this small (2⁻¹⁶ of a cell per axis), so the state is built by hand.
#[test]
fn a_leaf_that_cannot_split_collapses() {
    let dims = 3;
    let mut p = params(0, 0, 1, 8.0, 1);
    p.max_samples_per_leaf = 2;
    // One leaf, box [7, 8) on every axis, samples 0 and 1 both at quantum 7.
    let box_word = 7 | (7 << 16);
    let snapshot = Snapshot {
        iteration: 1,
        is_final: false,
        params: p,
        dims,
        film: Film {
            width: 1,
            height: 1,
        },
        budget: 8,
        leaf_count: 1,
        sample_count: 2,
        emax_bits: 1.0f32.to_bits(),
        inv_alpha: 4.0,
        inv_pace: 1.0,
        select_all: false,
        epsilon: 1e-2,
        // Cell, header (slot 0 = sample 0, count 2), error, the box, slot
        // 1 = sample 1 (slot m = 2 would be the error word).
        leaves: vec![
            0,
            2 << 27,
            1.0f32.to_bits(),
            box_word,
            box_word,
            box_word,
            1,
        ],
        samples: vec![7 | (7 << 16), 7, 7 | (7 << 16), 7],
        values: vec![0; 6],
    };
    let d = cpu_oracle::decide(&snapshot, 0);
    assert!(d.collapse && !d.selected, "{d:?}");
    let next = cpu_oracle::step(&snapshot);
    assert_eq!(next.sample_count, 2, "a collapsing leaf takes no sample");
    let mut collapsed = snapshot.clone();
    collapsed.leaves = next.leaves.clone();
    assert!(collapsed.leaf(0).collapsed);
    assert_eq!(
        cpu_oracle::decide(&collapsed, 0),
        Default::default(),
        "collapsed leaves are skipped"
    );
}

/// The paced selection (plan.wgsl `pace_next`): after each iteration the
/// factor c that multiplies every leaf's selection probability moves by
/// T/S, S the leaves that iteration selected and T = max(⌈s·left⌉, floor)
/// the next iteration's aim (the step within [1/64, 64], c within
/// [1, 2^24]); checked against a CPU port from consecutive snapshots
/// (relative 10⁻⁵: WGSL's f32 division may be off by 2.5 ulp). And what
/// it is for: at α = 16 the paper's rule (s = 0) takes many small
/// iterations, the paced one at most a third as many for the same budget.
#[test]
fn paced_selection_follows_its_rule_and_cuts_iterations() {
    let (_, case, dims, film, p) = *cases()
        .iter()
        .find(|c| c.0 == "edge 3D paced α=16")
        .expect("a listed case");
    let (_, snaps) = render_observed(case, dims, film, p);
    let budget = snaps[0].budget;
    let initial = snaps[0].sample_count;
    let floor = ((f64::from(p.pace) / 4.0 * f64::from(budget - initial)).ceil() as u32).max(1);
    assert_eq!(
        snaps[0].inv_pace, 1.0,
        "the first iteration is the paper's rule"
    );
    let mut raised = false;
    for w in snaps.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if b.is_final {
            break;
        }
        let selected = b.sample_count - a.sample_count;
        let left = budget - b.sample_count;
        let aim = (p.pace * left as f32).ceil().max(floor as f32);
        let step = (aim / selected.max(1) as f32).clamp(1.0 / 64.0, 64.0);
        let c = (step / a.inv_pace).clamp(1.0, 16_777_216.0);
        let want = 1.0 / c;
        assert!(
            (b.inv_pace - want).abs() <= 1e-5 * want,
            "iteration {}: 1/c = {} where the rule gives {want} (S = {selected}, left = {left})",
            b.iteration,
            b.inv_pace
        );
        raised |= b.inv_pace < 1.0;
    }
    assert!(
        raised,
        "c never rose above 1: the case does not exercise pacing"
    );
    let paced_iterations = snaps.last().unwrap().iteration;
    let (_, plain) = render_observed(case, dims, film, MdasParams { pace: 0.0, ..p });
    let plain_iterations = plain.last().unwrap().iteration;
    assert!(
        3 * paced_iterations <= plain_iterations,
        "paced: {paced_iterations} iterations, the paper's rule: {plain_iterations}"
    );
}

/// The iteration loop runs on the GPU whatever the host does: submitting
/// after every error pass (an observer reading snapshots) or recording
/// iterations in batches of 2, 4, 8, … with zero-sized dispatches past the
/// end gives the same bits, sample count and non-finite count.
#[test]
fn batched_and_observed_renders_agree_bit_for_bit() {
    let bits = |r: &mdas::integrator::Render| -> Vec<u32> {
        r.image.iter().flat_map(|p| p.map(f32::to_bits)).collect()
    };
    let mut crossed_batches = false;
    for (name, case, dims, film, p) in cases() {
        let batched = render(case, dims, film, p);
        let (observed, snaps) = render_observed(case, dims, film, p);
        // More than FIRST_BATCH = 2 iterations: the batched render read the
        // state between two submissions and ran iterations past the end.
        crossed_batches |= snaps.last().unwrap().iteration > 2;
        assert_eq!(batched.samples, observed.samples, "{name}");
        assert_eq!(batched.nonfinite, observed.nonfinite, "{name}");
        assert_eq!(bits(&batched), bits(&observed), "{name}: images differ");
    }
    assert!(crossed_batches, "no case ran more than one batch");
}

/// The arrays that grow with the budget split across several storage
/// bindings (issue 10 item 4: the capacity is the device's memory, not its
/// largest binding) give the same bits as one binding each: every leaf,
/// sample and value after every iteration, and the image. Pages of about
/// half the values array (rounded down to a power of two) put each array
/// on two or more pages; leaf records (3 + m words), values (3 words) and
/// the 8D case's boxes straddle page boundaries.
#[test]
fn paged_arrays_agree_with_whole_arrays_bit_for_bit() {
    use mdas::integrator::{Integrator, Mdas};
    let gpu = common::gpu();
    let bits = |r: &mdas::integrator::Render| -> Vec<u32> {
        r.image.iter().flat_map(|p| p.map(f32::to_bits)).collect()
    };
    let mut most_pages = 0;
    for (name, case, dims, film, p) in cases() {
        if name == "deep 3D" {
            // m = 8: its leaf array is a quarter of its values, so no page
            // size puts every array on two pages within 32 bindings.
            continue;
        }
        let integrand = common::TestIntegrand::new(gpu, case, dims, film);
        let (whole, whole_snaps) = render_observed(case, dims, film, p);
        let whole_cfg = Mdas::new(p).unwrap().config_for(gpu, &integrand).unwrap();
        assert_eq!(
            whole_cfg.pages.extra(),
            0,
            "{name}: a small render was paged"
        );
        let page = whole_cfg.values_bytes() / 2;
        let mut mdas = Mdas::new(p).unwrap().with_max_page_bytes(page);
        let cfg = mdas.config_for(gpu, &integrand).unwrap();
        assert!(
            cfg.pages.count.iter().all(|&c| c >= 2),
            "{name}: {:?}",
            cfg.pages
        );
        most_pages = most_pages.max(cfg.pages.count[2]);
        let mut snaps = Vec::new();
        let paged = mdas
            .render_observed(gpu, &integrand, &mut |s| snaps.push(s.clone()))
            .unwrap();
        assert_eq!(snaps.len(), whole_snaps.len(), "{name}: iterations");
        for (a, b) in snaps.iter().zip(&whole_snaps) {
            let ctx = format!("{name}, iteration {}", a.iteration);
            assert_eq!(a.leaves, b.leaves, "{ctx}: leaves");
            assert_eq!(a.samples, b.samples, "{ctx}: sample coordinates");
            assert_eq!(a.values, b.values, "{ctx}: values");
        }
        assert_eq!(paged.samples, whole.samples, "{name}");
        assert_eq!(paged.nonfinite, whole.nonfinite, "{name}");
        assert_eq!(bits(&paged), bits(&whole), "{name}: images differ");
        // The batched render (no observer) on pages too.
        let batched = mdas.render(gpu, &integrand).unwrap();
        assert_eq!(bits(&batched), bits(&whole), "{name}: batched paged image");
    }
    assert!(most_pages >= 4, "values never spanned four pages");
}

/// The reconstruction kernel against its CPU oracle (`Snapshot::reconstruct`,
/// f64), both rules, on every case: with `Pixel` at κ = 0 (a pixel's own
/// samples alone), 1 and 2.5. Only the reconstruction reads κ and the rule,
/// so every rule renders the same leaves and samples (checked), and the
/// images differ only where a leaf's film box spans pixels. Each splatted
/// term is a value of ≤ 15 f32 operations times a weight of ≤ 16 (relative
/// error ≤ 32·2⁻²⁴ ≈ 2e-6) plus the fixed point's 2⁻⁶⁰·max|f|, and the
/// weight sum's own rounding ≤ 1e-6: 1e-5 × max|f| bounds the gap.
#[test]
fn reconstruction_matches_the_cpu_oracle() {
    use mdas::integrator::mdas::Reconstruction;
    let mut pixel_differs = false;
    // Not the defaults' case: its leaves are a few hundredths of a pixel
    // wide, where the kernel's f32 leaf bounds (2⁻²⁴·W) move overlap
    // weights by more than the bound below assumes; every rule is checked
    // on the other cases.
    for (name, case, dims, film, p) in cases().into_iter().filter(|c| c.0 != "edge 3D defaults") {
        let (box_render, box_snaps) = render_observed(case, dims, film, p);
        let leaves = box_snaps.last().unwrap();
        let scale = leaves
            .values
            .chunks_exact(3)
            .take(leaves.sample_count as usize)
            .flat_map(|v| v[..3].iter().map(|&b| f32::from_bits(b)))
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs() as f64));
        // The rules differ only where a leaf's film box spans pixels, and
        // a one-pixel film has none: there (the deep case, ~550
        // iterations a render) the box rule alone is checked.
        let rules = if film.width * film.height == 1 { 1 } else { 7 };
        let runs = [(Reconstruction::Box, 1.0)]
            .into_iter()
            .chain([0.0, 1.0, 2.5].map(|k| (Reconstruction::Pixel, k)))
            .chain([0.0, 1.0].map(|k| (Reconstruction::Sampled, k)))
            .chain([(Reconstruction::Shrinkage, 0.0)])
            .take(rules);
        let mut box_oracle = Vec::new();
        for (rule, kappa) in runs {
            let q = MdasParams {
                reconstruction: rule,
                pixel_prior: kappa,
                ..p
            };
            let (r, snaps) = if rule == Reconstruction::Box {
                (box_render.clone(), box_snaps.clone())
            } else {
                render_observed(case, dims, film, q)
            };
            let s = snaps.last().unwrap();
            let ctx = format!("{name}, {rule} κ = {kappa}");
            assert_eq!(
                (&s.leaves, &s.samples, &s.values),
                (&leaves.leaves, &leaves.samples, &leaves.values),
                "{ctx}: the rule changed the sampling"
            );
            let oracle = Snapshot {
                params: q,
                ..s.clone()
            }
            .reconstruct();
            for (k, (g, o)) in r.image.iter().zip(&oracle).enumerate() {
                for c in 0..3 {
                    let (g, o) = (g[c] as f64, o[c]);
                    assert!(
                        (g.is_nan() && o.is_nan()) || (g - o).abs() <= 1e-5 * scale,
                        "{ctx}: pixel {k} channel {c}: GPU {g} vs oracle {o}"
                    );
                }
            }
            if rule == Reconstruction::Box {
                box_oracle = oracle;
            } else {
                pixel_differs |= oracle
                    .iter()
                    .zip(&box_oracle)
                    .any(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 1e-3 * scale));
            }
        }
    }
    assert!(pixel_differs, "no case has a leaf wider than a pixel");
}

/// The evaluate pass's loop (`Config::eval_per_invocation`: 8 on a CPU
/// adapter, 1 on a GPU) and the fewest workgroups a dispatch aims for
/// (`with_eval_min_groups`: fewer samples per invocation where a dispatch
/// is small) change which invocation evaluates a sample, not the sample
/// or its value: 1, 3 and 8 samples per invocation, and 8 with 1 or 64
/// workgroups at least, give the same image, bit for bit, and the same
/// sample count.
#[test]
fn evaluate_loop_changes_nothing() {
    use mdas::integrator::{Integrator, Mdas};
    let gpu = common::gpu();
    for (name, case, dims, film, p) in cases() {
        let integrand = common::TestIntegrand::new(gpu, case, dims, film);
        let renders: Vec<_> = [(1, 1), (3, 1), (8, 1), (8, 64)]
            .map(|(n, groups)| {
                Mdas::new(p)
                    .unwrap()
                    .with_eval_per_invocation(n)
                    .with_eval_min_groups(groups)
                    .render(gpu, &integrand)
                    .unwrap()
            })
            .into();
        for r in &renders[1..] {
            assert_eq!(r.samples, renders[0].samples, "{name}");
            let bits = |r: &mdas::integrator::Render| {
                r.image
                    .iter()
                    .flat_map(|p| p.map(f32::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(r), bits(&renders[0]), "{name}");
        }
    }
}

/// Unrolling the count pass's loops (`Config::unroll_loops`: on a GPU,
/// not on a CPU adapter) changes the compiled code, not a sample, a split
/// or a value: both give the same image, bit for bit. The deep case is
/// left out: unrolled on lavapipe, its ~550 count dispatches rebuild the
/// kernel each time (~7 ms each).
#[test]
fn loop_unrolling_changes_nothing() {
    use mdas::integrator::{Integrator, Mdas};
    let gpu = common::gpu();
    for (name, case, dims, film, p) in cases().into_iter().filter(|c| c.0 != "deep 3D") {
        let integrand = common::TestIntegrand::new(gpu, case, dims, film);
        let [a, b] = [false, true].map(|unroll| {
            Mdas::new(p)
                .unwrap()
                .with_unrolled_loops(unroll)
                .render(gpu, &integrand)
                .unwrap()
        });
        assert_eq!(a.samples, b.samples, "{name}");
        assert_eq!(common::image_bits(&a), common::image_bits(&b), "{name}");
    }
}

/// With `initial_offsets = "kronecker"` the initial samples follow
/// `initial.wgsl`'s rule exactly (a CPU oracle of the kernel): in each
/// cell, along every axis, the l samples take the l strata once each (a
/// Latin hypercube); on the film axes at independent offsets (their
/// offsets differ), on every axis past them all at one offset inside
/// their stratum, the cell's point of the Kronecker sequence
/// frac(c·α_a + s_a): with J_c = ⌊(c·A_a + S_a)/2^16⌋ (A_a, S_a in 0.32
/// fixed point), J_c = ⌊c·A_a/2^16⌋ + J_0 + (0 or 1) mod 2^16, and each
/// sample's coordinate is ⌊(rank·2^16 + J_c)/l⌋.
#[test]
fn initial_samples_are_latin_hypercubes_at_kronecker_offsets() {
    use mdas::integrator::mdas::initial::lattice_steps;
    use mdas::integrator::mdas::InitialOffsets;
    let steps = lattice_steps();
    for (dims, l, extra, bits) in [(3u32, 5u32, 3u32, 0u32), (4, 3, 2, 1), (8, 7, 1, 0)] {
        let film = Film {
            width: 8,
            height: 8,
        };
        let p = MdasParams {
            max_samples_per_leaf: l.max(4),
            initial_offsets: InitialOffsets::Kronecker,
            ..params(bits, extra, l, 40.0, 11)
        };
        let (_, snaps) = render_observed(0, dims, film, p);
        let s = &snaps[0];
        let cells = 1u32 << (dims * bits + 2 * extra);
        assert_eq!(s.sample_count, cells * l, "{dims}D: the initial samples");
        let words = dims.div_ceil(2) as usize;
        let coord = |sample: u32, axis: u32| {
            (s.samples[sample as usize * words + axis as usize / 2] >> (16 * (axis % 2))) & 0xffff
        };
        // The strata of cell c's samples on `axis` if they sit at offset
        // J: each coordinate is ⌊(rank·2^16 + J)/l⌋ for one rank < l.
        let ranks_at = |c: u32, axis: u32, j: u32| -> Option<Vec<u32>> {
            (0..l)
                .map(|k| {
                    let q = coord(c * l + k, axis);
                    (0..l).find(|&rank| (rank * 65536 + j) / l == q)
                })
                .collect()
        };
        // The film axes: a Latin hypercube per cell, offsets not shared
        // (l samples at one offset in every cell would be chance).
        for axis in 0..2 {
            let mut shared = 0;
            for c in 0..cells {
                let mut strata: Vec<u32> =
                    (0..l).map(|k| (coord(c * l + k, axis) * l) >> 16).collect();
                let offsets: Vec<u32> = (0..l)
                    .map(|k| (coord(c * l + k, axis) * l) & 0xffff)
                    .collect();
                strata.sort_unstable();
                // ⌊q·l⌋ can fall one short of a stratum's start: allow it.
                assert!(
                    strata.windows(2).all(|w| w[0] != w[1])
                        || offsets.iter().any(|&o| o > 65536 - l),
                    "{dims}D cell {c} film axis {axis}: two samples in one stratum"
                );
                shared +=
                    (offsets.iter().max().unwrap() - offsets.iter().min().unwrap() < l) as u32;
            }
            assert!(
                shared < cells / 4,
                "{dims}D film axis {axis}: {shared} of {cells} cells share an offset"
            );
        }
        for axis in 2..dims {
            let j0 = (0..65536)
                .find(|&j| ranks_at(0, axis, j).is_some())
                .unwrap_or_else(|| panic!("{dims}D axis {axis}: cell 0 has no common offset"));
            for c in 0..cells {
                let base = (c.wrapping_mul(steps[axis as usize]) >> 16) + j0;
                let mut ranks = (0..2)
                    .find_map(|carry| ranks_at(c, axis, (base + carry) & 0xffff))
                    .unwrap_or_else(|| {
                        panic!("{dims}D cell {c} axis {axis}: not at its Kronecker offset")
                    });
                ranks.sort_unstable();
                assert_eq!(
                    ranks,
                    (0..l).collect::<Vec<_>>(),
                    "{dims}D cell {c} axis {axis}: one sample per stratum"
                );
            }
        }
    }
}
