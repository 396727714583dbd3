//! Unit tests of `lgh`.

use super::*;

#[test]
fn auto_levels_follow_the_cell_budget() {
    assert_eq!(LghGrid::auto_levels(0), 1);
    assert_eq!(LghGrid::auto_levels(15), 1);
    assert_eq!(LghGrid::auto_levels(16), 2);
    assert_eq!(LghGrid::auto_levels(4096), 4);
    assert_eq!(LghGrid::auto_levels(1 << 20), 7);
    assert_eq!(LghGrid::auto_levels(usize::MAX), MAX_AUTO_LEVELS);
}

#[test]
fn powers_of_two_are_exact() {
    assert_eq!(LghGrid::pow2(0), 1.0);
    assert_eq!(LghGrid::pow2(3), 8.0);
    assert_eq!(LghGrid::pow2(-2), 0.25);
}

/// `a` and `b` agree to a relative 1e-6 (a few f32 roundings of
/// operands near 1).
fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= 1e-6 * b.abs().max_element().max(1e-30)
}

/// Original lights as shading sees them: a point is isotropic with no
/// normal and no clamp (its `p1` holds its position, not a normal); a
/// VPL keeps its normal and the VPL clamp.
#[test]
fn original_lights_become_emitters() {
    let p = Vec3::new(1.0, 2.0, 3.0);
    let point = Emitter::light(&LightPrim::point(p, Vec3::new(1.0, 2.0, 3.0)), 0.25);
    assert_eq!(
        point,
        Emitter {
            pos: p,
            sigma: Vec3::ZERO,
            e: Vec3::new(1.0, 2.0, 3.0),
            iso: 1.0,
            n: Vec3::ZERO,
            clamp2: 0.0,
            soft2: 0.0,
        }
    );
    let vpl = Emitter::light(&LightPrim::vpl(p, Vec3::Z, Vec3::ONE), 0.25);
    assert_eq!(
        (vpl.iso, vpl.n, vpl.clamp2, vpl.soft2),
        (0.0, Vec3::Z, 0.25, 0.0)
    );
}

