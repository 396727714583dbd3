#!/usr/bin/env bash
# Submits a sweep, a tune search or the battery as an N-task job array and
# its dependent merge (issue 52):
#   scripts/slurm/submit-run.sh sweep|tune SCENE N OUTDIR OUT [MDAS OPTIONS...]
#   scripts/slurm/submit-run.sh battery N OUT
# e.g. scripts/slurm/submit-run.sh sweep scenes/pool.toml 6 parts/pool out/sweep-pool --spps 4,8,16 --ref-spp 4096
# Options for sbatch (both jobs) go in SBATCH_OPTIONS, e.g.
# SBATCH_OPTIONS="--gres=gpu:1 --partition=gpu". The battery takes its
# settings from the environment (N_SCENES, SPPS, REF_SPP, SEEDS,
# INTEGRANDS, GRID, FLAGS: benches/unseen.sh) and runs from here, the
# repository root, which the nodes must share.
set -euo pipefail
here=$(dirname "$0")
read -r -a opts <<< "${SBATCH_OPTIONS:-}"
kind=${1:?sweep, tune or battery}
if [ "$kind" = battery ]; then
    n=${2:?parts}; out=${3:?output directory}
    array=$(OUT=$out sbatch --parsable --array=1-"$n" --export=ALL "${opts[@]}" "$here/battery.sbatch")
    array=${array%%;*}
    merge=$(sbatch --parsable --dependency=afterok:"$array" "${opts[@]}" "$here/battery-summary.sbatch" "$out")
    echo "battery array job $array ($n parts), summary job $merge"
    exit 0
fi
scene=${2:?scene}; n=${3:?parts}; outdir=${4:?parts directory}; out=${5:?merged output directory}
shift 5
array=$(sbatch --parsable --array=1-"$n" "${opts[@]}" "$here/run.sbatch" "$kind" "$scene" "$outdir" "$@")
array=${array%%;*}
merge=$(sbatch --parsable --dependency=afterok:"$array" "${opts[@]}" "$here/merge-run.sbatch" "$outdir" "$out")
echo "$kind array job $array ($n parts), merge job $merge"
