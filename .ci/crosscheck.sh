#!/usr/bin/env bash
# Independent-renderer cross-check: renders tests/crosscheck/scenes/*.xml with
# Mitsuba 3 (scalar_rgb) and with mdas, and compares the two statistically
# (image means per channel and per-pixel RelMSE over 4 seeds each; see
# tests/crosscheck/crosscheck.py). Results go to target/crosscheck/
# (summary.json, mean images). Extra arguments go to crosscheck.py:
#   .ci/crosscheck.sh                          # every scene, target/debug/mdas
#   MDAS=target/release/mdas .ci/crosscheck.sh --scenes area_direct,thinlens
#   .ci/crosscheck.sh --self-test              # Mitsuba against itself: checks the harness
# Mitsuba comes from PyPI into the venv target/mitsuba-venv, installed once
# with the pins below (a marker file records them). Exit status: 0 pass,
# 1 a check failed, 2 setup error.
set -euo pipefail
cd "$(dirname "$0")/.."

VENV=target/mitsuba-venv
./.ci/mitsuba-venv.sh

# mdas needs a Vulkan driver (lavapipe on a machine without a GPU); the
# self-test runs Mitsuba only.
self_test=0
for arg in "$@"; do
    if [ "$arg" = "--self-test" ]; then self_test=1; fi
done
if [ "$self_test" = 0 ]; then
    ./.ci/ensure-vulkan.sh
fi

exec "$VENV/bin/python" tests/crosscheck/crosscheck.py \
    --mdas "${MDAS:-target/debug/mdas}" --out target/crosscheck "$@"
