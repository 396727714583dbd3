#!/usr/bin/env bash
# Every GPU benchmark of the MDAS kernels in one command (issue 10), for a
# machine with a real GPU (it runs on lavapipe too, slowly):
#   1. `mdas bench` at 1/4 scale on cornell_pt, pool and cornell: MDAS's
#      phases against Halton at equal samples (warm, interleaved, medians);
#   2. the same on the paper's seven scenes at their full film size and
#      spp (Table 1 of the MDAS paper sits beside them in BENCHMARKS.md);
#   3. `mdas compare` (equal time) on cornell_pt and pool at 1/4 scale,
#      and at full film size with a REF_SPP_FULL reference;
#   4. the light samplers at equal time on vpl_atrium (100,000 VPLs made
#      per frame), stochastic substitute trees among them (issue 13), at
#      1/4 and full scale, and `sst`'s bias over seeds;
#   5. the lighting grid hierarchy (issue 14): equal time on lights_1m, its
#      bias over seeds, its GPU build and its cost per sample;
#   6. voxel visibility (issue 15): build, memory, shadow queries per
#      second and ε_v / ε_s against the BVH, the voxel render against the
#      BVH render, and `compare --visibility voxel` on vpl_atrium;
#   7. the light trees (issue 12): uniform, tree, tree_cone, unbalanced and
#      tree2 at equal time on cornell_lights (full size, 4x and 1/4; the
#      target is MSE uniform / tree_cone >= 2.4) and on street_lights
#      (sparse mesh lights, full size), per-frame build and sample times
#      over a frame sequence of cornell_lights, tree2's per-frame build
#      (its bottom levels gathered on the GPU against the CPU builds:
#      `cargo bench --bench tree2`), and the GPU tree build of 1k-1M
#      lights with and without cones (`cargo bench --bench light_tree`).
#   8. the open issues' figures (65, 66): `mdas compare` (Halton, MDAS and
#      pixel-adaptive Halton at equal samples and at equal time) on the
#      paper's seven scenes at full film size, and `tree` against
#      `tree_nocut` at equal light-sample count with the same camera
#      samples (benches/cuts_equal_count.sh, PROTOCOL=shared) on
#      vpl_atrium at full size, one sample per pixel, n = 4, 8, 16, 32.
#      A short lease runs it first: STEPS="8 1 2".
# With a baseline binary (another build of mdas that has `bench`), steps 1
# and 2 also run it, right after the same step of this build.
#
#   benches/gpu.sh [OUT] [MDAS_BINARY] [BASELINE_BINARY]
#
# OUT: out/gpu-bench by default; its *.md tables and *.json figures are
# what BENCHMARKS.md records. MDAS_BINARY: target/release/mdas, built when
# missing. Environment: REPEATS (default 5), REF_SPP (compare's reference
# at 1/4 scale, default 16384), REF_SPP_FULL (at full size, default 4096),
# QUICK=1 (lavapipe smoke run: 1/16 scale, 1 repeat, references of 256 spp),
# STEPS (the steps to run, in that order; default "1 2 3 4 5 6 7 8"),
# BENCH_BINS (a folder of prebuilt bench executables named light_tree,
# light_sampling, visibility and tree2, for a machine without cargo: `cargo bench
# --no-run` prints where cargo put them; default: `cargo bench`),
# SKIP_BENCHES (names of those benches not to run).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/gpu-bench}
BIN=${2:-target/release/mdas}
BASE=${3:-}
[ -x "$BIN" ] || cargo build --release
mkdir -p "$OUT"

QUARTER="scenes/cornell_pt.toml scenes/pool.toml scenes/cornell.toml"
PAPER="scenes/pool.toml scenes/chess.toml scenes/street.toml scenes/dragon.toml scenes/cobblestone.toml scenes/cornell_pt.toml scenes/breakfast.toml"
REPEATS=${REPEATS:-5}
REF_SPP=${REF_SPP:-16384}
REF_SPP_FULL=${REF_SPP_FULL:-4096}
QUARTER_SCALE=0.25
FULL_SCALE=1
LARGE_SCALE=4
if [ "${QUICK:-0}" = 1 ]; then
    REPEATS=1 REF_SPP=256 REF_SPP_FULL=256 QUARTER_SCALE=0.0625 FULL_SCALE=0.0625 LARGE_SCALE=0.25
fi

step() {
    local name=$1
    shift
    echo "== $name: $*" >&2
    local start=$SECONDS
    "$@" >"$OUT/$name.md"
    echo "   $((SECONDS - start)) s" >&2
    cat "$OUT/$name.md"
}

