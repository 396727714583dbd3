#!/usr/bin/env python3
"""The split of benches/cuts_equal_count.sh's MSE by the reference's
luminance (mean of R, G, B) at THRESHOLD (default 0.3), as
benches/cuts_split.py splits benches/cuts.sh's: in `cornell_lights` the
pixels above it are the lamps seen directly and their silhouettes, whose
error is the film's (anti-aliasing) variance, which only camera samples
reduce; the pixels below are the lit surfaces, where the light sampler's
variance shows. Pure Python (no numpy): for the small films of that script.

Usage: benches/cuts_equal_count_split.py [--threshold T] OUT_DIR [SCENE_NAME]
Prints per n the MSE ratio tree / tree_nocut on the lit pixels: ratio of
the means over seeds and the geometric mean of per-seed ratios, each with a
95 % bootstrap interval over seeds.

       benches/cuts_equal_count_split.py --paired OUT_A OUT_B [SCENE_NAME]
compares two runs' `tree` (two builds, same seeds): the geometric mean over
seeds of tree's lit-pixel MSE in A over B, with its bootstrap interval."""
import csv
import math
import os
import random
import sys

from exr_scanline import read_exr


def paired(a, b, name, thr):
    _, _, ref = read_exr(os.path.join(a, f"{name}-ref.exr"))
    lum = [(r + g + bb) / 3 for r, g, bb in zip(*ref)]
    lit = [k for k, v in enumerate(lum) if v <= thr]

    def mse(path):
        _, _, img = read_exr(path)
        return sum((img[c][k] - ref[c][k]) ** 2 for k in lit for c in range(3)) / (3 * len(lit))

    rows = list(csv.DictReader(open(os.path.join(a, f"{name}.csv"))))
    random.seed(66)
    for n in sorted({int(r["n"]) for r in rows}):
        seeds = sorted({int(r["seed"]) for r in rows if int(r["n"]) == n})
        f = lambda d, s: os.path.join(d, f"{name}-n{n}-tree-{s}.exr")
        r = [math.log(mse(f(a, s)) / mse(f(b, s))) for s in seeds]
        m = lambda xs: sum(xs) / len(xs)
        bs = sorted(m([random.choice(r) for _ in r]) for _ in range(10000))
        print(f"n = {n}: tree's lit-pixel MSE, {a} / {b}: geometric mean over {len(seeds)} seeds "
              f"{math.exp(m(r)):.3f} [{math.exp(bs[249]):.3f}, {math.exp(bs[9749]):.3f}]; per seed "
              + " ".join(f"{math.exp(x):.2f}" for x in r))


def main():
    args = sys.argv[1:]
    if args and args[0] == "--paired":
        paired(args[1], args[2], args[3] if len(args) > 3 else "cornell_lights", 0.3)
        return
    thr = 0.3
    if args and args[0] == "--threshold":
        thr = float(args[1]); args = args[2:]
    out = args[0]
    name = args[1] if len(args) > 1 else "cornell_lights"
    _, _, ref = read_exr(os.path.join(out, f"{name}-ref.exr"))
    lum = [(r + g + b) / 3 for r, g, b in zip(*ref)]
    lit = [k for k, v in enumerate(lum) if v <= thr]
    lamps = [k for k, v in enumerate(lum) if v > thr]

    def mse(path, idx):
        _, _, img = read_exr(path)
        return sum((img[c][k] - ref[c][k]) ** 2 for k in idx for c in range(3)) / (3 * len(idx))

    rows = list(csv.DictReader(open(os.path.join(out, f"{name}.csv"))))
    random.seed(66)
    print(f"{len(lit)} lit pixels (reference luminance <= {thr}), {len(lamps)} above")
    for n in sorted({int(r["n"]) for r in rows}):
        t, c, tl, cl = {}, {}, {}, {}
        for r in rows:
            if int(r["n"]) != n:
                continue
            path = os.path.join(out, f"{name}-n{n}-{r['sampler']}-{r['seed']}.exr")
            s = int(r["seed"])
            if r["sampler"] == "tree":
                t[s], tl[s] = mse(path, lit), mse(path, lamps)
            else:
                c[s], cl[s] = mse(path, lit), mse(path, lamps)
        seeds = sorted(t)
        mean = lambda xs: sum(xs) / len(xs)
        ratio = lambda ss: mean([t[s] for s in ss]) / mean([c[s] for s in ss])
        geo = lambda ss: math.exp(mean([math.log(t[s] / c[s]) for s in ss]))
        boot = lambda f: sorted(f([random.choice(seeds) for _ in seeds]) for _ in range(10000))
        br, bg = boot(ratio), boot(geo)
        share_t = mean([tl[s] * len(lamps) / (tl[s] * len(lamps) + t[s] * len(lit)) for s in seeds])
        print(f"n = {n}: lit pixels: tree MSE {mean(list(t.values())):.4e}, tree_nocut "
              f"{mean(list(c.values())):.4e}; ratio of means {ratio(seeds):.3f} "
              f"[{br[249]:.3f}, {br[9749]:.3f}]; geometric mean of per-seed ratios {geo(seeds):.3f} "
              f"[{bg[249]:.3f}, {bg[9749]:.3f}]; lamp pixels' share of tree's squared error "
              f"{100 * share_t:.0f} %; lamp pixels: ratio of means "
              f"{mean(list(tl.values())) / mean(list(cl.values())):.2f}")


main()
