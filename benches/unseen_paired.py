"""Two batteries of `benches/unseen.sh` compared scene by scene.

For every (integrand, scene seed, spp) job present in both, the ratio of
row B's MDAS RelMSE (run B) over row A's (run A); prints per integrand and
over all the geometric mean of those ratios with a 95 % bootstrap interval
over scenes, and on how many scenes B was better. A row is a `tune` grid
label (e.g. "reconstruction=shrinkage"), or "-" for the run's only (or
last) row. Both runs must share their scenes, seeds and references (the
same N and REF_SPP), so the ratio is free of the Halton side.

    python3 benches/unseen_paired.py OUT_A ROW_A OUT_B ROW_B [--scenes]

--scenes also prints each scene's ratio.
"""
import glob
import json
import math
import os
import random
import sys


def rows(out, label):
    found = {}
    for path in glob.glob(f"{out}/*-*-*/tune.json"):
        job = os.path.basename(os.path.dirname(path))
        for row in json.load(open(path))["rows"]:
            if label in ("-", row["label"]):
                found[job] = row
    return found


def bootstrap(logs, rounds=4000):
    rng = random.Random(1)
    means = sorted(
        sum(rng.choice(logs) for _ in logs) / len(logs) for _ in range(rounds)
    )
    return math.exp(means[rounds // 40]), math.exp(means[rounds - 1 - rounds // 40])


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    a_out, a_row, b_out, b_row = sys.argv[1:5]
    a, b = rows(a_out, a_row), rows(b_out, b_row)
    jobs = sorted(set(a) & set(b))
    if not jobs:
        sys.exit("no job is in both runs with those rows")
    by = {}
    for job in jobs:
        integrand = job.split("-")[0]
        by.setdefault(integrand, []).append((job, math.log(b[job]["relmse"] / a[job]["relmse"])))
    every = []
    for integrand, pairs in sorted(by.items()):
        logs = [x for _, x in pairs]
        every += logs
        lo, hi = bootstrap(logs)
        print(f"{integrand:16s} B/A {math.exp(sum(logs) / len(logs)):.3f} [{lo:.3f}, {hi:.3f}], "
              f"B better on {sum(x < 0 for x in logs)}/{len(logs)}")
    lo, hi = bootstrap(every)
    print(f"{'all':16s} B/A {math.exp(sum(every) / len(every)):.3f} [{lo:.3f}, {hi:.3f}], "
          f"B better on {sum(x < 0 for x in every)}/{len(every)}")
    if "--scenes" in sys.argv[5:]:
        for integrand, pairs in sorted(by.items()):
            print(integrand, " ".join(f"{j.split('-')[1]}:{math.exp(x):.2f}" for j, x in pairs))


main()
