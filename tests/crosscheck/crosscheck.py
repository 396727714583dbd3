#!/usr/bin/env python3
"""Independent-renderer cross-check: mdas against Mitsuba 3 (scalar_rgb).

    python tests/crosscheck/crosscheck.py --mdas target/debug/mdas --out target/crosscheck
    python tests/crosscheck/crosscheck.py --out DIR --self-test [--scenes a,b]

Every scene in ``scenes/`` (listed in SCENES below) is rendered with K = 4
independent seeds by Mitsuba (``mi.render(scene, seed, spp)``) and by
``mdas render SCENE --integrator halton --spp S --seed k -q -o OUT.exr``,
and the two K-seed sets are compared. Exit status: 0 all checks pass,
1 a check failed (a scene mdas refuses counts as failed, its stderr shown),
2 usage or setup error (no binary, Mitsuba missing, a scene Mitsuba cannot
load).

Checks, per scene
-----------------
Notation: N pixels, K seeds; for renderer R (A = mdas, B = Mitsuba) and a
channel, X_k is seed k's image, s²_i the sample variance (ddof 1) of pixel i
over the K seeds.

1. Image means, per channel. m_R = mean over seeds of the image mean; the
   difference d = m_A - m_B. Its variance is estimated from the per-pixel
   variances, Var(m_R) = sum_i s²_i / (K N²): with a box reconstruction
   filter every sample lands in one pixel, and both renderers draw each
   pixel's samples independently of the other pixels' (Mitsuba's
   independent sampler seeds a stream per pixel; mdas's Halton rotates
   every pixel by its own hash), so the pixel estimates of one seed are
   independent and the variance of their mean is the sum of theirs over N².
   This pooled estimate has the Welch–Satterthwaite dof
   nu = (sum_j c_j s²_j)² / sum_j (c_j s²_j)² / (K - 1) over both
   renderers' pixels (thousands unless a few pixels dominate the
   variance), where the K image means alone would give only 3–6 dof (a
   two-sided 1e-4 Student-t quantile of ~9–28 instead of ~3.9: 5–50x the
   samples for the same power).
   Pass iff |d| <= t·sigma + 0.0005·|m_B|, with sigma² = Var(m_A) +
   Var(m_B) and t the Student-t quantile at 1 - 1e-4/2 (two-sided 1e-4) for
   nu dof: a false alarm with probability 1e-4 per channel (~2e-3 for the
   18 channel tests of a full run; the fixed 4 sigma of the issue is the
   same to within t(inf) = 3.89). The 0.05 % allowance absorbs
   deterministic differences that are not bugs: mdas tessellates analytic
   spheres (1e-4 relative area error), and f32 GPU arithmetic against
   Mitsuba's.
   The check is also failed as *too weak* when t·sigma / |m_B| > 0.2 %
   (the issue's agreement target): then passing would not show agreement
   at 0.2 %. SCENES' sample counts keep it near 0.1 % (see the table).
   Guard for the independence assumption: the variance of the K seed means
   around their mean (dof K - 1) divided by the pooled Var(m_R) follows
   chi²_{K-1}/(K-1) when pixels are independent; a ratio above that
   distribution's 1 - 1e-4 quantile (7.0 for K = 4) means the pixels of one
   seed are correlated (say, one random offset for the whole image) and the
   pooled sigma is too small: the scene fails ("seed spread").

2. Per-pixel RelMSE of the K-seed means, A_bar against B_bar:
   measured = mean over pixels and channels of (A_bar - B_bar)² / (B_bar² + 0.01),
   predicted = mean over pixels and channels of (s²_A/K + s²_B/K) / (B_bar² + 0.01),
   the value expected from noise alone. Pass iff measured <= 1.5 x predicted.
   Why 1.5: measured is a weighted sum of chi²_1 terms and predicted one of
   (sums of) chi²_{K-1}/(K-1) terms, with weights w_i ~ pixel variance /
   (B² + 0.01); with N_eff = (sum w)² / sum w² effective terms the ratio has
   a standard deviation of about sqrt((2 + 2/(K-1)) / N_eff) (Gaussian
   pixels). These scenes have N_eff from ~300 (thinlens: the variance sits
   on the blurred edges) to ~4000 of their 3 x 3072 terms (printed per
   scene), sd 0.03-0.1. Measured on Mitsuba against itself (30 self-tests,
   6 scenes x 5 disjoint seed sets, these spp): ratio 0.83-1.07, mean 0.98,
   sd 0.05, so 1.5 is ~10 sd above the mean (>= 5 sd for thinlens) and
   leaves room for heavier-tailed noise. A geometric error (a mirrored or
   shifted image, a missing shadow) adds its squared difference at every
   pixel it touches and fails even when the means agree (a 1 % wider fov:
   ratio ~10; shading the smooth PLY sphere flat: ~1.8); a scene whose
   N_eff is below 100 fails as too weak.

--self-test: the mdas side is Mitsuba itself with seeds K..2K-1 (at mdas's
sample counts): it must pass; the same images times 1.01 and mirrored left
to right must fail, and so must Mitsuba renders of "mutants" of some scenes
(MUTANTS: the kind of mistake a scene loader makes, e.g. max_depth off by
one, a one-sided surface made two-sided, aperture radius read as a
diameter). Exit 0 only if every variant behaves, on every scene.
Checked on Mitsuba against itself, 72 channel tests: |d|/sigma had rms 1.03
and max 2.35, the seed spread max 4.4 (limit 7.0).

Mitsuba seeds: Mitsuba's scalar render seeds pixel streams with
seed·W·H + block_id·32² + i, so consecutive seeds overlap when the 32x32
blocks overhang the film (64x48 -> 4 blocks = 4096 streams > 3072); this
script passes seed = stride·k with a stride that avoids the overlap.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE_DIR = os.path.join(HERE, "scenes")

K = 4                      # seeds per renderer
MITSUBA_SPP_FACTOR = 4     # Mitsuba renders 4x mdas's spp: cheap here, cuts sigma by ~1.3x
ALPHA = 1e-4               # two-sided false-alarm probability per check
REL_ALLOWANCE = 5e-4       # deterministic differences allowed (0.05 %)
REL_TARGET = 2e-3          # a check weaker than 0.2 % fails as "too weak"
RELMSE_FACTOR = 1.5        # measured RelMSE must be <= 1.5 x predicted
RELMSE_EPS = 0.01          # RelMSE denominator B² + 0.01
MIN_NEFF = 100             # below this the RelMSE ratio is too noisy to trust

# Scene -> mdas samples per pixel (Mitsuba renders MITSUBA_SPP_FACTOR times
# as many) and the mdas integrand the scene should map to. The spp keep the
# mean check's t·sigma/mean at ~0.1 % (< 0.2 %) if mdas's per-sample
# variance is no larger than Mitsuba's, as in the self-test; mdas total =
# K x 3072 x sum(spp) = 17.3 M samples. Measured against mdas (Halton,
# lavapipe): t·sigma 0.03-0.09 %; mdas's variance per sample was far below
# Mitsuba's in the delta-light scenes and ~6x above it in path_cornell.
SCENES = {
    "area_direct": (192, "area-light direct lighting (perspective)"),
    "delta_lights": (256, "direct lighting of delta lights: point + directional"),
    "thinlens": (128, "direct lighting of delta lights, thin lens"),
    "ply_sphere": (64, "area-light direct lighting (perspective), disk light"),
    "ply_wound": (64, "area-light direct lighting, PLY spheres wound against their vertex normals, disk + point light"),
    "path_cornell": (320, "path, max_depth 4 (2 indirect bounces), area light"),
    "path_mixed": (448, "path, max_depth 3 (1 indirect bounce), area + point + directional"),
    "checker": (256, "area-light direct lighting, checkerboard textures (rectangle, cube, PLY u v)"),
}

# Self-test mutants: scene -> (label, XML text, replacement). Mitsuba renders
# the changed scene as the "mdas" side, which must fail. Each one changes the
# image well beyond the checks' noise (the mean or the RelMSE ratio by >5x).
MUTANTS = {
    "area_direct": [("one-sided card made two-sided",
                     '<bsdf type="diffuse">\n            <rgb name="reflectance" value="0.8, 0.8, 0.3"/>\n'
                     '        </bsdf>',
                     '<bsdf type="twosided"><bsdf type="diffuse">\n'
                     '            <rgb name="reflectance" value="0.8, 0.8, 0.3"/>\n        </bsdf></bsdf>')],
    "delta_lights": [("fov 1 % wider", '<float name="fov" value="40"/>', '<float name="fov" value="40.4"/>')],
    "thinlens": [("aperture radius read as a diameter", '<default name="aperture" value="0.08"/>',
                  '<default name="aperture" value="0.04"/>')],
    "path_cornell": [("max_depth 3 instead of 4", '<default name="max_depth" value="4"/>',
                      '<default name="max_depth" value="3"/>')],
}

CHANNELS = "RGB"


class SetupError(Exception):
    """Not a failed check: the harness cannot run (exit status 2)."""


class MdasError(Exception):
    """mdas refused the scene or wrote an unusable image (a failed check)."""


# ----------------------------------------------------------------------------
# Distributions (math only: no scipy)


def _betacf(a, b, x):
    """Continued fraction of the incomplete beta function (modified Lentz)."""
    tiny = 1e-300
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 100000):
        m2 = 2 * m
        for aa in (m * (b - m) * x / ((qam + m2) * (a + m2)),
                   -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))):
            d = 1.0 + aa * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + aa / c
            c = c if abs(c) > tiny else tiny
            h *= d * c
        if abs(d * c - 1.0) < 1e-15:
            return h
    raise ArithmeticError("incomplete beta: no convergence")


def betainc(a, b, x):
    """Regularized incomplete beta function I_x(a, b)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    lbt = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(lbt) * _betacf(a, b, x) / a
    return 1.0 - math.exp(lbt) * _betacf(b, a, 1.0 - x) / b


