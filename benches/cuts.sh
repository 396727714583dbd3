#!/usr/bin/env bash
# The paper's cut estimator at equal time (issue 49): `tree` drawing one
# light from each subtree of its block's cut (cut_sampling = "subtrees", the
# default) against `tree_nocut` (one light per evaluation from the root),
# for several cut sizes, and the one-pick mixture (cut_sampling = "mixture")
# at the scene's own cut size. Each run is one `mdas compare --samplers`
# (Halton's budget search per sampler at one target time, interleaved
# repeats, K seeds), so the two samplers' figures of one cut size come from
# one run; a table of means with 95 % intervals is printed at the end.
#
# Usage (defaults shown):
#   SCENE=scenes/cornell_lights.toml SCALE=1 REF_SPP=1024 SEEDS=3 REPEATS=3 \
#   SIZES="4 8 16 32" MIXTURE=1 TIME_MS= OUT=out/cuts benches/cuts.sh
# TIME_MS empty: MDAS+tree at its spp sets each run's target time;
# otherwise every run is at that time.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENE=${SCENE:-scenes/cornell_lights.toml}
SCALE=${SCALE:-1}
REF_SPP=${REF_SPP:-1024}
SEEDS=${SEEDS:-3}
REPEATS=${REPEATS:-3}
SIZES=${SIZES:-4 8 16 32}
TIME_MS=${TIME_MS:-}
OUT=${OUT:-out/cuts}
name=$(basename "$SCENE" .toml)
cargo build --release -q
budget=()
if [ -n "$TIME_MS" ]; then budget=(--time-ms "$TIME_MS"); fi
run() { # label, extra args...
    local label=$1; shift
    echo "== $name $label" >&2
    ./target/release/mdas -q compare "$SCENE" --samplers tree_nocut,tree "${budget[@]}" \
        --scale "$SCALE" --ref-spp "$REF_SPP" --repeats "$REPEATS" --seeds "$SEEDS" \
        --out "$OUT/$name-$label" "$@" > /dev/null
}
for n in $SIZES; do
    run "subtrees-$n" --cut-size "$n"
done
if [ "${MIXTURE:-1}" = 1 ]; then run "mixture" --cut-sampling mixture; fi
python3 - "$OUT" "$name" <<'EOF'
import json, sys, glob, os
out, name = sys.argv[1], sys.argv[2]
rows = []
for d in sorted(glob.glob(f"{out}/{name}-*")):
    r = json.load(open(os.path.join(d, "report.json")))
    eq = r["equal_time"]
    s = {x["sampler"]: x for x in eq["samplers"]}
    t, nc = s["tree"], s["tree_nocut"]
    def m(x):
        o = x.get("seeds")
        return (o["mse"], o["mse_ci95"]) if o else (x["mse"], [x["mse"], x["mse"]])
    (mt, ct), (mn, cn) = m(t), m(nc)
    rel = lambda x: (x.get("seeds") or x)["relmse"]
    rows.append((os.path.basename(d)[len(name) + 1:], eq["target_ms"], t["light_samples_per_eval"],
                 t["search"]["lo"]["spp"], mt, ct, nc["search"]["lo"]["spp"], mn, cn, mt / mn,
                 rel(t) / rel(nc)))
print(f"| {name} | target ms | tree light samples/eval | tree spp | tree MSE [95%] | tree_nocut spp | tree_nocut MSE [95%] | tree / tree_nocut MSE | RelMSE |")
print("|---|---:|---:|---:|---|---:|---|---:|---:|")
for (label, tms, ls, ts, mt, ct, ns, mn, cn, ratio, rratio) in rows:
    print(f"| {label} | {tms:.1f} | {ls:g} | {ts} | {mt:.3e} [{ct[0]:.3e}, {ct[1]:.3e}] | {ns} | "
          f"{mn:.3e} [{cn[0]:.3e}, {cn[1]:.3e}] | {ratio:.3f} | {rratio:.3f} |")
EOF
