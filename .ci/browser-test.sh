#!/usr/bin/env bash
# The real-browser test of the comparison page (issue 52; `make
# browser-test`, run by .ci/run after the cross-check; docs/testing.md):
#   1. installs Debian's chromium when /usr/bin/chromium is missing, the
#      pinned playwright-core (tests/browser/package-lock.json) into
#      tests/browser/node_modules, and OpenEXR, numpy and pypng (pins
#      below) into target/browser-venv;
#   2. runs a small `mdas compare --uniform` (Cornell box, 64×64), a tiny
#      `sweep` and `tune`, and assembles a 1024×1024 comparison from
#      `mdas render`s at that size (tests/browser/large_dir.py) whose page
#      `mdas view` writes (compare, sweep and tune write their own);
#   3. drives each index.html from file:// in headless Chromium with real
#      keyboard, mouse and wheel events (tests/browser/drive.mjs), with no
#      console error or warning, page error or network request allowed;
#   4. checks every screenshot against the EXR and PNG files read by
#      independent readers (tests/browser/verify.py; tolerances there);
#   5. times the 1024×1024 page's load (median of 3) against 2 s.
# Exit status: 0 when everything passes. Outputs in target/browser-test/.
#   MDAS=path/to/mdas .ci/browser-test.sh   (default: builds target/debug/mdas)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
LOAD_TARGET_MS=2000
PINS=(OpenEXR==3.5.3 numpy==2.4.6 pypng==0.20220715.0)
VENV=target/browser-venv
start=$(date +%s)

if [ ! -x /usr/bin/chromium ]; then
    echo "Installing chromium (Debian package) ..." >&2
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends chromium >/dev/null
fi
if ! cmp -s tests/browser/package-lock.json tests/browser/node_modules/.mdas-installed; then
    echo "Installing playwright-core (npm ci, tests/browser) ..." >&2
    (cd tests/browser && npm ci --no-audit --no-fund --loglevel=error)
    cp tests/browser/package-lock.json tests/browser/node_modules/.mdas-installed
fi
if [ "$(cat "$VENV/.pins" 2>/dev/null || true)" != "${PINS[*]}" ]; then
    echo "Installing ${PINS[*]} into $VENV ..." >&2
    rm -rf "$VENV"
    python3 -m venv "$VENV"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "${PINS[@]}"
    echo "${PINS[*]}" > "$VENV/.pins"
fi
python=$root/$VENV/bin/python

./.ci/ensure-vulkan.sh
if [ -z "${MDAS:-}" ]; then
    cargo build --profile test --bin mdas
    MDAS=target/debug/mdas
fi
MDAS=$(realpath "$MDAS")

out=$root/target/browser-test
rm -rf "$out/compare" "$out/sweep" "$out/tune" "$out/large" "$out/run"
mkdir -p "$out/large" "$out/run"
cache=(--cache "$out/cache")
echo "== runs" >&2
"$MDAS" -q compare scenes/cornell.toml --scale 0.25 --ref-spp 256 --seeds 2 --repeats 1 --uniform \
    "${cache[@]}" --out "$out/compare" >/dev/null
[ -f "$out/compare/index.html" ] || { echo "FAIL: mdas compare wrote no index.html" >&2; exit 1; }
"$MDAS" -q sweep scenes/cornell.toml --scale 0.25 --spps 4,8,16 --seeds 2 --ref-spp 256 --repeats 1 \
    "${cache[@]}" --out "$out/sweep" >/dev/null
"$MDAS" -q tune scenes/cornell.toml --scale 0.25 --spp 8 --grid alpha=0,2 --seeds 2 --ref-spp 256 \
    "${cache[@]}" --out "$out/tune" >/dev/null
for d in sweep tune; do
    [ -f "$out/$d/index.html" ] || { echo "FAIL: mdas $d wrote no index.html" >&2; exit 1; }
done
if "$MDAS" -q view "$out/run" 2>/dev/null; then
    echo "FAIL: mdas view accepted a directory without a record" >&2
    exit 1
fi

# The 1024×1024 comparison: cornell.toml's 256×256 film at scale 4.
big=(scenes/cornell.toml --scale 4)
"$MDAS" -q render "${big[@]}" --integrator halton --spp 16 --seed 1 -o "$out/large/reference.exr" >/dev/null
"$MDAS" -q render "${big[@]}" --integrator mdas --spp 2 -o "$out/large/mdas.exr" >/dev/null
"$MDAS" -q render "${big[@]}" --integrator halton --spp 2 -o "$out/large/halton.exr" >/dev/null
"$MDAS" -q render "${big[@]}" --integrator adaptive --spp 2 -o "$out/large/adaptive.exr" >/dev/null
"$MDAS" -q render "${big[@]}" --integrator mdas --spp 2 --alpha 0 --candidates 1 -o "$out/large/mdas-uniform.exr" >/dev/null
"$python" tests/browser/large_dir.py "$out/compare" "$out/large"
"$MDAS" -q view "$out/large" >/dev/null
echo "pages: $(du -h "$out/compare/index.html" | cut -f1) (64×64), $(du -h "$out/large/index.html" | cut -f1) (1024×1024)" >&2

echo "== browser ($(/usr/bin/chromium --version 2>/dev/null | head -1))" >&2
node tests/browser/drive.mjs --chromium /usr/bin/chromium --out "$out/run" \
    --compare "$out/compare" --sweep "$out/sweep" --tune "$out/tune" --big "$out/large" --runs 3
echo "== pixels" >&2
"$python" tests/browser/verify.py "$out/run/steps.json"

median=$("$python" -c "
import json, statistics
loads = json.load(open('$out/run/steps.json'))['loads']
print(round(statistics.median(l['loadMs'] for l in loads)))")
echo "1024×1024 comparison page: ready in ${median} ms (median of 3 loads; target ${LOAD_TARGET_MS} ms)"
if [ "$median" -gt "$LOAD_TARGET_MS" ]; then
    echo "FAIL: the 1024×1024 page took ${median} ms to be ready (target ${LOAD_TARGET_MS} ms)" >&2
    exit 1
fi
echo "browser test passed in $(($(date +%s) - start)) s"
