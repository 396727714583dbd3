#!/usr/bin/env python3
"""Summary of benches/unseen.sh: reads OUT/<integrand>-<seed>-<spp>/tune.json
and prints, per integrand and budget, MDAS (its defaults) against Halton:
win rate, geometric mean of the RelMSE ratio with a 95 % bootstrap interval
over scenes, the worst scene, MDAS's mean |relative bias| (G channel)
beside Halton's at the same spp and seeds (noise alone: Halton is
unbiased) and the count of scenes whose MDAS bias interval excludes 0,
and the equal-time ratio. Also writes OUT/battery.json. Standard library
only.

    unseen_summary.py OUT
    unseen_summary.py --paired OUT_A ROW_A OUT_B ROW_B [--scenes]
        two batteries scene by scene (see `paired`)

Equal time: tune fits Halton's time as a + b·spp and reports the spp
Halton reaches in MDAS's time; Halton's RelMSE there is interpolated
log-log between its budgets (½, 1, 2, 4 × MDAS's spp) and, past 4× or
below ½×, extrapolated along the nearest segment (counted in the table).
"""
import glob, json, math, os, random, re, sys

def geomean(xs):
    return math.exp(sum(math.log(x) for x in xs) / len(xs))

def boot(xs, reps=4000):
    rng = random.Random(48)
    ms = sorted(geomean([rng.choice(xs) for _ in xs]) for _ in range(reps))
    return ms[int(0.025 * reps)], ms[int(0.975 * reps) - 1]

def paired(a_out, a_row, b_out, b_row, scenes=False):
    """Two batteries scene by scene: for every job in both, row B's MDAS
    RelMSE (run B) over row A's (run A), free of the Halton side when both
    share their scenes, seeds and references; per integrand and over all
    the geometric mean with its bootstrap interval and on how many scenes
    B was better. A row is a `tune` grid label, or "-" for a run's only
    (or last) row."""
    def rows(out, label):
        found = {}
        for path in glob.glob(f"{out}/*-*-*/tune.json"):
            job = os.path.basename(os.path.dirname(path))
            for row in json.load(open(path))["rows"]:
                if label in ("-", row["label"]):
                    found[job] = row
        return found
    a, b = rows(a_out, a_row), rows(b_out, b_row)
    by = {}
    for job in sorted(set(a) & set(b)):
        by.setdefault(job.split("-")[0], []).append((job, b[job]["relmse"] / a[job]["relmse"]))
    if not by:
        sys.exit("no job is in both runs with those rows")
    every = []
    for integrand, pairs in sorted(by.items()) + [("all", None)]:
        ratios = [r for _, r in pairs] if pairs else every
        lo, hi = boot(ratios)
        print(f"{integrand:16s} B/A {geomean(ratios):.3f} [{lo:.3f}, {hi:.3f}], "
              f"B better on {sum(r < 1 for r in ratios)}/{len(ratios)}")
        if pairs:
            every += ratios
    if scenes:
        for integrand, pairs in sorted(by.items()):
            print(integrand, " ".join(f"{j.split('-')[1]}:{r:.2f}" for j, r in pairs))

if sys.argv[1:2] == ["--paired"]:
    if len(sys.argv) < 6:
        sys.exit("usage: unseen_summary.py --paired OUT_A ROW_A OUT_B ROW_B [--scenes]")
    paired(*sys.argv[2:6], scenes="--scenes" in sys.argv[6:])
    sys.exit()

out = sys.argv[1] if len(sys.argv) > 1 else "out/unseen"
# The battery's jobs (benches/unseen.sh writes OUT/jobs.txt; its parts,
# PART=I/N, share it): every job must have its tune.json, run with the
# battery's reference spp and seeds, or there is no summary to write.
jobs_file = os.path.join(out, "jobs.txt")
if os.path.exists(jobs_file):
    lines = open(jobs_file).read().splitlines()
    settings = dict(kv.split("=", 1) for kv in lines[0].removeprefix("# settings: ").split(" ")
                    if "=" in kv)
    missing, wrong = [], []
    for line in lines[1:]:
        t, k, spp = line.split()
        path = os.path.join(out, f"{t}-{k}-{spp}", "tune.json")
        if not os.path.exists(path):
            missing.append(f"{t}-{k}-{spp}")
            continue
        d = json.load(open(path))
        if (str(d["reference_spp"]) != settings.get("ref_spp")
                or str(len(d["mdas_seeds"])) != settings.get("seeds")):
            wrong.append(f"{t}-{k}-{spp}")
    if missing or wrong:
        sys.exit(f"{out}: the battery is not whole: "
                 + (f"{len(missing)} jobs missing ({', '.join(missing[:8])}"
                    + (", ..." if len(missing) > 8 else "") + ")" if missing else "")
                 + ("; " if missing and wrong else "")
                 + (f"run with other settings than jobs.txt: {', '.join(wrong)}" if wrong else ""))
