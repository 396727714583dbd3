"""Bias over seeds: for each method X, the renders DIR/X-<seed>.exr against
DIR/ref.exr. Prints the relative bias of the film's sum per channel (mean
over the K seeds, ± the 95 % t interval) and the per-pixel MSE split:
bias² = mean((mean image − ref)²) − variance/K, variance = the mean
per-pixel variance of one render over the seeds; and how much of that
variance the top 1 % of pixels hold. Usage: seed_bias.py DIR X [X ...]"""
import glob
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
T975 = {2: 12.706, 3: 4.303, 4: 3.182, 5: 2.776, 6: 2.571, 7: 2.447, 8: 2.365}


def read(path):
    return np.array(mi.Bitmap(path))[..., :3].astype(np.float64)


d = sys.argv[1]
ref = read(f"{d}/ref.exr")
for k in sys.argv[2:]:
    imgs = np.stack([read(f) for f in sorted(glob.glob(f"{d}/{k}-[0-9]*.exr"))])
    n = len(imgs)
    rel = 100 * (imgs.sum((1, 2)) / ref.sum((0, 1)) - 1)
    m, se = rel.mean(0), rel.std(0, ddof=1) / np.sqrt(n)
    pixel_var = imgs.var(0, ddof=1).mean(-1).ravel()
    var = pixel_var.mean()
    bias2 = max(((imgs.mean(0) - ref) ** 2).mean() - var / n, 0.0)
    top = np.sort(pixel_var)[-len(pixel_var) // 100:].sum() / pixel_var.sum()
    bias = " / ".join(f"{a:+.2f}±{T975[n] * b:.2f}" for a, b in zip(m, se))
    print(f"{k:12s} K={n} bias R/G/B % = {bias}  MSE: bias² {bias2:.3e} + variance {var:.3e}"
          f" (median pixel {np.median(pixel_var):.3e}, top 1 % of pixels {top:.0%})")
