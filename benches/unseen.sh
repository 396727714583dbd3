#!/usr/bin/env bash
# The battery of scenes nobody tuned (issue 48): MDAS with its defaults
# (no [mdas] table: `MdasParams::for_film`) against Halton on scenes that
# `mdas scene random` generates, at equal samples and — from the same
# renders and `tune`'s time fit — at equal time.
#
# For each integrand and each of its fixed seeds: generate the scene
# (128×96), then one `mdas tune SCENE --equal-samples --grid alpha=2`
# per budget in SPPS (a one-row grid: the default α, AUTO_ALPHA in
# src/integrator/mdas/params.rs, so the scene's own defaults; GRID sets
# other rows), 3 seeds per method, a cached Halton reference
# of REF_SPP samples per pixel. `benches/unseen_summary.py` then prints
# per integrand and budget: the win rate (MDAS's mean RelMSE ≤ Halton's
# at the same spp), the geometric mean of the RelMSE ratio with a 95 %
# bootstrap interval over scenes, the worst scene, MDAS's mean |relative
# bias| (G channel) and the equal-time ratio (MDAS's RelMSE over Halton's
# interpolated log-log at the spp Halton reaches in MDAS's time; beyond
# 4× the budget, extrapolated along the last segment, and counted).
# Timings need a quiet machine: run nothing else beside it.
#
#   benches/unseen.sh                         all of it (hours on 2 cores)
#   N=4 SPPS="8" INTEGRANDS="motion_blur path" benches/unseen.sh
#   RESUME=1 benches/unseen.sh                keeps the scenes and budgets
#                                             already measured in OUT
#   PART=3/8 benches/unseen.sh                only jobs ⌊2·J/8⌋ .. ⌊3·J/8⌋
#                                             of the J (scene, budget) jobs,
#                                             no summary (a job array:
#                                             scripts/slurm/, docs/cluster.md)
#
# Outputs in OUT (default out/unseen): scenes/, one tune directory per
# scene and budget, jobs.txt (the settings and every job, which the
# summary checks are all there), battery.json and battery.md (the summary).
# MDAS=path/to/mdas uses that binary instead of building one.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ -z "${MDAS:-}" ]; then
    cargo build --release --quiet
    MDAS=target/release/mdas
fi
mdas=$MDAS
out=${OUT:-out/unseen}
n=${N:-8}
spps=${SPPS:-8 32}
ref_spp=${REF_SPP:-2048}
seeds=${SEEDS:-3}
integrands=${INTEGRANDS:-area_light depth_of_field motion_blur path}
# The grid of `tune` (default: one row, α at its default AUTO_ALPHA = 2,
# so the scene's own defaults; until 2026-12-07 this said 0.25, the
# default before the paced selection); GRID="alpha=0.25,1 pixel_prior=0,1" compares variants.
grid=${GRID:-alpha=2}
# Further `tune` flags for every row (e.g. FLAGS="--max-samples-per-leaf 6").
flags=${FLAGS:-}
# Scene seeds, fixed so that a run is reproducible: the first N of these.
scene_seeds=(101 202 303 404 505 606 707 808 909 1010 1111 1212 1313 1414 1515 1616)
mkdir -p "$out/scenes"
# Every job, in order, after the settings that make them one battery: a
# part (PART=I/N) runs its contiguous share, and parts sharing OUT must
# agree on this list (the summary refuses a battery with a job missing).
jobs=$(
    echo "# settings: ref_spp=$ref_spp seeds=$seeds grid=$grid flags=$flags"
    for t in $integrands; do
        for k in "${scene_seeds[@]:0:$n}"; do
            for spp in $spps; do echo "$t $k $spp"; done
        done
    done
)
if [ -f "$out/jobs.txt" ] && [ "$(cat "$out/jobs.txt")" != "$jobs" ]; then
    echo "$out/jobs.txt lists another battery (other settings or jobs): use another OUT" >&2
    exit 1
fi
tmp=$(mktemp "$out/.jobs.XXXXXX")
echo "$jobs" > "$tmp" && mv "$tmp" "$out/jobs.txt"
total=$(grep -vc '^#' "$out/jobs.txt")
first=0 end=$total
if [ -n "${PART:-}" ]; then
    i=${PART%/*} count=${PART#*/}
    if ! [[ $i =~ ^[0-9]+$ && $count =~ ^[0-9]+$ ]] || ((i < 1 || i > count || count > total)); then
        echo "PART=$PART is not a part I/N with 1 ≤ I ≤ N ≤ $total (jobs)" >&2
        exit 1
    fi
    first=$(( (i - 1) * total / count )) end=$(( i * total / count ))
fi
index=0
failed=0
while read -r t k spp; do
    index=$((index + 1))
    ((index > first && index <= end)) || continue
    scene="$out/scenes/$t-$k.toml"
    # Generation is deterministic; parts may write the same scene (atomically).
    [ -f "$scene" ] || $mdas -q scene random --integrand "$t" --seed "$k" -o "$scene"
    dir="$out/$t-$k-$spp"
    if [ -n "${RESUME:-}" ] && [ -f "$dir/tune.json" ]; then
        continue # RESUME=1: a scene and budget already measured
    fi
    echo "== $t seed $k, $spp spp $(date -u +%H:%M:%S)"
    $mdas -q tune "$scene" --spp "$spp" --equal-samples --seeds "$seeds" \
        --ref-spp "$ref_spp" $(printf -- '--grid %s ' $grid) $flags --out "$dir" \
        > "$dir.log" 2>&1 || { echo "   failed: see $dir.log"; failed=$((failed + 1)); }
done < <(grep -v '^#' "$out/jobs.txt")
if [ -n "${PART:-}" ]; then
    echo "part $PART: jobs $((first + 1))..$end of $total done, $failed failed"
    exit $((failed > 0))
fi
python3 benches/unseen_summary.py "$out" | tee "$out/battery.md"
