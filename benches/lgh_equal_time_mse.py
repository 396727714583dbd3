#!/usr/bin/env python3
"""The grid hierarchy's default decided by equal-time MSE (issue 66 item 4,
BENCHMARKS.md): per scene, the paper's configuration (S1 first) and
lgh_level0 = true, two seeds each at 64 spp, MSE against a tree reference
split into variance (half the mean squared difference of the two seeds)
and the rest (bias² and the reference's noise); at equal time the
variance scales by the evaluate-time ratio. Paths are those of the run
recorded; needs numpy and mitsuba (target/mitsuba-venv)."""
import numpy as np, mitsuba as mi
mi.set_variant('scalar_rgb')
rd = lambda p: np.array(mi.Bitmap(p), dtype=np.float64)[..., :3]
# Evaluate-time ratios level 0 / S1 first, measured in the same run (pairs interleaved).
ratio = {'vap': 1.44, 'va': 1.50, 'l1m': 0.95}
refs = {'vap': '/work/lgh/vap-ref.exr', 'va': '/work/lgh/va-ref.exr', 'l1m': '/work/lgh/l1m-ref.exr'}
for sc in ['vap', 'va', 'l1m']:
    ref = rd(refs[sc])
    out = []
    for cfg in ['s1', 'l0']:
        x = [rd(f'/work/lgh/eq-{sc}-{cfg}-{s}.exr') for s in (1, 2)]
        mse = np.mean([np.mean((xi - ref) ** 2) for xi in x])
        var = np.mean((x[0] - x[1]) ** 2) / 2
        b2 = mse - var
        t = 1.0 if cfg == 's1' else ratio[sc]
        eq = b2 + var * t
        bias = np.mean([xi[..., 1].sum() / ref[..., 1].sum() - 1 for xi in x])
        out.append((cfg, bias, mse, var, b2, eq))
    for cfg, bias, mse, var, b2, eq in out:
        print(f"{sc} {cfg}: G bias {bias*100:+.2f} %, MSE {mse:.4e} (variance {var:.3e}, bias² {b2:.3e}), equal-time MSE {eq:.4e}")
    print(f"{sc}: level 0 / S1 first at equal time: {out[1][5]/out[0][5]:.3f}")
