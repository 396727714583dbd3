#!/usr/bin/env python3
"""Where the MSE of `benches/cuts.sh`'s runs comes from: for each run
directory, the MSE of `halton-tree` and `halton-tree_nocut` against the
reference over the whole image and split by the reference's luminance
(mean of R, G, B) at THRESHOLD (default 0.3): in `cornell_lights` the pixels
above it are the lamps seen directly and their silhouettes, whose error is
the film's (anti-aliasing) variance, not the lighting's.

Usage: benches/cuts_split.py [--threshold T] RUN_DIR...
Needs numpy. Reads the EXRs mdas writes with benches/exr_scanline.py."""
import sys

import numpy as np

import exr_scanline


def read_exr(path):
    """RGB float64 image (H, W, 3) of a scanline float32 EXR."""
    w, h, rgb = exr_scanline.read_exr(path)
    return np.stack([np.asarray(c, np.float64).reshape(h, w) for c in rgb], -1)


def main(argv):
    threshold = 0.3
    if argv[:1] == ["--threshold"]:
        threshold, argv = float(argv[1]), argv[2:]
    print(f"| run | pixels above {threshold} | MSE tree / tree_nocut, whole image | below | above | share of tree's MSE above |")
    print("|---|---:|---:|---:|---:|---:|")
    for d in argv:
        ref = read_exr(f"{d}/reference.exr")
        err = {k: ((read_exr(f"{d}/halton-{k}.exr") - ref) ** 2).mean(-1) for k in ("tree", "tree_nocut")}
        above = ref.mean(-1) >= threshold
        ratio = lambda m: err["tree"][m].mean() / err["tree_nocut"][m].mean()
        print(f"| {d} | {above.mean() * 100:.2f} % | {ratio(np.ones_like(above)):.3f} | "
              f"{ratio(~above):.3f} | {ratio(above):.3f} | "
              f"{err['tree'][above].sum() / err['tree'].sum() * 100:.1f} % |")


if __name__ == "__main__":
    main(sys.argv[1:])
