#!/usr/bin/env bash
# Issue 49 item 3: sst over the paper's radix tree against sst_perfect
# (and the unbiased sst_nosub), Halton over seeds 1..4 against an
# sst_nosub reference (seed 0), on vpl_spheres (1/2 scale) and vpl_atrium
# (1/4 scale). Prints each sampler's relative bias per channel with its
# 95 % interval and the per-pixel MSE split (benches/seed_bias.py).
# BENCHMARKS.md, "Substitute trees over the paper's radix tree".
# Usage: benches/sst_trees.sh [OUT]   (OUT defaults to out/sst_trees)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/sst_trees}
cargo build --release -q
B=target/release/mdas
bash .ci/mitsuba-venv.sh >/dev/null
PY=target/mitsuba-venv/bin/python
run() { # scene scale ref_spp spp dir
  mkdir -p "$5"
  $B reference "$1" --scale "$2" --spp "$3" --sampler sst_nosub -o "$5/ref.exr" -q
  for seed in 1 2 3 4; do
    for k in sst sst_perfect sst_nosub; do
      $B render "$1" --scale "$2" --integrator halton --spp "$4" --seed $seed \
        --sampler $k -o "$5/$k-$seed.exr" -q
    done
  done
  echo "$1 (scale $2, $4 spp, reference $3 spp):"
  $PY benches/seed_bias.py "$5" sst sst_perfect sst_nosub
}
run scenes/tests/vpl_spheres.toml 0.5 2048 256 "$OUT/vpl_spheres"
run scenes/vpl_atrium.toml 0.25 1024 128 "$OUT/vpl_atrium"
