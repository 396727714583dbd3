#!/usr/bin/env bash
# The paper's cut estimator at equal light-sample count (issue 66 item 2):
# `tree` (one light from each subtree of its block's cut of n nodes) at SPP
# samples per pixel against `tree_nocut`, both under Halton, both tracing
# n·SPP shadow rays per pixel. Two protocols:
#   PROTOCOL=shared (the default; the paper's Table 3): `tree_nocut` at the
#     same SPP with `light_samples = n` (n picks from the root at each
#     shading point, pick j drawn with the numbers of cut node j): the same
#     camera samples and shading points for both, the light numbers drawn
#     alike. The scene is copied beside itself (its meshes resolve) with
#     sampler = "tree_nocut" and light_samples = n, and removed after.
#   PROTOCOL=camera: `tree_nocut` at n·SPP, one pick per evaluation; it
#     thereby also gets n times the camera samples (on a scene with
#     emitters in view its film variance favours `tree_nocut`). Seeds 1..SEEDS for each; MSE against one
# REF_SPP-spp reference (the scene's sampler, seed 0). Prints, per n, the
# mean MSE of each, the ratio of the means with a 95 % bootstrap interval
# over seeds, and the geometric mean of the per-seed ratios (paired by
# seed) with its 95 % bootstrap interval (robust to a heavy-tailed seed).
#
# Usage (defaults shown):
#   SCENE=scenes/cornell_lights.toml SCALE=0.25 REF_SPP=1024 SPP=4 SIZES="4 8" \
#   SEEDS=10 PROTOCOL=shared OUT=out/cuts_equal_count benches/cuts_equal_count.sh
# BIN=path/to/mdas uses that binary instead of building target/release/mdas.
# benches/cuts_equal_count_split.py OUT splits the MSE into the lamps seen
# directly and the lit surfaces.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENE=${SCENE:-scenes/cornell_lights.toml}
SCALE=${SCALE:-0.25}
REF_SPP=${REF_SPP:-1024}
SPP=${SPP:-4}
SIZES=${SIZES:-4 8}
SEEDS=${SEEDS:-10}
PROTOCOL=${PROTOCOL:-shared}
case "$PROTOCOL" in shared | camera) ;; *) echo "PROTOCOL must be shared or camera" >&2; exit 1 ;; esac
OUT=${OUT:-out/cuts_equal_count}
name=$(basename "$SCENE" .toml)
mkdir -p "$OUT"
if [ -z "${BIN:-}" ]; then cargo build --release -q; fi
bin=${BIN:-./target/release/mdas}
ref="$OUT/$name-ref.exr"
$bin reference "$SCENE" --spp "$REF_SPP" --scale "$SCALE" -o "$ref" > /dev/null
csv="$OUT/$name.csv"
echo "n,seed,sampler,spp,mse" > "$csv"
mse() { # n, sampler, spp, seed, extra args...
    local n=$1 s=$2 spp=$3 seed=$4; shift 4
    $bin render "$SCENE" --integrator halton --sampler "$s" --spp "$spp" --seed "$seed" \
        --scale "$SCALE" --reference "$ref" -o "$OUT/$name-n$n-$s-$seed.exr" "$@" 2>&1 |
        sed -n 's/.*  MSE \([0-9.e+-]*\).*/\1/p'
}
# A copy of the scene beside it with sampler = "tree_nocut" and
# light_samples = n in its [integrand] table.
variant() { # n
    local out
    out="$(dirname "$SCENE")/.$name-light-samples-$1.toml"
    python3 - "$SCENE" "$1" "$out" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
text, found = re.subn(r'(?m)^sampler\s*=.*$', 'sampler = "tree_nocut"', text)
extra = f"light_samples = {sys.argv[2]}\n" + ("" if found else 'sampler = "tree_nocut"\n')
text = re.sub(r'(?m)^\[integrand\]\s*$', lambda m: m.group(0) + "\n" + extra.rstrip("\n"), text, count=1)
open(sys.argv[3], "w").write(text)
PY
    echo "$out"
}
variants=()
trap 'rm -f "${variants[@]}"' EXIT
for n in $SIZES; do
    if [ "$PROTOCOL" = shared ]; then
        v=$(variant "$n")
        variants+=("$v")
    fi
    for seed in $(seq 1 "$SEEDS"); do
        echo "$n,$seed,tree,$SPP,$(mse "$n" tree "$SPP" "$seed" --cut-size "$n")" >> "$csv"
        if [ "$PROTOCOL" = shared ]; then
            echo "$n,$seed,tree_nocut,$SPP,$(SCENE=$v mse "$n" tree_nocut "$SPP" "$seed")" >> "$csv"
        else
            echo "$n,$seed,tree_nocut,$((n * SPP)),$(mse "$n" tree_nocut $((n * SPP)) "$seed")" >> "$csv"
        fi
    done
done
python3 - "$csv" <<'PY'
import csv, math, random, sys
rows = list(csv.DictReader(open(sys.argv[1])))
random.seed(66)
for n in sorted({int(r["n"]) for r in rows}):
    t = {int(r["seed"]): float(r["mse"]) for r in rows if int(r["n"]) == n and r["sampler"] == "tree"}
    c = {int(r["seed"]): float(r["mse"]) for r in rows if int(r["n"]) == n and r["sampler"] == "tree_nocut"}
    seeds = sorted(t)
    mean = lambda xs: sum(xs) / len(xs)
    ratio = lambda ss: mean([t[s] for s in ss]) / mean([c[s] for s in ss])
    geo = lambda ss: math.exp(mean([math.log(t[s] / c[s]) for s in ss]))
    boot = lambda f: sorted(f([random.choice(seeds) for _ in seeds]) for _ in range(10000))
    br, bg = boot(ratio), boot(geo)
    ci = lambda b: (b[249], b[9749])
    spp_c = [r["spp"] for r in rows if int(r["n"]) == n and r["sampler"] == "tree_nocut"][0]
    print(f"n = {n}: {len(seeds)} seeds; tree MSE {mean(list(t.values())):.4e}, "
          f"tree_nocut ({spp_c} spp) {mean(list(c.values())):.4e}; ratio of means {ratio(seeds):.3f} "
          f"[{ci(br)[0]:.3f}, {ci(br)[1]:.3f}]; geometric mean of per-seed ratios {geo(seeds):.3f} "
          f"[{ci(bg)[0]:.3f}, {ci(bg)[1]:.3f}]; per seed: "
          + " ".join(f"{t[s] / c[s]:.2f}" for s in seeds))
PY
