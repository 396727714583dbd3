#!/usr/bin/env bash
# Mutation testing of the CPU code with cargo-mutants (issue 20): each
# module below (samplers, trees, closed forms, metrics, comparison
# statistics, scene parsing) is mutated (operators swapped, returns
# replaced, …) and its fast tests, named beside it, must catch every mutant.
# Survivors are listed; docs/testing.md records the last run of each
# module and explains every survivor it keeps (equivalent or unreachable
# mutants).
#
#   make mutants                                  # every module (hours on 2 cores)
#   ONLY="src/metrics/mod.rs" make mutants        # some modules
#   LIST=1 make mutants                           # list the mutants, build nothing
#   MUTANTS_ARGS="-F split" make mutants          # extra cargo-mutants arguments
#   TESTS="--lib" ONLY=... make mutants           # other tests than the list's
#
# On the 2-core VM a mutant costs about 12 s with `--lib` alone and 30–40 s
# with integration tests (an incremental build of the library, the `mdas`
# binary and the named test targets, and those tests): a first pass with
# TESTS="--lib" (and a test-name filter, MUTANTS_ARGS="--cargo-test-arg=NAME"),
# then its survivors against the list's tests, is the fast way through. It works on a copy of the committed tree (git worktree
# in $WORK, default /tmp/mdas-cargo-mutants), so the checkout is never
# modified. Builds go to a target directory of its own,
# $MUTANTS_TARGET_DIR or /tmp/mdas-mutants-target, kept between runs (the
# first run builds the dependencies): mutated builds in the checkout's
# target/ would replace its test binaries, which have the same names
# whatever the source path (seen: a `make test` during a run failed on the
# mutants' binaries). Installs cargo-mutants if it is missing. Logs:
# $WORK-logs/<module>/mutants.out. Exits 1 if any module has a surviving
# (missed) or timed-out mutant. Not part of `make test`.
#
# The whole script is one function, read before it runs: editing this file
# during a run (hours) does not change what the run does.
set -euo pipefail

# module | the cargo test arguments that select its fast tests
MODULES=(
  "src/analytic/half_plane.rs|--lib"
  "src/lights/simple/alias.rs|--lib --test=lights_cpu"
  "src/lights/tree/perfect.rs|--lib --test=lights_cpu"
  "src/lights/two_level.rs|--lib --test=lights_cpu"
  "src/lights/bvh.rs|--lib --test=lights_cpu"
  "src/lights/tree/cut.rs|--lib --test=lights_cpu"
  "src/lights/sampler.rs|--lib --test=lights_cpu --test=lights_gpu_sampler"
  "src/lights/cone.rs|--lib --test=lights_cpu"
  "src/lights/importance.rs|--lib --test=lights_cpu"
  "src/lights/substitute.rs|--lib --test=lights_cpu"
  "src/lights/lgh.rs|--lib --test=lights_cpu"
  "src/metrics/mod.rs|--lib"
  "src/compare/intervals.rs|--lib"
  "src/compare/seeds.rs|--lib"
  "src/scene_file/values.rs|--lib --test=scene_format"
  "src/scene_file/ctx.rs|--lib --test=scene_format"
  "src/scene_file/raw.rs|--lib --test=scene_format --test=many_light_scenes"
)
CARGO_MUTANTS_VERSION=27.1.0

main() {
  cd "$(dirname "$0")/.."
  ROOT=$(pwd)
  WORK=${WORK:-/tmp/mdas-cargo-mutants}
  export CARGO_TARGET_DIR=${MUTANTS_TARGET_DIR:-/tmp/mdas-mutants-target}

  if ! cargo mutants --version > /dev/null 2>&1; then
    echo "installing cargo-mutants $CARGO_MUTANTS_VERSION (once)..."
    cargo install --locked cargo-mutants --version "$CARGO_MUTANTS_VERSION"
  fi

  # shellcheck source=.ci/worktree.sh
  source "$ROOT/.ci/worktree.sh"

  local failed=() m file tests t rc out
  for m in "${MODULES[@]}"; do
    IFS='|' read -r file tests <<< "$m"
    tests=${TESTS:-$tests}
    if [[ -n "${ONLY:-}" && " $ONLY " != *" $file "* ]]; then
      continue
    fi
    [[ -f "$file" ]] || { echo "no such module: $file" >&2; exit 2; }
    local args=(-f "$file")
    for t in $tests; do
      args+=("--cargo-arg=$t")
    done
    # shellcheck disable=SC2206
    local extra=(${MUTANTS_ARGS:-})
    if [[ -n "${LIST:-}" ]]; then
      echo "== $file: $(cargo mutants --list "${args[@]}" "${extra[@]}" | wc -l) mutants"
      continue
    fi
    out="$LOGS/${file//\//_}"
    echo "== $file ($tests)"
    set +e
    cargo mutants --in-place --no-shuffle -o "$out" "${args[@]}" "${extra[@]}" 2>&1 | tail -n 3
    rc=${PIPESTATUS[0]}
    set -e
    # cargo-mutants: 0 all caught, 2 some missed, 3 some timed out.
    if [[ -s "$out/mutants.out/missed.txt" ]]; then
      sed 's/^/   missed: /' "$out/mutants.out/missed.txt"
    fi
    if [[ $rc -ne 0 ]]; then
      failed+=("$file (exit $rc)")
    fi
  done

  if [[ -z "${LIST:-}" ]]; then
    if [[ ${#failed[@]} -gt 0 ]]; then
      echo "modules with survivors or failures: ${failed[*]}"
      echo "(docs/testing.md explains the survivors that are kept)"
      exit 1
    fi
    echo "every mutant caught"
  fi
}

main "$@"; exit