def gammaincc(a, x):
    """Regularized upper incomplete gamma function Q(a, x)."""
    if x <= 0.0:
        return 1.0
    lpre = -x + a * math.log(x) - math.lgamma(a)
    if x < a + 1.0:  # series for P
        term = s = 1.0 / a
        n = a
        while abs(term) > abs(s) * 1e-16:
            n += 1.0
            term *= x / n
            s += term
        return 1.0 - s * math.exp(lpre)
    tiny = 1e-300  # continued fraction for Q
    b = x + 1.0 - a
    c, d = 1.0 / tiny, 1.0 / b
    h = d
    for i in range(1, 100000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = b + an / c
        c = c if abs(c) > tiny else tiny
        h *= d * c
        if abs(d * c - 1.0) < 1e-15:
            return math.exp(lpre) * h
    raise ArithmeticError("incomplete gamma: no convergence")


def _solve_decreasing(f, target, lo, hi):
    """x in [lo, hi] with f(x) = target, f decreasing (bisection in x)."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if f(mid) > target:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * hi:
            break
    return 0.5 * (lo + hi)


def t_two_sided_quantile(alpha, nu):
    """t with P(|T_nu| > t) = alpha (nu may be fractional)."""
    if nu > 1e5:  # normal limit
        return _solve_decreasing(lambda t: math.erfc(t / math.sqrt(2.0)), alpha, 0.0, 50.0)
    return _solve_decreasing(lambda t: betainc(nu / 2.0, 0.5, nu / (nu + t * t)), alpha, 0.0, 1e6)


def chi2_upper_quantile(alpha, k):
    """x with P(chi²_k > x) = alpha."""
    return _solve_decreasing(lambda x: gammaincc(k / 2.0, x / 2.0), alpha, 0.0, 1e4)


# ----------------------------------------------------------------------------
# Renderers


def load_mitsuba():
    try:
        import mitsuba as mi
        import numpy as np  # noqa: F401
    except ImportError as e:
        raise SetupError(f"cannot import mitsuba/numpy ({e}); run .ci/crosscheck.sh") from e
    mi.set_variant("scalar_rgb")
    return mi


class MitsubaScene:
    def __init__(self, mi, path, replace=None):
        """The scene at path; replace = (old, new) edits its XML text first."""
        self.mi = mi
        try:
            if replace is None:
                self.scene = mi.load_file(path)
            else:
                with open(path) as fh:
                    text = fh.read()
                if text.count(replace[0]) != 1:
                    raise SetupError(f"mutant of {path}: text to replace not found once: {replace[0]!r}")
                # Relative file names resolve against the scene's folder.
                mi.file_resolver().prepend(os.path.dirname(os.path.abspath(path)))
                self.scene = mi.load_string(text.replace(*replace))
        except SetupError:
            raise
        except Exception as e:  # a scene Mitsuba cannot load is a broken test
            raise SetupError(f"Mitsuba cannot load {path}: {e}") from e
        w, h = (int(v) for v in self.scene.sensors()[0].film().crop_size())
        self.size = (w, h)
        # Seeds with disjoint pixel-stream ranges (see the docstring).
        blocks = math.ceil(w / 32) * math.ceil(h / 32)
        self.seed_stride = max(1, math.ceil(blocks * 32 * 32 / (w * h)))

    def render(self, k, spp):
        import numpy as np
        img = np.array(self.mi.render(self.scene, seed=self.seed_stride * k, spp=spp), dtype=np.float64)
        return img[..., :3]


def render_mdas(mi, binary, scene_path, seed, spp, out_exr, size):
    import numpy as np
    cmd = [binary, "render", scene_path, "--integrator", "halton", "--spp", str(spp),
           "--seed", str(seed), "-q", "-o", out_exr]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    except subprocess.TimeoutExpired as e:
        raise MdasError(f"timed out after 900 s: {' '.join(cmd)}") from e
    if proc.returncode != 0:
        raise MdasError(f"exit status {proc.returncode}: {' '.join(cmd)}\n{proc.stderr.strip()}")
    try:
        bmp = mi.Bitmap(out_exr)
    except Exception as e:
        raise MdasError(f"cannot read {out_exr}: {e}") from e
    img = np.array(bmp, dtype=np.float64)
    w, h = size
    if img.shape != (h, w, 3):
        raise MdasError(f"{out_exr}: image of shape {img.shape} ({bmp.pixel_format()}), "
                        f"expected ({h}, {w}, 3) RGB")
    return img


# ----------------------------------------------------------------------------
# Statistics


def compare(a, b):
    """Checks of mdas images a against Mitsuba images b, both (K, H, W, 3)."""
    import numpy as np
    ka, kb = a.shape[0], b.shape[0]
    n = a.shape[1] * a.shape[2]
    t_seed_limit = chi2_upper_quantile(ALPHA, ka - 1) / (ka - 1)
    s2a = a.var(axis=0, ddof=1)          # (H, W, 3) per-pixel variance over seeds
    s2b = b.var(axis=0, ddof=1)
    abar, bbar = a.mean(axis=0), b.mean(axis=0)
    checks, failures = [], []
    for c, name in enumerate(CHANNELS):
        ma, mb = a[..., c].mean(axis=(1, 2)), b[..., c].mean(axis=(1, 2))  # per-seed image means
        mean_a, mean_b = ma.mean(), mb.mean()
        ca, cb = s2a[..., c] / (ka * n * n), s2b[..., c] / (kb * n * n)
        var_a, var_b = ca.sum(), cb.sum()
        sigma = math.sqrt(var_a + var_b)
        den = (ca ** 2).sum() / (ka - 1) + (cb ** 2).sum() / (kb - 1)
        nu = (var_a + var_b) ** 2 / den if den > 0 else float("inf")
        t = t_two_sided_quantile(ALPHA, nu) if math.isfinite(nu) else 0.0
        d = mean_a - mean_b
        bound = t * sigma + REL_ALLOWANCE * abs(mean_b)
        rel = lambda x: x / abs(mean_b) if mean_b != 0 else float("inf")
        ok_mean = abs(d) <= bound
        strong = rel(t * sigma) <= REL_TARGET
        # seed spread over pooled variance, ~ chi²_{K-1}/(K-1) if pixels are independent
        spread = []
        for m, v, k in ((ma, var_a, ka), (mb, var_b, kb)):
            spread.append(float(m.var(ddof=1) / k / v) if v > 0 else (0.0 if m.var() == 0 else float("inf")))
        ok_spread = all(s <= t_seed_limit for s in spread)
        checks.append({
            "channel": name, "mean_mdas": float(mean_a), "mean_mitsuba": float(mean_b),
            "se_mdas_seeds": float(ma.std(ddof=1) / math.sqrt(ka)),
            "se_mitsuba_seeds": float(mb.std(ddof=1) / math.sqrt(kb)),
            "se_mdas": math.sqrt(var_a), "se_mitsuba": math.sqrt(var_b),
            "sigma": sigma, "dof": nu, "t": t, "diff": float(d), "bound": float(bound),
            "rel_diff": float(rel(d)), "rel_bound": float(rel(bound)), "rel_t_sigma": float(rel(t * sigma)),
            "seed_spread_mdas": spread[0], "seed_spread_mitsuba": spread[1],
            "seed_spread_limit": t_seed_limit,
            "pass_mean": bool(ok_mean), "strong_enough": bool(strong), "pass_seed_spread": bool(ok_spread),
        })
        if not ok_mean:
            failures.append(f"{name} mean differs: {100 * rel(d):+.3f} % (bound {100 * rel(bound):.3f} %)")
        if not strong:
            failures.append(f"{name} mean check too weak: t*sigma = {100 * rel(t * sigma):.3f} % > "
                            f"{100 * REL_TARGET:.1f} % (more spp needed)")
        if not ok_spread:
            failures.append(f"{name} seed spread {max(spread):.1f}x the pooled pixel variance "
                            f"(limit {t_seed_limit:.1f}): pixels of a seed are correlated")
    denom = bbar ** 2 + RELMSE_EPS
    w = (s2a / ka + s2b / kb) / denom
    measured = float(((abar - bbar) ** 2 / denom).mean())
    predicted = float(w.mean())
    neff = float(w.sum() ** 2 / (w ** 2).sum()) if (w ** 2).sum() > 0 else 0.0
    ratio = measured / predicted if predicted > 0 else float("inf")
    ratio_sd = math.sqrt((2.0 + 2.0 / (min(ka, kb) - 1)) / neff) if neff > 0 else float("inf")
    ok_relmse = ratio <= RELMSE_FACTOR
    if not ok_relmse:
        failures.append(f"RelMSE {measured:.3g} is {ratio:.2f}x the predicted {predicted:.3g} "
                        f"(limit {RELMSE_FACTOR}x)")
    if neff < MIN_NEFF:
        failures.append(f"RelMSE check too weak: N_eff {neff:.0f} < {MIN_NEFF}")
    relmse = {"measured": measured, "predicted": predicted, "ratio": ratio, "limit": RELMSE_FACTOR,
              "n_eff": neff, "ratio_sd_approx": ratio_sd, "pass": bool(ok_relmse and neff >= MIN_NEFF)}
    return {"channels": checks, "relmse": relmse, "failures": failures, "pass": not failures}


# ----------------------------------------------------------------------------
# Output


def write_image(mi, path, img):
    import numpy as np
    bmp = mi.Bitmap(np.ascontiguousarray(img, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    bmp.write(path)
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(path[:-4] + ".png")


def print_result(label, res, out=sys.stdout):
    if len(label) > 28:
        print(label, file=out)
        label = ""
    for ch in res["channels"]:
        ok = ch["pass_mean"] and ch["strong_enough"] and ch["pass_seed_spread"]
        print(f"{label:<28} {ch['channel']}  {ch['mean_mdas']:10.6f}  {ch['mean_mitsuba']:12.6f}  "
              f"{100 * ch['rel_diff']:+8.3f}  {100 * ch['rel_bound']:7.3f}  {100 * ch['rel_t_sigma']:7.3f}  "
              f"{ch['dof']:8.0f}  {max(ch['seed_spread_mdas'], ch['seed_spread_mitsuba']):6.2f}  "
              f"{'pass' if ok else 'FAIL'}", file=out)
        label = ""
    r = res["relmse"]
    print(f"{'':<28} RelMSE {r['measured']:.4g} vs predicted {r['predicted']:.4g}: ratio {r['ratio']:.3f} "
          f"(limit {r['limit']}, N_eff {r['n_eff']:.0f}, sd ~{r['ratio_sd_approx']:.3f})  "
          f"{'pass' if r['pass'] else 'FAIL'}", file=out)
    for f in res["failures"]:
        print(f"{'':<28} ! {f}", file=out)


HEADER = (f"{'scene':<28} ch  {'mean_mdas':>10}  {'mean_mitsuba':>12}  {'diff %':>8}  {'bound %':>7}  "
          f"{'t·σ %':>7}  {'dof':>8}  {'spread':>6}  pass")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mdas", help="path of the mdas binary (not needed with --self-test)")
    p.add_argument("--out", required=True, help="output directory (summary.json, mean images)")
    p.add_argument("--scenes", help="comma-separated scene names (default: all): " + ",".join(SCENES))
    p.add_argument("--self-test", action="store_true",
                   help="use Mitsuba (seeds K..2K-1) as the mdas side; checks the harness itself")
    args = p.parse_args(argv)

    try:
        names = list(SCENES) if not args.scenes else [s.strip() for s in args.scenes.split(",") if s.strip()]
        unknown = [s for s in names if s not in SCENES]
        if unknown or not names:
            raise SetupError(f"unknown scene(s) {','.join(unknown) or '(none)'}; known: {','.join(SCENES)}")
        mdas = None
        if not args.self_test:
            if not args.mdas:
                raise SetupError("--mdas PATH is required (or --self-test)")
            mdas = os.path.abspath(args.mdas)
            if not (os.path.isfile(mdas) and os.access(mdas, os.X_OK)):
                raise SetupError(f"mdas binary not found or not executable: {args.mdas}")
        mi = load_mitsuba()
        os.makedirs(args.out, exist_ok=True)
        return run(mi, names, mdas, args)
    except SetupError as e:
        print(f"crosscheck: error: {e}", file=sys.stderr)
        return 2


def run(mi, names, mdas, args):
    import numpy as np
    t_start = time.time()
    summary = {"k": K, "alpha": ALPHA, "rel_allowance": REL_ALLOWANCE, "rel_target": REL_TARGET,
               "relmse_factor": RELMSE_FACTOR, "self_test": bool(args.self_test),
               "mitsuba": mi.__version__, "mdas": mdas, "scenes": {}}
    table = []
    all_ok = True
    for name in names:
        path = os.path.join(SCENE_DIR, name + ".xml")
        spp_mdas, integrand = SCENES[name]
        spp_mts = spp_mdas * MITSUBA_SPP_FACTOR
        scene_out = os.path.join(args.out, name)
        os.makedirs(scene_out, exist_ok=True)
        print(f"[{name}] Mitsuba {K} x {spp_mts} spp ...", file=sys.stderr, flush=True)
        scene = MitsubaScene(mi, path)
        t0 = time.time()
        b = np.stack([scene.render(k, spp_mts) for k in range(K)])
        t_mts = time.time() - t0
        entry = {"xml": os.path.relpath(path, HERE), "integrand": integrand, "size": scene.size,
                 "spp_mdas": spp_mdas, "spp_mitsuba": spp_mts, "mitsuba_seeds":
                 [scene.seed_stride * k for k in range(K)], "time_mitsuba_s": t_mts}
        if args.self_test:
            print(f"[{name}] Mitsuba as mdas, {K} x {spp_mdas} spp ...", file=sys.stderr, flush=True)
            t0 = time.time()
            a = np.stack([scene.render(k, spp_mdas) for k in range(K, 2 * K)])
            variants = {"same": (a, True), "scaled_1.01": (a * 1.01, False), "mirrored": (a[:, :, ::-1], False)}
            for label, old, new in MUTANTS.get(name, []):
                print(f"[{name}] Mitsuba mutant ({label}) as mdas ...", file=sys.stderr, flush=True)
                mutant = MitsubaScene(mi, path, (old, new))
                variants["mutant: " + label] = (np.stack([mutant.render(k, spp_mdas) for k in range(K, 2 * K)]),
                                                False)
            entry["time_mitsuba_as_mdas_s"] = time.time() - t0
            entry["variants"] = {}
            for vname, (img, expect_pass) in variants.items():
                res = compare(img, b)
                res["expected_pass"] = expect_pass
                res["behaved"] = res["pass"] == expect_pass
                all_ok &= res["behaved"]
                entry["variants"][vname] = res
                table.append((f"{name} [{vname}]", res,
                              ("as expected" if res["behaved"] else "UNEXPECTED") +
                              (" (must pass)" if expect_pass else " (must fail)")))
            write_image(mi, os.path.join(scene_out, "mdas_mean.exr"), a.mean(axis=0))
        else:
            print(f"[{name}] mdas {K} x {spp_mdas} spp ...", file=sys.stderr, flush=True)
            t0 = time.time()
            try:
                a = np.stack([render_mdas(mi, mdas, path, k, spp_mdas,
                                          os.path.join(scene_out, f"mdas_seed{k}.exr"), scene.size)
                              for k in range(K)])
            except MdasError as e:
                entry["time_mdas_s"] = time.time() - t0
                entry["error"] = str(e)
                entry["pass"] = False
                all_ok = False
                summary["scenes"][name] = entry
                table.append((name, None, f"FAIL: mdas: {e}"))
                print(f"[{name}] mdas failed: {e}", file=sys.stderr)
                continue
            entry["time_mdas_s"] = time.time() - t0
            entry["mdas_seeds"] = list(range(K))
            res = compare(a, b)
            entry.update(res)
            all_ok &= res["pass"]
            table.append((name, res, "pass" if res["pass"] else "FAIL"))
            write_image(mi, os.path.join(scene_out, "mdas_mean.exr"), a.mean(axis=0))
        write_image(mi, os.path.join(scene_out, "mitsuba_mean.exr"), b.mean(axis=0))
        summary["scenes"][name] = entry

    print()
    print(HEADER)
    for label, res, verdict in table:
        if res is None:
            print(f"{label:<28} {verdict}")
            continue
        print()
        print_result(label, res)
        print(f"{'':<28} => {verdict}")
    print()
    for name, e in summary["scenes"].items():
        times = f"Mitsuba {e['time_mitsuba_s']:.1f} s ({K} x {e['spp_mitsuba']} spp)"
        if "time_mdas_s" in e:
            times += f", mdas {e['time_mdas_s']:.1f} s ({K} x {e['spp_mdas']} spp)"
        if "time_mitsuba_as_mdas_s" in e:
            times += f", Mitsuba as mdas {e['time_mitsuba_as_mdas_s']:.1f} s ({K} x {e['spp_mdas']} spp)"
        print(f"{name:<14} {times}")
    total = time.time() - t_start
    summary["time_total_s"] = total
    summary["pass"] = bool(all_ok)
    print(f"total {total:.1f} s: {'all checks behaved' if args.self_test and all_ok else ''}"
          f"{'PASS' if all_ok and not args.self_test else ''}{'' if all_ok else 'FAIL'}")
    with open(os.path.join(args.out, "summary.json"), "w") as fh:
        json.dump(summary, fh, indent=1)
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