/// `I(ω)·cosθ_x / (max(d², clamp²) + soft²)` worked by hand: an
/// emitter 2 above the shading point (d² = 4, ω toward it = +z).
#[test]
fn emitter_eval_known_answers() {
    let e = Vec3::new(1.0, 2.0, 3.0);
    let at = |iso: f32, n: Vec3, clamp2: f32, soft2: f32| Emitter {
        pos: Vec3::new(0.0, 0.0, 2.0),
        sigma: Vec3::ZERO,
        e,
        iso,
        n,
        clamp2,
        soft2,
    };
    let point = at(1.0, Vec3::ZERO, 0.0, 0.0);
    assert_eq!(point.eval(Vec3::ZERO, Vec3::Z), e / 4.0);
    // Issue 51: a smooth-shaded receiver whose shading normal faces the
    // light but whose geometric surface hides it gets nothing, as with
    // every other sampler (cos_reflect); the shading cosine weights the
    // rest.
    let ns = Vec3::new(0.6, 0.0, 0.8);
    assert!(close(point.eval_shaded(Vec3::ZERO, ns, Vec3::Z), e * 0.2));
    assert_eq!(point.eval_shaded(Vec3::ZERO, ns, -Vec3::Z), Vec3::ZERO);
    assert_eq!(
        point.eval_shaded(Vec3::ZERO, Vec3::Z, Vec3::new(0.0, 1.0, -1e-3).normalize()),
        Vec3::ZERO
    );
    // A receiver tilted to cos θ_x = 0.8; one facing away sees nothing.
    let tilted = Vec3::new(0.6, 0.0, 0.8);
    assert!(close(point.eval(Vec3::ZERO, tilted), e * 0.2));
    assert_eq!(point.eval(Vec3::ZERO, -Vec3::Z), Vec3::ZERO);
    assert_eq!(point.eval(Vec3::ZERO, Vec3::X), Vec3::ZERO);
    // The clamp replaces d² when larger; soft² always adds.
    assert!(close(
        at(1.0, Vec3::ZERO, 9.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
        e / 9.0
    ));
    assert_eq!(
        at(1.0, Vec3::ZERO, 1.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
        e / 4.0
    );
    assert_eq!(
        at(1.0, Vec3::ZERO, 0.0, 4.0).eval(Vec3::ZERO, Vec3::Z),
        e / 8.0
    );
    assert_eq!(
        at(1.0, Vec3::ZERO, 12.0, 4.0).eval(Vec3::ZERO, Vec3::Z),
        e / 16.0
    );
    // A cosine lobe about n: facing the point (1), tilted (0.8), away (0).
    assert_eq!(
        at(0.0, -Vec3::Z, 0.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
        e / 4.0
    );
    let lobe = at(0.0, Vec3::new(0.0, 0.6, -0.8), 0.0, 0.0);
    assert!(close(lobe.eval(Vec3::ZERO, Vec3::Z), e * 0.2));
    assert_eq!(
        at(0.0, Vec3::Z, 0.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
        Vec3::ZERO
    );
    // A grid light's mix: iso/W = 1/4 plus the lobe of N/W = (0, 0, −1/2).
    let mix = at(0.25, Vec3::new(0.0, 0.0, -0.5), 0.0, 0.0);
    assert_eq!(mix.eval(Vec3::ZERO, Vec3::Z), e * (0.75 / 4.0));
    // On the light (d = 0) and with a NaN lobe: zero, not NaN.
    assert_eq!(point.eval(point.pos, Vec3::Z), Vec3::ZERO);
    assert_eq!(
        at(f32::NAN, Vec3::ZERO, 0.0, 0.0).eval(Vec3::ZERO, Vec3::Z),
        Vec3::ZERO
    );
}

/// The levels of a grid over lights spanning (4, 1, 1) from (1, 2, 3)
/// with L = 3, worked by hand: h_1 = 4/4 = 1, h_0 = 1/2, h_3 = 4.
#[test]
fn grid_geometry_known_answers() {
    let prims = [
        LightPrim::point(Vec3::new(1.0, 2.0, 3.0), Vec3::ONE),
        LightPrim::point(Vec3::new(5.0, 3.0, 4.0), Vec3::ONE),
        // Triangles are not grid lights: it widens nothing.
        LightPrim::triangle(Vec3::splat(-50.0), Vec3::splat(60.0), Vec3::X, Vec3::ONE),
    ];
    let g = LghGrid::new(&prims, 3).unwrap();
    assert_eq!(
        g,
        LghGrid {
            lo: Vec3::new(1.0, 2.0, 3.0),
            levels: 3,
            h1: 1.0,
            inv_h1: 1.0,
        }
    );
    assert_eq!(g.cells(), 4);
    assert_eq!([g.res(1), g.res(2), g.res(3)], [5, 3, 2]);
    assert_eq!([g.h(0), g.h(1), g.h(2), g.h(3)], [0.5, 1.0, 2.0, 4.0]);
    assert_eq!([g.inv_h(1), g.inv_h(2), g.inv_h(3)], [1.0, 0.5, 0.25]);
    assert_eq!(
        [g.index_offset(1), g.index_offset(2), g.index_offset(3)],
        [0, 125, 152]
    );
    assert_eq!(g.index_len(), 160);
    assert_eq!(g.vertex_index(1, [1, 2, 3]), 1 + 5 * (2 + 5 * 3));
    assert_eq!(g.vertex_index(2, [2, 1, 0]), 5);
    assert_eq!(g.vertex_pos(2, [1, 0, 1]), Vec3::new(3.0, 2.0, 5.0));
    assert_eq!(g.vertex_pos(1, [0, 3, 2]), Vec3::new(1.0, 5.0, 5.0));
    assert_eq!(g.vertex_pos(2, [2, 1, 2]), Vec3::new(5.0, 4.0, 7.0));
    // Cells and fractions; the last cell is clamped and takes t = 1
    // on its far side, points outside clamp to the border.
    let cell = |level, p| g.cell_of(level, p);
    assert_eq!(
        cell(1, Vec3::new(2.5, 2.25, 3.0)),
        ([1, 0, 0], Vec3::new(0.5, 0.25, 0.0))
    );
    assert_eq!(
        cell(1, Vec3::new(5.0, 3.0, 4.0)),
        ([3, 1, 1], Vec3::new(1.0, 0.0, 0.0))
    );
    assert_eq!(cell(1, Vec3::new(0.0, 2.0, 3.0)), ([0, 0, 0], Vec3::ZERO));
    assert_eq!(cell(1, Vec3::new(9.0, 2.0, 3.0)), ([3, 0, 0], Vec3::X));
    assert_eq!(
        cell(3, Vec3::new(5.0, 3.0, 4.0)),
        ([0, 0, 0], Vec3::new(1.0, 0.25, 0.25))
    );
    assert_eq!(
        cell(2, Vec3::new(4.0, 3.0, 4.0)),
        ([1, 0, 0], Vec3::new(0.5, 0.5, 0.5))
    );

    // A span that is no power of two: 1/h_1 is rounded once.
    let g = LghGrid::new(&prims[..2], 2).unwrap();
    assert_eq!((g.h1, g.inv_h1), (2.0, 0.5));
    let three = [
        LightPrim::vpl(Vec3::ZERO, Vec3::Z, Vec3::ONE),
        LightPrim::vpl(Vec3::new(0.0, 3.0, 0.0), Vec3::Z, Vec3::ONE),
    ];
    let g = LghGrid::new(&three, 2).unwrap();
    assert_eq!((g.h1, g.inv_h1), (1.5, (1.0f32 / 3.0) * 2.0));
    // Coincident lights span 1 from their position; without grid
    // lights the grid sits at the origin.
    let g = LghGrid::new(&prims[1..2], 1).unwrap();
    assert_eq!((g.lo, g.h1, g.inv_h1), (Vec3::new(5.0, 3.0, 4.0), 1.0, 1.0));
    let g = LghGrid::new(&prims[2..], 4).unwrap();
    assert_eq!((g.lo, g.h1, g.inv_h1), (Vec3::ZERO, 0.125, 8.0));
    // The default level count, and what is refused.
    assert_eq!(LghGrid::new(&prims, 0).unwrap().levels, 1);
    assert!(LghGrid::new(&prims, MAX_LEVELS).is_ok());
    assert!(LghGrid::new(&prims, MAX_LEVELS + 1).is_err());
    let nan = LightPrim::point(Vec3::new(0.0, f32::NAN, 0.0), Vec3::ONE);
    assert!(LghGrid::new(&[prims[0], nan], 2).is_err());
}

/// Trilinear weights at t = (1/4, 3/8, 3/4), exact in f32.
#[test]
fn trilinear_known_answers() {
    let t = Vec3::new(0.25, 0.375, 0.75);
    let want = [
        0.75 * 0.625 * 0.25,
        0.25 * 0.625 * 0.25,
        0.75 * 0.375 * 0.25,
        0.25 * 0.375 * 0.25,
        0.75 * 0.625 * 0.75,
        0.25 * 0.625 * 0.75,
        0.75 * 0.375 * 0.75,
        0.25 * 0.375 * 0.75,
    ];
    for (delta, w) in want.into_iter().enumerate() {
        assert_eq!(LghGrid::trilinear(t, delta as u32), w, "δ = {delta}");
    }
}

/// The paper's clamp `(c·R)²` with R = √3/2·h_top, against f64.
#[test]
fn soft_clamp_is_a_fraction_of_the_bounding_radius() {
    let g = LghGrid {
        lo: Vec3::ZERO,
        levels: 3,
        h1: 1.0,
        inv_h1: 1.0,
    };
    let want = (0.01 * 3f64.sqrt() / 2.0 * 4.0).powi(2);
    assert!((g.soft2(0.01) as f64 - want).abs() <= 1e-6 * want);
    assert_eq!(g.soft2(0.0), 0.0);
}

/// The blending ramps at hand-picked distances (h_1 = 1, L = 3, α = 1,
/// so r_1 = 1, r_2 = 2, r_3 = 4; with level 0, r_0 = 1/2).
#[test]
fn blend_ramps_known_answers() {
    let g = LghGrid {
        lo: Vec3::ZERO,
        levels: 3,
        h1: 1.0,
        inv_h1: 1.0,
    };
    // (distance, weight) pairs of level `level` with `first` the finest.
    let ramp = |first: u32, level: u32, cases: &[(f32, f32)]| {
        for &(d, want) in cases {
            let got = g.blend(1.0, first, level, d);
            assert_eq!(got, want, "first {first}, level {level}, d = {d}");
        }
    };
    // The finest level used rises from 0; it falls over [r, 2r].
    ramp(
        1,
        1,
        &[(0.0, 1.0), (1.0, 1.0), (1.5, 0.5), (2.0, 0.0), (2.5, 0.0)],
    );
    // Level 2: 0 below r/2 = 1, rises to 1 at r = 2, falls to 0 at 4.
    ramp(
        1,
        2,
        &[(0.5, 0.0), (1.5, 0.5), (2.0, 1.0), (3.0, 0.5), (4.0, 0.0)],
    );
    // The top level rises and never falls.
    ramp(1, 3, &[(1.0, 0.0), (3.0, 0.5), (1e30, 1.0)]);
    // With level 0 first, level 1 rises too.
    ramp(0, 0, &[(0.0, 1.0), (0.625, 0.75), (1.0, 0.0)]);
    ramp(0, 1, &[(0.25, 0.0), (0.625, 0.25), (1.0, 1.0)]);
    // α scales the radii: α = 2 puts level 2's rise over [2, 4].
    assert_eq!(g.blend(2.0, 1, 2, 3.0), 0.5);
}

/// A grid light's sums, worked by hand: a point and a VPL added with
/// their trilinear weights, then the sum moved to another vertex
/// equals adding the lights there directly.
#[test]
fn grid_light_sums_and_moves() {
    let i = Vec3::new(1.0, 2.0, 4.0);
    let lum = luminance(i);
    let point = LightPrim::point(Vec3::new(1.0, 2.0, 3.0), i);
    let normal = Vec3::new(0.0, 0.6, 0.8);
    let vpl = LightPrim::vpl(Vec3::new(0.0, 3.0, 2.0), normal, 2.0 * i);
    let v = Vec3::new(0.0, 2.0, 2.0);
    let mut g = GridLight::default();
    g.add_light(0.5, &point, v);
    g.add_light(0.25, &vpl, v);
    // ω = 0.5·lum and 0.25·2·lum; offsets (1, 0, 1) and (0, 1, 0).
    let w = 0.5 * lum;
    assert!(close(Vec3::from(g.e), 0.5 * i + 0.5 * i));
    assert!((g.w - 2.0 * w).abs() <= 1e-6 * g.w);
    assert!(close(Vec3::from(g.p), Vec3::new(w, w, w)));
    assert!(close(Vec3::from(g.q), Vec3::new(w, w, w)));
    assert_eq!(g.iso, w);
    assert!(close(Vec3::from(g.n), w * normal));
    assert!(close(g.centre(v), v + Vec3::splat(0.5)));

    // Moved to u with weight 1/4: the same as adding the two lights at
    // u with their weights quartered.
    let u = Vec3::new(2.0, -1.0, 0.5);
    let mut moved = GridLight::default();
    moved.add_grid(0.25, &g, v - u);
    let mut direct = GridLight::default();
    direct.add_light(0.125, &point, u);
    direct.add_light(0.0625, &vpl, u);
    for (a, b) in [
        (moved.e, direct.e),
        (moved.p, direct.p),
        (moved.q, direct.q),
        (moved.n, direct.n),
    ] {
        assert!(close(Vec3::from(a), Vec3::from(b)), "{a:?} vs {b:?}");
    }
    assert!((moved.w - direct.w).abs() <= 1e-6 * direct.w);
    assert!((moved.iso - direct.iso).abs() <= 1e-6 * direct.iso);
}

/// A grid light as shading sees it: centre v + P/W, σ² = Q/W − (P/W)²
/// (clamped at 0), iso/W and N/W.
#[test]
fn grid_light_emitter_known_answer() {
    let g = GridLight {
        e: [1.0, 2.0, 3.0],
        w: 2.0,
        p: [2.0, 0.0, 4.0],
        iso: 1.0,
        q: [4.0, 2.0, 7.0],
        vertex: 0,
        n: [0.0, 0.0, 1.0],
        level: 1,
    };
    let v = Vec3::new(1.0, 1.0, 1.0);
    assert_eq!(
        g.emitter(v, 0.5, 0.25),
        Emitter {
            pos: Vec3::new(2.0, 1.0, 3.0),
            sigma: Vec3::new(1.0, 1.0, 0.0),
            e: Vec3::new(1.0, 2.0, 3.0),
            iso: 0.5,
            n: Vec3::new(0.0, 0.0, 0.5),
            clamp2: 0.5,
            soft2: 0.25,
        }
    );
    assert_eq!(g.centre(v), Vec3::new(2.0, 1.0, 3.0));
}

/// The level-1 gather, vertex by vertex, against the trilinear weights
/// worked by hand: one cell (L = 1) spanning (0, 0, 0)–(2, 2, 2), a
/// light on each of two corners and one inside at t = (1/4, 1/2, 3/4);
/// a dark light adds nothing.
#[test]
fn level_one_gathers_trilinear_weights() {
    let prims = [
        LightPrim::point(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)),
        LightPrim::point(Vec3::splat(2.0), Vec3::new(0.0, 1.0, 0.0)),
        LightPrim::point(Vec3::new(0.5, 1.0, 1.5), Vec3::new(0.0, 0.0, 8.0)),
        LightPrim::point(Vec3::new(1.0, 1.0, 1.0), Vec3::ZERO),
    ];
    let h = build(&prims, 1).unwrap();
    assert_eq!(h.grid.h1, 2.0);
    assert_eq!(h.cells, vec![[0, 4]]);
    assert_eq!(h.sorted, vec![0, 1, 2, 3]);
    let t = Vec3::new(0.25, 0.5, 0.75);
    for delta in 0..8u32 {
        let v = [delta & 1, (delta >> 1) & 1, (delta >> 2) & 1];
        let g = h.light_at(1, v).expect("every corner holds light");
        let mut e = Vec3::new(0.0, 0.0, 8.0 * LghGrid::trilinear(t, delta));
        if delta == 0 {
            e.x = 1.0;
        }
        if delta == 7 {
            e.y = 1.0;
        }
        assert_eq!(Vec3::from(g.e), e, "vertex {v:?}");
        assert_eq!(g.vertex, h.grid.vertex_index(1, v));
        assert_eq!(g.level, 1);
    }
    assert_eq!(h.lights.len(), 8);
    // Without the inner light only the two corners hold light.
    let h = build(&[prims[0], prims[1], prims[3]], 1).unwrap();
    assert_eq!(h.lights.len(), 2);
    assert_eq!(h.index.iter().filter(|&&i| i != EMPTY).count(), 2);
    assert_eq!((h.index[0], h.index[7]), (0, 1));
}

/// The level-2 gather, vertex by vertex: one light at (1/2, 1/4, 3/2)
/// between dark lights fixing the bounds (0,0,0)–(2,2,2), L = 2. Every
/// level-1 grid light is centred on the light, so level 2 (one cell of
/// side 2) splits it with the trilinear weights of t = (1/4, 1/8, 3/4),
/// up to the rounding of the centres P/W (relative 1e-6). No two
/// coordinates of t are equal or 1/2, so a corner's weight names its
/// corner (a wrong delta bit or axis changes it).
#[test]
fn coarse_levels_gather_at_the_centres() {
    let prims = [
        LightPrim::point(Vec3::ZERO, Vec3::ZERO),
        LightPrim::point(Vec3::new(0.5, 0.25, 1.5), Vec3::new(0.0, 0.0, 8.0)),
        LightPrim::point(Vec3::splat(2.0), Vec3::ZERO),
    ];
    let h = build(&prims, 2).unwrap();
    assert_eq!((h.grid.h1, h.grid.res(1), h.grid.res(2)), (1.0, 3, 2));
    // Level 1: cell (0, 0, 1) at t = (1/2, 1/4, 1/2): eight vertices.
    assert_eq!(h.lights.iter().filter(|g| g.level == 1).count(), 8);
    let t = Vec3::new(0.25, 0.125, 0.75);
    for delta in 0..8u32 {
        let v = [delta & 1, (delta >> 1) & 1, (delta >> 2) & 1];
        let g = h.light_at(2, v).expect("every coarse corner holds light");
        let want = Vec3::new(0.0, 0.0, 8.0 * LghGrid::trilinear(t, delta));
        assert!(
            close(Vec3::from(g.e), want),
            "vertex {v:?}: {:?} vs {want}",
            g.e
        );
        let c = g.centre(h.grid.vertex_pos(2, v));
        assert!(
            close(c, Vec3::from(prims[1].p0)),
            "vertex {v:?}: centre {c}"
        );
    }
}

/// Lights sorted by (level-1 cell, id) and each cell's range, worked by
/// hand on L = 2 (2 × 2 × 2 cells of side 1 over (0,0,0)–(2,2,2)).
#[test]
fn lights_sort_by_cell_then_id() {
    let at = |x: f32, y: f32, z: f32| LightPrim::point(Vec3::new(x, y, z), Vec3::ONE);
    let prims = [
        at(2.0, 2.0, 2.0), // cell (1, 1, 1) = 7
        at(0.5, 0.5, 0.5), // cell 0
        at(1.5, 0.5, 0.5), // cell 1
        at(0.0, 0.0, 0.0), // cell 0
        at(0.5, 1.5, 1.5), // cell (0, 1, 1) = 6
        LightPrim::triangle(Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE),
    ];
    let h = build(&prims, 2).unwrap();
    assert_eq!(h.sorted, vec![1, 3, 2, 4, 0, 5]);
    assert_eq!(
        h.cells,
        vec![
            [0, 2],
            [2, 3],
            [0, 0],
            [0, 0],
            [0, 0],
            [0, 0],
            [3, 4],
            [4, 5]
        ]
    );
}

/// `candidates` visits only the lights and grid vertices within reach
/// of the shading point (the cells within α of it at level 0, the
/// vertices within 2α + 1 at the finer levels); it must find exactly
/// what a visit of every light and every vertex of every level finds
/// (the same blending and emitters: equal bits). Points and VPLs
/// scattered over [3, 23]³ (a grid whose origin and cell size are not
/// 0 and 1), shading points inside and just outside the bounds and
/// far outside them, α from below one cell to four, with and without
/// level 0.
#[test]
fn candidates_equal_a_visit_of_everything() {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    let mut rng = StdRng::seed_from_u64(43);
    let v3 = |rng: &mut StdRng, lo: f32, hi: f32| {
        Vec3::new(
            rng.random_range(lo..hi),
            rng.random_range(lo..hi),
            rng.random_range(lo..hi),
        )
    };
    let prims: Vec<LightPrim> = (0..400)
        .map(|i| {
            let p = v3(&mut rng, 3.0, 23.0);
            let e = v3(&mut rng, 0.1, 1.0);
            if i % 2 == 0 {
                LightPrim::point(p, e)
            } else {
                LightPrim::vpl(p, v3(&mut rng, -1.0, 1.0).normalize(), e)
            }
        })
        .collect();
    let h = build(&prims, 4).unwrap();
    let g = &h.grid;
    assert!(
        g.lo.min_element() > 2.0 && g.h1 != 1.0,
        "{:?}, {}",
        g.lo,
        g.h1
    );
    let clamp2 = 0.05;
    let key = |c: &Candidate| (c.level, c.id);
    let mut compared = 0;
    for alpha in [0.4, 1.0, 2.0, 4.0] {
        for level0 in [false, true] {
            let params = LghParams {
                alpha,
                level0,
                ..LghParams::default()
            };
            let first = if level0 { 0 } else { 1 };
            let soft2 = g.soft2(params.clamp);
            for k in 0..40 {
                let x = if k < 30 {
                    v3(&mut rng, 2.5, 23.5)
                } else {
                    v3(&mut rng, -30.0, 56.0)
                };
                let n = v3(&mut rng, -1.0, 1.0).normalize();
                let mut got = h.candidates(&prims, &params, clamp2, x, n);
                // Everything, with the same filter.
                let mut want = Vec::new();
                let mut visit = |level: u32, id: u32, e: Emitter| {
                    let b = g.blend(alpha, first, level, (e.pos - x).length());
                    let f = b * e.eval(x, n);
                    if b > 0.0 && luminance(f) > 0.0 {
                        want.push((level, id, f));
                    }
                };
                if level0 {
                    for (i, l) in prims.iter().enumerate() {
                        visit(0, i as u32, Emitter::light(l, clamp2));
                    }
                }
                for level in 1..=g.levels {
                    let r = g.res(level);
                    for_box([0; 3], [r - 1; 3], |v| {
                        if let Some(gl) = h.light_at(level, v) {
                            let slot = h.index[(g.index_offset(level)
                                + g.vertex_index(level, v) as u64)
                                as usize];
                            visit(
                                level,
                                slot,
                                gl.emitter(g.vertex_pos(level, v), clamp2, soft2),
                            );
                        }
                    });
                }
                got.sort_by_key(key);
                want.sort_by_key(|w| (w.0, w.1));
                let got: Vec<(u32, u32, Vec3)> = got.iter().map(|c| (c.level, c.id, c.f)).collect();
                assert_eq!(got, want, "α {alpha}, level 0 {level0}, x {x}");
                compared += want.len();
            }
        }
    }
    // The comparisons had candidates at every level to miss.
    assert!(compared > 1000, "{compared} candidates");
}

/// The stratified picks, worked by hand: ‖f‖ = 1, 2, 1 (F = 4) with
/// s = 4 and ξ = 1/2 aim at 0.5, 1.5, 2.5, 3.5 of the running sums 1,
/// 3, 4; ξ = 0 at 0, 1, 2, 3 (a target equal to a running sum goes to
/// the next candidate); a candidate holding a whole number of strata
/// (s·‖f‖/F) gets that many picks for every ξ, and a lone one every
/// pick; no candidate or F = 0 gives no pick; a target that rounding
/// puts at F goes to the last candidate. (Moved here from
/// `tests/lights_cpu/`, whose cases it keeps.)
#[test]
fn picks_follow_the_running_sum() {
    let c = |lum: f32| Candidate {
        f: Vec3::splat(lum),
        lum,
        pos: Vec3::ZERO,
        sigma: Vec3::ZERO,
        level: 1,
        id: 0,
    };
    let cands = [c(1.0), c(2.0), c(1.0)];
    assert_eq!(pick(&cands, 4, 0.5), vec![0, 1, 1, 2]);
    assert_eq!(pick(&cands, 4, 0.0), vec![0, 1, 1, 2]);
    assert_eq!(pick(&cands, 2, 0.0), vec![0, 1]);
    assert_eq!(pick(&cands, 2, 0.75), vec![1, 2]);
    assert_eq!(pick(&cands, 1, 0.3), vec![1]);
    assert_eq!(pick(&cands, 4, 0.999_999), vec![0, 1, 1, 2]);
    assert_eq!(pick(&cands, 8, 0.5), vec![0, 0, 1, 1, 1, 1, 2, 2]);
    assert_eq!(pick(&cands[..1], 3, 0.5), vec![0, 0, 0]);
    // ξ just below 1: k + ξ rounds to k + 1 for k ≥ 1, so the last
    // target is F itself, which no running sum exceeds; the last
    // candidate takes it.
    let xi = 1.0 - f32::EPSILON / 2.0;
    assert_eq!(3.0 + xi, 4.0);
    assert_eq!(pick(&cands, 4, xi), vec![0, 1, 2, 2]);
    assert_eq!(pick(&[], 4, 0.5), Vec::<usize>::new());
    assert_eq!(pick(&[c(0.0), c(0.0)], 2, 0.5), Vec::<usize>::new());
}

/// Each coarse level gathers from the fine vertices within three of
/// twice its own (a fine grid light's centre lies within one fine cell
/// of its vertex, so no other can reach a coarse vertex's cells): the
/// gathers must equal, bit for bit, gathers over *every* fine vertex
/// in the same (z-major) order. 600 points and VPLs, five levels, so
/// that levels 2–5 have vertices far from the origin on every axis.
#[test]
fn coarse_gathers_equal_gathers_over_every_fine_vertex() {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    let mut rng = StdRng::seed_from_u64(53);
    let prims: Vec<LightPrim> = (0..600)
        .map(|i| {
            let p = Vec3::new(rng.random(), rng.random(), rng.random()) * 16.0;
            let e = Vec3::new(rng.random(), rng.random(), rng.random()) + Vec3::splat(0.1);
            if i % 2 == 0 {
                LightPrim::point(p, e)
            } else {
                let n = Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
                LightPrim::vpl(p, n.normalize(), e)
            }
        })
        .collect();
    let h = build(&prims, 5).unwrap();
    let g = &h.grid;
    assert_eq!(g.levels, 5);
    let mut compared = 0;
    for level in 2..=g.levels {
        let fine = g.res(level - 1);
        let r = g.res(level);
        for_box([0; 3], [r - 1; 3], |v| {
            let vpos = g.vertex_pos(level, v);
            let mut acc = GridLight::default();
            for_box([0; 3], [fine - 1; 3], |u| {
                let Some(fl) = h.light_at(level - 1, u) else {
                    return;
                };
                let upos = g.vertex_pos(level - 1, u);
                let (cell, t) = g.cell_of(level, fl.centre(upos));
                let d = [0, 1, 2].map(|a| v[a].wrapping_sub(cell[a]));
                if d.iter().all(|&x| x <= 1) {
                    let delta = d[0] + 2 * d[1] + 4 * d[2];
                    acc.add_grid(LghGrid::trilinear(t, delta), fl, upos - vpos);
                }
            });
            match h.light_at(level, v) {
                Some(got) => {
                    let want = GridLight {
                        vertex: g.vertex_index(level, v),
                        level,
                        ..acc
                    };
                    assert_eq!(*got, want, "level {level}, vertex {v:?}");
                    compared += 1;
                }
                None => assert!(acc.w <= 0.0, "level {level}, vertex {v:?} lost its light"),
            }
        });
    }
    assert!(compared > 100, "{compared} grid lights compared");
}

/// The paper's construction ([`Coarse::FromS1`]): every coarse level is
/// gathered from S₁'s grid lights, so its vertex search box must lose
/// none — each grid light equals, bit for bit, a gather over *every* S₁
/// vertex in the same order — and level 2 is the cascade's (S₁ is the
/// level below it), while coarser levels differ from it.
#[test]
fn levels_from_s1_gather_every_s1_grid_light() {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    let mut rng = StdRng::seed_from_u64(71);
    let prims: Vec<LightPrim> = (0..600)
        .map(|_| {
            let p = Vec3::new(rng.random(), rng.random(), rng.random()) * 16.0;
            let e = Vec3::new(rng.random(), rng.random(), rng.random()) + Vec3::splat(0.1);
            LightPrim::point(p, e)
        })
        .collect();
    let h = build_with(&prims, 5, Coarse::FromS1).unwrap();
    let cascade = build(&prims, 5).unwrap();
    let g = &h.grid;
    let r1 = g.res(1);
    let mut compared = 0;
    let mut differ = 0;
    for level in 2..=g.levels {
        let r = g.res(level);
        for_box([0; 3], [r - 1; 3], |v| {
            let vpos = g.vertex_pos(level, v);
            let mut acc = GridLight::default();
            for_box([0; 3], [r1 - 1; 3], |u| {
                let Some(fl) = h.light_at(1, u) else {
                    return;
                };
                let upos = g.vertex_pos(1, u);
                let (cell, t) = g.cell_of(level, fl.centre(upos));
                let d = [0, 1, 2].map(|a| v[a].wrapping_sub(cell[a]));
                if d.iter().all(|&x| x <= 1) {
                    let delta = d[0] + 2 * d[1] + 4 * d[2];
                    acc.add_grid(LghGrid::trilinear(t, delta), fl, upos - vpos);
                }
            });
            let got = h.light_at(level, v);
            match got {
                Some(got) => {
                    let want = GridLight {
                        vertex: g.vertex_index(level, v),
                        level,
                        ..acc
                    };
                    assert_eq!(*got, want, "level {level}, vertex {v:?}");
                    compared += 1;
                }
                None => assert!(acc.w <= 0.0, "level {level}, vertex {v:?} lost its light"),
            }
            let other = cascade.light_at(level, v);
            if level == 2 {
                assert_eq!(got, other, "level 2 is gathered from S₁ either way");
            } else if got != other {
                differ += 1;
            }
        });
    }
    assert!(compared > 100, "{compared} grid lights compared");
    assert!(differ > 0, "levels 3-5 from S₁ differ from the cascade");
}
