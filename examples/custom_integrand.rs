//! A custom integrand, compared with MDAS and Halton at equal time against
//! its closed form.
//!
//! The integrand is a motion-blurred edge: over the shutter (its one
//! dimension of its own, t ∈ [0, 1)) the half-plane n·p < c(t) sweeps
//! across a 64×64 film, c(t) = C0 + V·t, coloured `INSIDE` on its side and
//! `OUTSIDE` beyond. A pixel's value is the mean over the pixel and the
//! shutter, which has a closed form: the area a(c) of the unit pixel
//! below the line n·p = c is piecewise quadratic in c (breaks where the line
//! passes a corner), so Simpson's rule between the breaks integrates it
//! over c exactly.
//!
//! ```text
//! cargo run --release --example custom_integrand [OUT_DIR]
//! ```
//!
//! writes the comparison (images, heat maps, `figure.png`, `report.json`)
//! into OUT_DIR (default `out/custom_integrand`) and prints the table of
//! `mdas compare`. It first checks a 1024-spp Halton render against the
//! closed form, so a wrong WGSL or a wrong closed form fails loudly.
//!
//! Expect MDAS to lose at equal time here, by two orders of magnitude on
//! lavapipe: the integrand costs almost nothing, so MDAS's adaptive passes
//! (error, selection, splits) cost far more than Halton's evaluations
//! (BENCHMARKS.md, issue 10: the cheap-integrand bench). At equal samples
//! it wins (RelMSE ratio ≈ 0.9 at 8 spp): adaptive sampling pays where
//! samples are expensive, as with the scenes' ray-traced integrands.

use anyhow::{ensure, Result};
use mdas::compare::{
    compare_integrand, report, Budget, CompareSpec, ReferenceSource, Setup, Subject,
};
use mdas::film::Film;
use mdas::gpu::shader::Wgsl;
use mdas::gpu::Gpu;
use mdas::integrand::{point_wgsl, Integrand};
use mdas::integrator::mdas::MdasParams;
use mdas::integrator::{Halton, Integrator};

/// The edge's unit normal, its offset at t = 0 and its travel over the
/// shutter (raster units).
const NORMAL: [f64; 2] = [0.8, 0.6];
const C0: f64 = 30.0;
const V: f64 = 14.0;
const INSIDE: [f64; 3] = [1.0, 0.8, 0.5];
const OUTSIDE: [f64; 3] = [0.05, 0.05, 0.1];

/// The integrand: no GPU resources of its own, so `layout` and
/// `bind_group` keep their defaults (no bind group 1).
struct MovingEdge {
    film: Film,
}

impl Integrand for MovingEdge {
    fn name(&self) -> &'static str {
        "moving_edge"
    }

    fn dims(&self) -> u32 {
        3
    }

    fn film(&self) -> Film {
        self.film
    }

    fn wgsl(&self) -> Wgsl {
        // The constants go in as text, so the WGSL and the closed form
        // below cannot disagree on them.
        let f = |x: f64| format!("{x:?}");
        let source = format!(
            "fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {{
                let t = (*p).u[0];
                let inside = dot(vec2<f32>({}, {}), (*p).film) < {} + {} * t;
                return select(vec3<f32>({}, {}, {}), vec3<f32>({}, {}, {}), inside);
            }}",
            f(NORMAL[0]),
            f(NORMAL[1]),
            f(C0),
            f(V),
            f(OUTSIDE[0]),
            f(OUTSIDE[1]),
            f(OUTSIDE[2]),
            f(INSIDE[0]),
            f(INSIDE[1]),
            f(INSIDE[2]),
        );
        point_wgsl().part(("moving_edge.wgsl", source))
    }
}

/// Area of the unit pixel [x0, x0 + 1) × [y0, y0 + 1) where n·p < c
/// (`mdas::analytic::half_plane_area`: the square clipped by the line).
fn area_below(x0: f64, y0: f64, c: f64) -> f64 {
    mdas::analytic::half_plane_area([x0, y0], [1.0, 1.0], NORMAL, c)
}

/// The pixel's mean over the shutter: (1/V)∫ a(c) dc over [C0, C0 + V],
/// Simpson's rule on each piece between the corners' offsets (exact for a
/// piecewise quadratic).
fn pixel_mean(i: u32, j: u32) -> [f32; 3] {
    let (x0, y0) = (i as f64, j as f64);
    let mut breaks = vec![C0, C0 + V];
    for (x, y) in [
        (x0, y0),
        (x0 + 1.0, y0),
        (x0 + 1.0, y0 + 1.0),
        (x0, y0 + 1.0),
    ] {
        let c = NORMAL[0] * x + NORMAL[1] * y;
        if c > C0 && c < C0 + V {
            breaks.push(c);
        }
    }
    breaks.sort_by(f64::total_cmp);
    let covered: f64 = breaks
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let m = (a + b) / 2.0;
            (b - a) / 6.0
                * (area_below(x0, y0, a) + 4.0 * area_below(x0, y0, m) + area_below(x0, y0, b))
        })
        .sum::<f64>()
        / V;
    std::array::from_fn(|k| (covered * INSIDE[k] + (1.0 - covered) * OUTSIDE[k]) as f32)
}

fn main() -> Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "out/custom_integrand".into());
    let gpu = Gpu::shared()?;
    let film = Film {
        width: 64,
        height: 64,
    };
    let edge = MovingEdge { film };
    let exact: Vec<[f32; 3]> = (0..film.height)
        .flat_map(|j| (0..film.width).map(move |i| pixel_mean(i, j)))
        .collect();

    // A sanity check before the comparison: Halton converges to the
    // closed form. Measured worst pixel errors: 0.062, 0.017, 0.0084 and
    // 0.0028 at 64, 256, 1024 and 4096 spp, image mean within 2e-5; a
    // wrong closed form or WGSL misses by the edge's contrast (~0.1–0.9).
    let check = Halton::new(1024, 7).render(gpu, &edge)?;
    let worst = check
        .image
        .iter()
        .zip(&exact)
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0f32, f32::max);
    ensure!(
        worst < 0.03,
        "Halton at 1024 spp is {worst} from the closed form"
    );
    println!("Halton at 1024 spp is within {worst:.4} of the closed form everywhere");

    // MDAS at 8 spp sets the time; Halton is searched to the same time.
    let identity = |p| p;
    let spec = CompareSpec::new(
        Setup::new("moving edge", out.clone().into(), &identity),
        Budget::MdasSpp,
    );
    let subject = Subject {
        name: "moving_edge".into(),
        scene_file: None,
        integrand: &edge,
        mdas: MdasParams {
            spp: 8.0,
            ..MdasParams::for_film(film)
        },
        reference: &exact,
        reference_source: ReferenceSource::Exact(
            "closed form (piecewise-quadratic area, Simpson)".into(),
        ),
        sampler: None,
        reference_sampler: None,
        visibility: None,
    };
    let report = compare_integrand(gpu, &spec, &subject)?;
    print!("{}", report::table(&report));
    println!("wrote {out}/");
    Ok(())
}
