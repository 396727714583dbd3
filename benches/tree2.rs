//! The two-level light tree's per-frame CPU build (`tree2`), on the
//! scenes it is for: `cornell_lights` (12 keyframed mesh lights of 1,000
//! triangles, rigid motion) and `street_lights` (56 static mesh lights of
//! 2–224 triangles). Two ways to build a frame's tree from its lights:
//!
//! * **sort every frame** — [`two_level::build`]: every group's Morton
//!   codes and sort, then the bottom levels gathered, the top level, the
//!   flattening;
//! * **sorted once** — [`two_level::BottomLevels::tree`]: the groups' leaf orders
//!   sorted once in object space ([`scene_lights::bottom_levels`], timed
//!   apart as "once"), each frame only the gathers, the top level and the
//!   flattening (what `mdas render --frames` does per frame).
//!
//! Method: the lights of 8 frame times (t = 0, 0.5, …, 3.5) are computed
//! first; then `ROUNDS` rounds, each building all 8 frames both ways,
//! alternating which way goes first; the figure is the median per frame
//! over rounds, and the ratio of the medians. CPU only (no adapter).
//! Run: `cargo bench --bench tree2`.

use mdas::lights::scene_lights::{self, light_groups, light_prims};
use mdas::lights::two_level;
use mdas::lights::LightPrim;
use mdas::scene_file;
use std::path::Path;
use std::time::Instant;

const ROUNDS: usize = 31;
const FRAMES: usize = 8;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    // `cargo bench` passes `--bench` (and any filter): nothing to parse.
    println!("| scene | lights | groups | shared orders | once (ms) | sort every frame (ms/frame) | sorted once (ms/frame) | ratio |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for name in ["cornell_lights", "street_lights"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml"));
        let file = scene_file::load(&path).expect("scene loads");
        let scene = &file.scene;
        let groups = light_groups(scene);
        let frames: Vec<Vec<LightPrim>> = (0..FRAMES)
            .map(|f| light_prims(scene, 0.5 * f as f32))
            .collect();
        let start = Instant::now();
        let bottoms = scene_lights::bottom_levels(scene);
        let once = start.elapsed().as_secs_f64() * 1e3;
        let (mut full, mut kept) = (Vec::new(), Vec::new());
        for round in 0..ROUNDS {
            let time = |sorted_once: bool| {
                let start = Instant::now();
                for prims in &frames {
                    let t = if sorted_once {
                        bottoms.tree(prims)
                    } else {
                        two_level::build(prims, &groups)
                    };
                    std::hint::black_box(t);
                }
                start.elapsed().as_secs_f64() * 1e3 / FRAMES as f64
            };
            if round % 2 == 0 {
                full.push(time(false));
                kept.push(time(true));
            } else {
                kept.push(time(true));
                full.push(time(false));
            }
        }
        // The same trees both ways where nothing moves (a check, not a
        // figure: the tests prove it).
        if name == "street_lights" {
            assert_eq!(
                bottoms.tree(&frames[0]),
                two_level::build(&frames[0], &groups)
            );
        }
        let (f, k) = (median(full), median(kept));
        println!(
            "| `{name}` | {} | {} | {} | {once:.2} | {f:.2} | {k:.2} | {:.2} |",
            frames[0].len(),
            groups.len(),
            bottoms.shared_orders(),
            k / f
        );
    }
}
