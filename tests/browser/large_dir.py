"""Assembles the 1024×1024 comparison directory whose page load the browser
test times (.ci/browser-test.sh).

A real `mdas compare` at 1024×1024 renders some 70 films (nine interleaved
timing rounds of six renders, the budget search, the seeds): minutes on
lavapipe. The page's load time depends on what it carries — five films of
half floats and nine map PNGs — not on how the record was measured, so the
test renders the five films with `mdas render` at 1024×1024 (reference,
MDAS, Halton, pixel-adaptive Halton, MDAS-uniform; given here as EXRs),
computes the maps from them here, and takes the record of the small real
comparison, its film size changed. The page then holds what `compare
--uniform` writes at that size: the reference and four methods, RelMSE
maps of the four, three FLIP slots and two density slots. FLIP and
density are not recomputed here: their slots hold |error| (linear over
[0, 1]) and the method's luminance (log), maps of the same size and
comparable PNG entropy.

    python large_dir.py SMALL_COMPARE_DIR LARGE_DIR
"""

import json
import os
import sys

import numpy as np
import OpenEXR
import png

VIRIDIS = np.array(
    [
        [68, 1, 84],
        [71, 44, 122],
        [59, 81, 139],
        [44, 113, 142],
        [33, 144, 141],
        [39, 173, 129],
        [92, 200, 99],
        [170, 220, 50],
        [253, 231, 37],
    ],
    dtype=np.float64,
)


def read_exr(path):
    with OpenEXR.File(path) as f:
        return np.asarray(f.channels()["RGB"].pixels, dtype=np.float32)


def viridis(t):
    x = np.clip(np.nan_to_num(t, nan=0.0), 0.0, 1.0) * 8.0
    i = np.minimum(np.floor(x).astype(int), 7)
    f = (x - i)[..., None]
    return np.round(VIRIDIS[i] + f * (VIRIDIS[i + 1] - VIRIDIS[i])).astype(np.uint8)


def log_position(v, lo, hi):
    v = np.maximum(v, lo)
    return (np.log(v) - np.log(lo)) / (np.log(hi) - np.log(lo))


def write_png(path, rgb):
    h, w, _ = rgb.shape
    with open(path, "wb") as f:
        png.Writer(w, h, greyscale=False, bitdepth=8).write(f, rgb.reshape(h, w * 3))


def main():
    small, large = sys.argv[1], sys.argv[2]
    ref = read_exr(os.path.join(large, "reference.exr")).astype(np.float64)
    h, w, _ = ref.shape
    images = {}
    for name in ["mdas", "halton", "adaptive", "mdas-uniform"]:
        images[name] = read_exr(os.path.join(large, f"{name}.exr")).astype(np.float64)
        relmse = ((images[name] - ref) ** 2 / (ref**2 + 0.01)).mean(axis=-1)
        write_png(os.path.join(large, f"relmse-{name}.png"), viridis(log_position(relmse, 1e-6, 10.0)))
    for name in ["mdas", "halton", "adaptive"]:
        error = np.abs(images[name] - ref).mean(axis=-1)
        write_png(os.path.join(large, f"flip-{name}.png"), viridis(error))
    for name in ["mdas", "adaptive"]:
        luminance = images[name].mean(axis=-1)
        write_png(os.path.join(large, f"density-{name}.png"), viridis(log_position(luminance, 1e-3, 10.0)))

    with open(os.path.join(small, "report.json")) as f:
        report = json.load(f)
    names = [m["name"] for m in report["methods"]]
    if names != ["mdas", "halton", "adaptive", "mdas-uniform"]:
        sys.exit(f"the small comparison's methods are {names}: run it with --uniform (and adaptive)")
    report["film"] = {"width": w, "height": h}
    report["scale"] = report["scale"] * w / 64
    report["browser_test"] = (
        "films rendered by mdas render at this size; record from the small comparison; "
        "maps computed by tests/browser/large_dir.py (FLIP and density slots: proxies)"
    )
    with open(os.path.join(large, "report.json"), "w") as f:
        json.dump(report, f, indent=1)
    maps = sum(name.endswith(".png") and name.split("-")[0] in ("relmse", "flip", "density") for name in os.listdir(large))
    print(f"{large}: {w}×{h}, {len(names) + 1} films, {maps} maps")


if __name__ == "__main__":
    main()
