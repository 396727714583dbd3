#!/usr/bin/env bash
# WGSL mutation testing (issue 20): each mutation below plants a classic
# estimator bug in a copy of the kernels, and the tests named with it must
# fail. A mutation the tests survive is a hole in the suite.
#
#   make mutants-wgsl            # all mutations (minutes per mutation on 2 cores)
#   ONLY="cos_dropped cos_abs" make mutants-wgsl
#
# It works on a copy of the committed tree (git worktree in $WORK, default
# /tmp/mdas-wgsl-mutants), so the checkout's files are never modified; it
# builds in a target directory of its own (below). Prints one line per mutation and a
# summary; exits 1 if any mutation survives. Not part of `make test`.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
WORK=${WORK:-/tmp/mdas-wgsl-mutants}
# A target directory of its own, shared with .ci/cargo-mutants.sh and kept
# between runs (dependencies are built once, then only the crate rebuilds
# per mutation): mutated builds in the checkout's target/ would replace its
# test binaries.
export CARGO_TARGET_DIR=${MUTANTS_TARGET_DIR:-/tmp/mdas-mutants-target}

# name | file | exact text | replacement | test binaries that must fail
MUTATIONS=(
  "cos_dropped|wgsl/shared/shading.wgsl|(cos_x * cos_y / (dist2 * l.pdf_area))|(cos_x / (dist2 * l.pdf_area))|integrands analytic"
  "cos_abs|wgsl/shared/shading.wgsl|let cos_y = -dot(l.n, wi);|let cos_y = abs(dot(l.n, wi));|integrands"
  "pdf_measure|wgsl/shared/shading.wgsl|(cos_x * cos_y / (dist2 * l.pdf_area))|(cos_x * cos_y / l.pdf_area)|analytic"
  "pmf_division|wgsl/many_light.wgsl|ldexp(c / pick.pmf_m, vec3<i32>(-pick.pmf_e))|ldexp(c, vec3<i32>(-pick.pmf_e))|many_light"
  "morton_bit|wgsl/lights/morton.wgsl|(spread3(q[0]) << 2u)|(spread3(q[0]) << 3u)|light_tree_gpu"
  "splat_weight|wgsl/mdas/reconstruct.wgsl|add_fixed(word + 6u, to_fixed(ldexp(w, 60)));|add_fixed(word + 6u, to_fixed(ldexp(ox * oy, 60)));|mdas_invariants mdas_bias"
  "voxel_skip|wgsl/shared/voxel.wgsl|let extra = 1 + i32(scene.voxel_skip);|let extra = 2 + i32(scene.voxel_skip);|bvh_traversal"
  "voxel_column|wgsl/voxel_build.wgsl|floor(kmin - 1e-3)|floor(kmin + 1e-3)|bvh_traversal"
  "pixel_prior|wgsl/mdas/reconstruct.wgsl|value = m.mean * (kappa * inv);|value = m.mean * inv;|mdas_invariants mdas_quality"
  "pixel_own|wgsl/mdas/reconstruct.wgsl|                    if (pixel_of[n] == t) {|                    if (pixel_of[n] <= t) {|mdas_invariants mdas_quality"
  "shrink_kappa|wgsl/mdas/reconstruct.wgsl|    return min(sigma2 / tau2, SHRINK_KAPPA_MAX);|    return 0.0;|mdas_invariants"
  "shrink_bound|wgsl/mdas/reconstruct.wgsl|value = clamp(value, min(a, b), max(a, b));|value = value;|mdas_invariants"
  "slot_last|wgsl/mdas/common.wgsl|        leaves_set(leaf_base(k) + 2u, s);|        boxes_set(box_base(k) + DIMS, s);|mdas_invariants"
  "split_side|wgsl/mdas/adapt.wgsl|        side[i] = sample_q(all[i], d.axis) >= d.plane;|        side[i] = sample_q(all[i], d.axis) > d.plane;|mdas_invariants"
  "trim_tie|wgsl/mdas/adapt.wgsl|                if (i < count && finite[i] && d > worst) {|                if (i < count && finite[i] && d >= worst) {|mdas_invariants"
  "trim_min|wgsl/mdas/adapt.wgsl|        if (n >= 3u) {|        if (n >= 5u) {|mdas_invariants mdas_bias"
)

# shellcheck source=.ci/worktree.sh
source "$ROOT/.ci/worktree.sh"
killed=0
survived=()
broken=()
for m in "${MUTATIONS[@]}"; do
  IFS='|' read -r name file from to tests <<< "$m"
  if [[ -n "${ONLY:-}" && " $ONLY " != *" $name "* ]]; then
    continue
  fi
  python3 - "$file" "$from" "$to" <<'PY'
import sys
path, old, new = sys.argv[1:4]
text = open(path).read()
if text.count(old) != 1:
    sys.exit(f"mutation text found {text.count(old)} times in {path}: {old}")
open(path, "w").write(text.replace(old, new))
PY
  args=()
  for t in $tests; do args+=(--test "$t"); done
  start=$(date +%s)
  log="$LOGS/$name.log"
  # A kill counts only when a test fails: a mutation that stops the
  # kernels compiling is a broken mutation, not a caught bug.
  if cargo test --release "${args[@]}" > "$log" 2>&1; then
    result=SURVIVED
    survived+=("$name")
  elif grep -qE '^test .* \.\.\. FAILED$' "$log"; then
    result=killed
    killed=$((killed + 1))
  else
    result=BROKEN
    broken+=("$name")
  fi
  # No failing test (a survivor): grep finds nothing, which must not end
  # the script under pipefail.
  by=$({ grep -E '^test .* \.\.\. FAILED$' "$log" || true; } | sed -E 's/^test (.*) \.\.\. FAILED$/\1/' | head -2 | paste -sd, -)
  printf '%-14s %-8s %4ss  (%s; %s)%s\n' "$name" "$result" $(( $(date +%s) - start )) "$file" "$tests" "${by:+ by $by}"
  git checkout -- "$file"
done

echo "killed $killed, survived ${#survived[@]}${survived:+: ${survived[*]}}, broken ${#broken[@]}${broken:+: ${broken[*]}} (logs in $LOGS)"
[[ ${#survived[@]} -eq 0 && ${#broken[@]} -eq 0 ]]
