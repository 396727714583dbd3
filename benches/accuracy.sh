#!/usr/bin/env bash
# MDAS against Halton, scene by scene (issue 11's table in BENCHMARKS.md,
# "Where MDAS stands, scene by scene"): for each scene,
#   1. `mdas tune` at the scene's budget over split = extent, contrast,
#      trimmed × reconstruction = box, pixel (the scene's other [mdas]
#      values): RelMSE with its 95% interval and bias per channel at equal
#      samples, and tune's equal-time search column;
#   2. for scenes whose table left Table 1's values, the paper's own
#      configuration (its values, extent split, box reconstruction);
#   3. `mdas compare --uniform` with the scene's own table: the published
#      equal-time ratio (interleaved repeats), MDAS-uniform beside it.
# Equal-time figures need a quiet machine: run nothing else beside it.
#
#   benches/accuracy.sh [SCENE...]      (default: all eight; logs and
#                                        reports in out/accuracy/)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
mdas=target/release/mdas
out=out/accuracy
mkdir -p "$out"

# Film scale per scene: the issue's 1/4 where a 1,024-spp reference takes
# minutes on lavapipe; `cobblestone` and `street` smaller (their references
# at 1/4 would take about 6 and 40 minutes on the 2-core VM). Reference spp,
# and the Table 1 values a scene's table changed (the paper row).
declare -A scale=( [cornell]=0.25 [cornell_pt]=0.25 [pool]=0.25 [chess]=0.25
                   [breakfast]=0.25 [dragon]=0.25 [cobblestone]=0.125 [street]=0.0625 )
declare -A ref=( [cornell]=4096 [cornell_pt]=2048 [pool]=1024 [chess]=1024
                 [breakfast]=1024 [dragon]=1024 [cobblestone]=1024 [street]=1024 )
declare -A paper=( [cornell_pt]="--epsilon 0.01" [pool]="--scale-factor 0.0625"
                   [dragon]="--alpha 0.015625" )

scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(cornell cornell_pt pool chess breakfast dragon cobblestone street)
for s in "${scenes[@]}"; do
    f=${scale[$s]:?unknown scene $s}
    r=${ref[$s]}
    common=(--scale "$f" --ref-spp "$r" --seeds 3 -q)
    echo "== $s (scale $f, reference $r spp) $(date -u +%H:%M:%S)"
    $mdas tune "scenes/$s.toml" "${common[@]}" --equal-samples \
        --grid split=extent,contrast,trimmed --grid reconstruction=box,pixel \
        --out "$out/$s-tune" 2>&1 | tee "$out/$s-tune.log"
    if [ -n "${paper[$s]:-}" ]; then
        # shellcheck disable=SC2086
        $mdas tune "scenes/$s.toml" "${common[@]}" --equal-samples ${paper[$s]} \
            --grid split=extent --grid reconstruction=box \
            --out "$out/$s-paper" 2>&1 | tee "$out/$s-paper.log"
    fi
    $mdas compare "scenes/$s.toml" "${common[@]}" --uniform \
        --out "$out/$s-compare" 2>&1 | tee "$out/$s-compare.log"
done
echo "done $(date -u +%H:%M:%S)"
