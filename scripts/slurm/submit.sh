#!/usr/bin/env bash
# Submits a reference as an N-task job array and its dependent merge:
#   scripts/slurm/submit.sh SCENE SPP N [SCALE] [OUTDIR] [CACHE] [-- SBATCH OPTIONS]
# e.g. scripts/slurm/submit.sh scenes/street.toml 65536 64 1 parts/street .cache/references -- --gres=gpu:1
# The SBATCH OPTIONS go to the array and to the merge job alike.
set -euo pipefail
here=$(dirname "$0")
scene=${1:?scene}; spp=${2:?spp}; n=${3:?parts}
scale=${4:-1}; outdir=${5:-parts}; cache=${6:-.cache/references}
shift $(( $# < 6 ? $# : 6 ))
if [ "${1:-}" = "--" ]; then shift; fi
array=$(sbatch --parsable --array=1-"$n" "$@" "$here/reference.sbatch" "$scene" "$spp" "$scale" "$outdir")
array=${array%%;*}
merge=$(sbatch --parsable --dependency=afterok:"$array" "$@" "$here/merge.sbatch" "$outdir" "$cache")
echo "reference array job $array ($n parts), merge job $merge"
