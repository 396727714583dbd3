#!/usr/bin/env bash
# Evaluate time of `tree` (a cut of n) against `tree_nocut` with
# `light_samples = n` at the same spp (issue 66 item 2, BENCHMARKS.md "The
# paper's protocol: the same camera samples"): 3 interleaved rounds per n,
# warm (`--warmup`), on cornell_lights (1/4 scale, 4 spp) and vpl_atrium
# (full size, 1 spp). Multiply benches/cuts_equal_count.sh's MSE ratio by
# the ratio of the medians for the equal-time ratio.
#   BIN=target/release/mdas benches/cuts_equal_time.sh
set -euo pipefail
cd "$(dirname "$0")/.."
B=${BIN:-target/release/mdas}
for sc in "cornell_lights scenes/cornell_lights.toml 0.25 4" "vpl_atrium scenes/vpl_atrium.toml 1 1"; do
  set -- $sc
  for n in 4 8; do
    v="$(dirname $2)/.$1-ls$n.toml"
    python3 - "$2" "$n" "$v" <<'PY'
import re, sys
t = open(sys.argv[1]).read()
t = re.sub(r'(?m)^sampler\s*=.*$', 'sampler = "tree_nocut"', t)
t = re.sub(r'(?m)^\[integrand\]\s*$', lambda m: m.group(0) + f"\nlight_samples = {sys.argv[2]}", t, count=1)
open(sys.argv[3], "w").write(t)
PY
    for r in 1 2 3; do
      a=$($B render $2 --scale $3 --integrator halton --sampler tree --cut-size $n --spp $4 --seed $r --warmup -o /tmp/ct.exr 2>&1 | sed -n 's/.*(evaluate \([0-9.]*\) ms.*/\1/p')
      b=$($B render $v --scale $3 --integrator halton --sampler tree_nocut --spp $4 --seed $r --warmup -o /tmp/ct.exr 2>&1 | sed -n 's/.*(evaluate \([0-9.]*\) ms.*/\1/p')
      echo "$1 n=$n round $r: tree $a ms, tree_nocut(light_samples) $b ms"
    done
    rm -f "$v"
  done
done