"$BIN" info | tee "$OUT/info.txt"
# A criterion bench: prebuilt in BENCH_BINS, else through cargo; skipped
# when SKIP_BENCHES names it (a rerun of steps whose benches already ran).
run_bench() {
    case " ${SKIP_BENCHES:-} " in
        *" $1 "*)
            echo "(bench $1 skipped: SKIP_BENCHES)"
            return
            ;;
    esac
    if [ -n "${BENCH_BINS:-}" ]; then
        "$BENCH_BINS/$1" --bench
    else
        cargo bench --bench "$1"
    fi
}
bench() {
    local name=$1 scale=$2
    shift 2
    step "$name" "$BIN" bench "$@" --scale "$scale" --repeats "$REPEATS" --json-out "$OUT/$name.json"
    if [ -n "$BASE" ]; then
        # Builds before 2026-11-30 call the file flag --json.
        local flag=--json-out
        "$BASE" bench --help | grep -q -- --json-out || flag=--json
        step "$name-baseline" "$BASE" bench "$@" --scale "$scale" --repeats "$REPEATS" "$flag" "$OUT/$name-baseline.json"
    fi
}
# Each step writes its own files under OUT; STEPS picks which run, in
# which order (a short device lease puts the open issue's step first).
step1() {
    # shellcheck disable=SC2086 # the scene lists are word lists
    bench quarter "$QUARTER_SCALE" $QUARTER
}
step2() {
    # shellcheck disable=SC2086
    bench paper-full "$FULL_SCALE" $PAPER
}
step3() {
    for scene in cornell_pt pool; do
        step "compare-$scene" "$BIN" compare "scenes/$scene.toml" --scale "$QUARTER_SCALE" \
            --ref-spp "$REF_SPP" --repeats "$REPEATS" --out "$OUT/compare-$scene"
        step "compare-$scene-full" "$BIN" compare "scenes/$scene.toml" --scale "$FULL_SCALE" \
            --ref-spp "$REF_SPP_FULL" --repeats "$REPEATS" --out "$OUT/compare-$scene-full"
    done
}
step4() {
    SAMPLERS=power,tree_nocut,tree,tree_cone,unbalanced,sst,sst_nosub,lgh
    step "samplers-vpl_atrium" "$BIN" compare scenes/vpl_atrium.toml --samplers "$SAMPLERS" \
        --scale "$QUARTER_SCALE" --ref-spp "$REF_SPP" --repeats "$REPEATS" --out "$OUT/samplers-vpl_atrium"
    step "samplers-vpl_atrium-full" "$BIN" compare scenes/vpl_atrium.toml --samplers "$SAMPLERS" \
        --scale "$FULL_SCALE" --ref-spp "$REF_SPP_FULL" --repeats "$REPEATS" --out "$OUT/samplers-vpl_atrium-full"
    step "sst-bias-vpl_atrium" "$BIN" compare scenes/vpl_atrium.toml --sampler sst --seeds 8 --spp 16 \
        --scale "$QUARTER_SCALE" --ref-spp "$REF_SPP" --repeats "$REPEATS" --out "$OUT/sst-bias-vpl_atrium"
}
step5() {
    # The lighting grid hierarchy (issue 14): equal time against the trees on
    # lights_1m, its bias over seeds on both scenes (MDAS needs 128 spp on the
    # atrium: lgh with its skylight has 9 dimensions), and its build for 1k–1M
    # lights with the per-sample cost at S = 0, 1, 4, 16 (the two criterion
    # benches; their tables go to stderr).
    step "samplers-lights_1m" "$BIN" compare scenes/lights_1m.toml --samplers tree,tree_cone,lgh \
        --scale "$QUARTER_SCALE" --ref-spp "$REF_SPP" --repeats "$REPEATS" --out "$OUT/samplers-lights_1m"
    step "lgh-bias-vpl_atrium" "$BIN" compare scenes/vpl_atrium.toml --sampler lgh --seeds 8 --spp 128 \
        --scale "$QUARTER_SCALE" --ref-spp "$REF_SPP" --repeats "$REPEATS" --out "$OUT/lgh-bias-vpl_atrium"
    step "lgh-bias-lights_1m" "$BIN" compare scenes/lights_1m.toml --sampler lgh --seeds 8 --spp 16 \
        --scale "$QUARTER_SCALE" --ref-spp "$REF_SPP" --repeats "$REPEATS" --out "$OUT/lgh-bias-lights_1m"
    if [ "${QUICK:-0}" != 1 ]; then
        # The lighting grid's per-sample cost (its build is step 7's bench).
        MDAS_BENCH_SCALE=$FULL_SCALE run_bench light_sampling 2>&1 | tee "$OUT/light-sampling.txt"
    fi
}
step6() {
    # Voxel visibility (issue 15): build, memory, shadow queries per second
    # against the BVH and ε_v / ε_s on the test and many-light scenes and on
    # dragon_lights (1.31M triangles, 1,024 lights), at the default array and
    # at the paper's 2°, 128³ (which a real GPU's storage binding holds); then
    # the voxel render against the BVH render, same seed, and MDAS vs Halton
    # with voxel shadows against the exact reference.
    VIS_CONFIGS="30x64 22x128 90x128"
    [ "${QUICK:-0}" = 1 ] && VIS_CONFIGS="12x32"
    # (The bench reads its settings from the environment.)
    export CONFIGS="$VIS_CONFIGS" REPEATS SCALE="$QUARTER_SCALE" \
        SCENES="scenes/tests/box_shadow.toml scenes/cornell_lights.toml scenes/vpl_atrium.toml scenes/dragon_lights.toml"
    step "visibility" run_bench visibility
    "$BIN" render scenes/vpl_atrium.toml --integrator halton --scale "$QUARTER_SCALE" --spp 64 --seed 1 \
        --warmup -o "$OUT/vpl_atrium-bvh64.exr" 2>&1 | tee "$OUT/vpl_atrium-bvh64.txt"
    "$BIN" render scenes/vpl_atrium.toml --integrator halton --scale "$QUARTER_SCALE" --spp 64 --seed 1 \
        --warmup --visibility voxel --reference "$OUT/vpl_atrium-bvh64.exr" \
        -o "$OUT/vpl_atrium-voxel64.exr" 2>&1 | tee "$OUT/vpl_atrium-voxel-vs-bvh.txt"
    step "compare-vpl_atrium-voxel" "$BIN" compare scenes/vpl_atrium.toml --visibility voxel \
        --scale "$QUARTER_SCALE" --ref-spp "$REF_SPP" --repeats "$REPEATS" --out "$OUT/compare-vpl_atrium-voxel"
}
step7() {
    # The light trees (issue 12): the samplers at equal time (MDAS + tree sets
    # the time) on cornell_lights at full size, 4x and 1/4 and on
    # street_lights at full size, then a 64-frame sequence of cornell_lights per tree kind
    # (X.frames.csv: each frame's light build, cut pass and render times),
    # then tree2's per-frame build (GPU gather against the CPU), then every
    # size of the perfect tree's GPU build without and with cones and the
    # lighting grid's build (issue 14).
    TREES=uniform,tree,tree_cone,unbalanced,tree2
    # Each sampler's bracketing budgets over 4 seeds: means with 95 %
    # intervals (two in a QUICK run).
    TREE_SEEDS=4
    [ "${QUICK:-0}" = 1 ] && TREE_SEEDS=2
    step "samplers-cornell_lights-full" "$BIN" compare scenes/cornell_lights.toml --samplers "$TREES" --seeds "$TREE_SEEDS" \
        --scale "$FULL_SCALE" --ref-spp "$REF_SPP_FULL" --repeats "$REPEATS" --out "$OUT/samplers-cornell_lights-full"
    # 1024×1024, a film that fills a large GPU (the scene's own 256×256
    # leaves most of it idle), against a reference of REF_SPP_FULL / 2 spp.
    step "samplers-cornell_lights-x4" "$BIN" compare scenes/cornell_lights.toml --samplers "$TREES" --seeds "$TREE_SEEDS" \
        --scale "$LARGE_SCALE" --ref-spp $((REF_SPP_FULL / 2)) --repeats "$REPEATS" --out "$OUT/samplers-cornell_lights-x4"
    step "samplers-street_lights-full" "$BIN" compare scenes/street_lights.toml --samplers "$TREES" --seeds "$TREE_SEEDS" \
        --scale "$FULL_SCALE" --ref-spp "$REF_SPP_FULL" --repeats "$REPEATS" --out "$OUT/samplers-street_lights-full"
    step "samplers-cornell_lights" "$BIN" compare scenes/cornell_lights.toml --samplers "$TREES" --seeds "$TREE_SEEDS" \
        --scale "$QUARTER_SCALE" --ref-spp "$REF_SPP" --repeats "$REPEATS" --out "$OUT/samplers-cornell_lights"
    FRAMES=0..64
    [ "${QUICK:-0}" = 1 ] && FRAMES=0..4
    for kind in tree tree_cone tree2; do
        "$BIN" render scenes/cornell_lights.toml --integrator halton --spp 16 --scale "$FULL_SCALE" \
            --sampler "$kind" --frames "$FRAMES" -o "$OUT/frames-cornell_lights-$kind/frame.exr" \
            2>&1 | tee "$OUT/frames-cornell_lights-$kind.txt"
    done
    run_bench tree2 2>&1 | tee "$OUT/tree2-build.txt"
    if [ "${QUICK:-0}" != 1 ]; then
        run_bench light_tree 2>&1 | tee "$OUT/light-tree-build.txt"
    fi
}

step8() {
    # shellcheck disable=SC2086
    for scene in $PAPER; do
        local name
        name=$(basename "$scene" .toml)
        step "compare-paper-$name" "$BIN" compare "$scene" --scale "$FULL_SCALE" \
            --ref-spp "$REF_SPP_FULL" --repeats "$REPEATS" --out "$OUT/compare-paper-$name"
    done
    local seeds=10 sizes="4 8 16 32"
    [ "${QUICK:-0}" = 1 ] && seeds=2 sizes="4 8"
    BIN=$BIN SCENE=scenes/vpl_atrium.toml SCALE=$FULL_SCALE SPP=1 SIZES="$sizes" SEEDS=$seeds \
        REF_SPP=$REF_SPP_FULL PROTOCOL=shared OUT="$OUT/cuts-vpl_atrium" \
        benches/cuts_equal_count.sh | tee "$OUT/cuts-vpl_atrium.md"
}

for n in ${STEPS:-1 2 3 4 5 6 7 8}; do
    "step$n"
done
