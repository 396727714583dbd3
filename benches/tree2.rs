//! The two-level light tree's per-frame build (`tree2`), on the scenes it
//! is for: `cornell_lights` (12 keyframed mesh lights of 1,000 triangles,
//! rigid motion) and `street_lights` (56 static mesh lights of 2–224
//! triangles). Three ways to build a frame's tree from its lights:
//!
//! * **sort every frame** — [`two_level::build`]: every group's Morton
//!   codes and sort, then the bottom levels gathered, the top level, the
//!   flattening;
//! * **sorted once** — [`two_level::BottomLevels::tree`]: the groups' leaf orders
//!   sorted once in object space ([`scene_lights::bottom_levels`], timed
//!   apart as "once"), each frame only the gathers, the top level and the
//!   flattening (what `mdas render --frames` did per frame before the GPU
//!   gather, and still does for scenes with VPLs or orbiting light sets);
//! * **GPU gather** — [`GpuTwoLevel::build`] (what `mdas render --frames`
//!   does now): the frame's lights uploaded, the bottom levels gathered on
//!   the GPU (`tree2.bottom`, GPU time), the roots read back and the top
//!   level built and written on the host (`tree2.top`, wall clock with the
//!   read-back wait); "wall" is the whole build to a device sync.
//!
//! Method: the lights of 8 frame times (t = 0, 0.5, …, 3.5) are computed
//! first; then `ROUNDS` rounds, each building all 8 frames the three ways,
//! rotating which way goes first; the figure is the median per frame over
//! rounds, and the ratio of the medians. The GPU is the process's adapter
//! (lavapipe without a GPU), warmed by one build before timing.
//! Run: `cargo bench --bench tree2`.

use mdas::gpu::buffer::STORAGE;
use mdas::gpu::{Gpu, Profiler};
use mdas::lights::scene_lights::{self, light_groups, light_prims};
use mdas::lights::two_level;
use mdas::lights::two_level::gpu::{GpuTwoLevel, PHASES};
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
    let gpu = Gpu::shared().expect("a GPU adapter (lavapipe without a GPU)");
    let mut rows = Vec::new();
    let mut gpu_rows = Vec::new();
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
        let two_level = GpuTwoLevel::new(gpu, bottoms.gpu_plan().expect("groups keep their shape"))
            .expect("the GPU holds the tree");
        let buffer = gpu
            .buffer_zeroed("bench.tree2.lights", 64 * frames[0].len() as u64, STORAGE)
            .expect("a light buffer");
        // One GPU frame: (wall ms to a device sync, GPU bottom ms, host top ms).
        let gpu_frame = |prims: &[LightPrim]| {
            let start = Instant::now();
            gpu.queue
                .write_buffer(&buffer, 0, bytemuck::cast_slice(prims));
            let mut profiler = Profiler::new(gpu);
            two_level
                .build(gpu, &buffer, &mut profiler)
                .expect("GPU build");
            let times = profiler.finish().expect("phase times");
            gpu.wait().expect("device sync");
            let get = |p: &str| times.get(p).unwrap_or(f64::NAN);
            (
                start.elapsed().as_secs_f64() * 1e3,
                get(PHASES[0]),
                get(PHASES[1]),
            )
        };
        gpu_frame(&frames[0]); // warm-up: pipelines compile at their first dispatch
        let (mut full, mut kept, mut wall, mut bottom, mut top) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for round in 0..ROUNDS {
            for way in 0..3 {
                match (way + round) % 3 {
                    0 | 1 => {
                        let sorted_once = (way + round) % 3 == 1;
                        let start = Instant::now();
                        for prims in &frames {
                            let t = if sorted_once {
                                bottoms.tree(prims)
                            } else {
                                two_level::build(prims, &groups)
                            };
                            std::hint::black_box(t);
                        }
                        let ms = start.elapsed().as_secs_f64() * 1e3 / FRAMES as f64;
                        if sorted_once {
                            kept.push(ms)
                        } else {
                            full.push(ms)
                        }
                    }
                    _ => {
                        for prims in &frames {
                            let (w, b, t) = gpu_frame(prims);
                            wall.push(w);
                            bottom.push(b);
                            top.push(t);
                        }
                    }
                }
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
        rows.push(format!(
            "| `{name}` | {} | {} | {} | {once:.2} | {f:.2} | {k:.2} | {:.2} |",
            frames[0].len(),
            groups.len(),
            bottoms.shared_orders(),
            k / f
        ));
        let w = median(wall);
        gpu_rows.push(format!(
            "| `{name}` | {} | {} | {:.3} | {:.3} | {w:.3} | {k:.2} | {:.2} |",
            frames[0].len(),
            two_level.plan().joins.len() + 1,
            median(bottom),
            median(top),
            w / k
        ));
    }
    println!("CPU build per frame:\n");
    println!("| scene | lights | groups | shared orders | once (ms) | sort every frame (ms/frame) | sorted once (ms/frame) | ratio |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        println!("{r}");
    }
    println!("\nGPU gather per frame ({}):\n", gpu.info.name);
    println!("| scene | lights | dispatches | tree2.bottom GPU (ms) | tree2.top host (ms) | wall (ms) | CPU sorted once (ms) | wall / CPU |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in gpu_rows {
        println!("{r}");
    }
}