rows = []
for name in sorted(os.listdir(out)):
    m = re.fullmatch(r"([a-z_]+)-(\d+)-(\d+(?:\.\d+)?)", name)
    path = os.path.join(out, name, "tune.json")
    if not m or not os.path.exists(path):
        continue
    d = json.load(open(path))
    halton = sorted(d["halton"], key=lambda h: h["spp"])
    same = [h for h in halton if h["spp"] == d["spp"]]
    if not same:
        continue
    h_same = same[0]["relmse"]
    for r in d["rows"]:
        t_spp = r["equal_time_halton_spp"]
        extrapolated = False
        eq_time = None
        if t_spp and t_spp > 0:
            xs = [math.log(h["spp"]) for h in halton]
            ys = [math.log(h["relmse"]) for h in halton]
            x = math.log(t_spp)
            i = 0
            while i < len(xs) - 2 and x > xs[i + 1]:
                i += 1
            extrapolated = x < xs[0] or x > xs[-1]
            y = ys[i] + (ys[i + 1] - ys[i]) * (x - xs[i]) / (xs[i + 1] - xs[i])
            eq_time = r["relmse"] / math.exp(y)
        rows.append({
            "integrand": m.group(1), "seed": int(m.group(2)), "spp": float(m.group(3)),
            "mdas": r["relmse"], "mdas_ci95": r["relmse_ci95"], "halton": h_same,
            "ratio": r["relmse"] / h_same, "bias_g": r["relative_bias"][1],
            "bias_g_ci95": r["relative_bias_ci95"][1],
            "halton_bias_g": same[0]["relative_bias"][1],
            "mdas_ms": r["time_ms"], "halton_ms": same[0]["time_ms"],
            "equal_time_ratio": eq_time, "equal_time_extrapolated": extrapolated,
            "label": r["label"], "params": r["params"],
        })

print(f"Battery of scenes nobody tuned ({out}); MDAS/Halton RelMSE, MDAS with its defaults\n")
# The bias column: MDAS's mean |relative bias| of the image (G channel)
# over the scenes, then Halton's at the same spp and seeds — Halton is
# unbiased, so its figure is what noise alone reads — and on how many
# scenes MDAS's 95 % interval excludes 0 (a resolved bias).
print("| integrand | spp | scenes | wins (≤ 1) | geo. mean [95 %] | worst (seed) | mean abs. bias (G): MDAS, Halton; resolved | MDAS time / Halton's | equal time geo. mean [95 %] (extrapolated) |")
print("|---|---|---|---|---|---|---|---|---|")
groups = {}
for r in rows:
    groups.setdefault((r["label"], r["spp"], r["integrand"]), []).append(r)
labels = sorted({k[0] for k in groups})
summary = []
for label, spp in sorted({k[:2] for k in groups}):
    all_ratios, all_bias, all_time, all_noise, all_resolved = [], [], [], [], 0
    if len(labels) > 1:
        print(f"| *{label}* | | | | | | | | |")
    for (lab, s, t), rs in sorted(groups.items()):
        if s != spp or lab != label:
            continue
        ratios = [r["ratio"] for r in rs]
        wins = sum(x <= 1.0 for x in ratios)
        gm, (lo, hi) = geomean(ratios), boot(ratios)
        worst = max(rs, key=lambda r: r["ratio"])
        bias = sum(abs(r["bias_g"]) for r in rs) / len(rs)
        noise = sum(abs(r["halton_bias_g"]) for r in rs) / len(rs)
        resolved = sum(r["bias_g_ci95"][0] > 0 or r["bias_g_ci95"][1] < 0 for r in rs)
        cost = geomean([r["mdas_ms"] / r["halton_ms"] for r in rs])
        et = [r["equal_time_ratio"] for r in rs if r["equal_time_ratio"]]
        ext = sum(r["equal_time_extrapolated"] for r in rs if r["equal_time_ratio"])
        et_s = f"{geomean(et):.2f} [{boot(et)[0]:.2f}, {boot(et)[1]:.2f}] ({ext})" if et else "–"
        print(f"| {t} | {spp:g} | {len(rs)} | {wins}/{len(rs)} ({100*wins/len(rs):.0f} %) | {gm:.2f} [{lo:.2f}, {hi:.2f}] | {worst['ratio']:.2f} ({worst['seed']}) | {100*bias:.2f} %, {100*noise:.2f} %; {resolved} | {cost:.2f} | {et_s} |")
        summary.append({"label": label, "spp": spp, "integrand": t, "scenes": len(rs), "wins": wins,
                        "geomean": gm, "geomean_ci95": [lo, hi], "worst": worst["ratio"],
                        "worst_seed": worst["seed"], "mean_abs_bias_g": bias,
                        "halton_mean_abs_bias_g": noise, "bias_resolved": resolved,
                        "time_ratio_geomean": cost,
                        "equal_time_geomean": geomean(et) if et else None,
                        "equal_time_extrapolated": ext})
        all_ratios += ratios
        all_bias += [abs(r["bias_g"]) for r in rs]
        all_noise += [abs(r["halton_bias_g"]) for r in rs]
        all_resolved += resolved
        all_time += et
    if all_ratios:
        lo, hi = boot(all_ratios)
        et_s = f"{geomean(all_time):.2f} [{boot(all_time)[0]:.2f}, {boot(all_time)[1]:.2f}]" if all_time else "–"
        wins = sum(x <= 1.0 for x in all_ratios)
        print(f"| **all** | {spp:g} | {len(all_ratios)} | {wins}/{len(all_ratios)} | **{geomean(all_ratios):.2f} [{lo:.2f}, {hi:.2f}]** | {max(all_ratios):.2f} | {100*sum(all_bias)/len(all_bias):.2f} %, {100*sum(all_noise)/len(all_noise):.2f} %; {all_resolved} | | {et_s} |")
json.dump({"rows": rows, "summary": summary}, open(os.path.join(out, "battery.json"), "w"), indent=1)
