#!/usr/bin/env bash
# The Python environment with Mitsuba 3 (and numpy) that the cross-check
# (.ci/crosscheck.sh) and the Slurm test (scripts/slurm/test.sh) use:
# target/mitsuba-venv, installed from PyPI with the pins below once (a
# marker file records them).
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=target/mitsuba-venv
PINS=(mitsuba==3.9.1 drjit==1.5.0 numpy==2.4.6)
MARKER="$VENV/.crosscheck-pins"

if [ ! -x "$VENV/bin/python" ]; then
    echo "Creating $VENV ..." >&2
    python3 -m venv "$VENV"
fi
if [ "$(cat "$MARKER" 2>/dev/null || true)" != "${PINS[*]}" ]; then
    echo "Installing ${PINS[*]} into $VENV ..." >&2
    rm -f "$MARKER"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "${PINS[@]}"
    echo "${PINS[*]}" > "$MARKER"
fi

