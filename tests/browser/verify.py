"""Checks the screenshots drive.mjs took of mdas's index.html pages against
the run's files, read here with readers independent of mdas (the OpenEXR
and pypng packages, numpy): .ci/browser-test.sh.

For every step, every film pixel whose square lies wholly inside the
canvas (and outside the label drawn over it) is looked up in the
screenshot at the screen pixel holding the square's centre: the canvas
draws film pixel (x, y) over left + ox + [x, x + 1)·zoom (and likewise in
y), as the page's test hook states. Steps below zoom 2 are not checked
pixel by pixel (nearest-neighbour minification picks pixels as the
browser pleases).

Expected values:
  an image at exposure s: sRGB8(clamp(2^s · v, 0, 1)) of the EXR's float v
      (NaN as 0), tolerance ±1 code value: the page stores v as a half
      float (relative error ≤ 2^-11), which moves the encoded value by at
      most 255 · (1.055/2.4) · 2^-11 ≈ 0.055 codes, so rounding to 8 bits
      can differ by one code, never two;
  a map layer (opacity 1): the map PNG's own bytes, exactly.
Each step also has a control that must fail (the same image one stop
brighter; for a map, the image under it), so that a check that would pass
anything is caught.
The inspector's numbers (4 significant digits of the half) are checked
against the EXR to 1e-3 relative.

    python verify.py STEPS.json
Exit status 0 when every check passes, 1 otherwise.
"""

import json
import math
import os
import sys

import numpy as np
import OpenEXR
import png

IMAGE_TOLERANCE = 1
MAP_TOLERANCE = 0


def read_exr(path):
    with OpenEXR.File(path) as f:
        channels = f.channels()
        if "RGB" in channels:
            rgb = channels["RGB"].pixels
        else:
            rgb = np.stack([channels[c].pixels for c in "RGB"], axis=-1)
        return np.asarray(rgb, dtype=np.float32)


def read_png(path):
    width, height, rows, _ = png.Reader(filename=path).asRGB8()
    return np.vstack([np.frombuffer(bytes(r), dtype=np.uint8) for r in rows]).reshape(
        height, width, 3
    )


def srgb8(v, stops):
    v = np.nan_to_num(v.astype(np.float64) * 2.0**stops, nan=0.0, posinf=1.0, neginf=0.0)
    v = np.clip(v, 0.0, 1.0)
    s = np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)
    return np.floor(s * 255.0 + 0.5).astype(np.int32)


cache = {}


def load(path, reader):
    if path not in cache:
        cache[path] = reader(path)
    return cache[path]


def check_step(base, step):
    s = step["state"]
    directory = os.path.join(base, step["page"]) if not os.path.isabs(step["page"]) else step["page"]
    zoom, ox, oy = s["zoom"], s["ox"], s["oy"]
    if zoom < 2:
        return 0, f"{step['name']}: zoom {zoom:.3g} < 2, not checked pixel by pixel"
    shot = load(os.path.join(base, step["shot"]), read_png).astype(np.int32)
    width, height = s["film"]
    c = s["canvas"]
    xs = np.arange(width)
    ys = np.arange(height)
    x0 = c["left"] + ox + xs * zoom
    y0 = c["top"] + oy + ys * zoom
    inside_x = (x0 >= c["left"]) & (x0 + zoom <= c["left"] + c["width"]) & (x0 + zoom <= shot.shape[1])
    inside_y = (y0 >= c["top"]) & (y0 + zoom <= c["top"] + c["height"]) & (y0 + zoom <= shot.shape[0])
    fx, fy = xs[inside_x], ys[inside_y]
    if len(fx) == 0 or len(fy) == 0:
        return 1, f"{step['name']}: no film pixel wholly on the canvas"
    sx = np.floor(c["left"] + ox + (fx + 0.5) * zoom).astype(int)
    sy = np.floor(c["top"] + oy + (fy + 0.5) * zoom).astype(int)
    got = shot[np.ix_(sy, sx)]
    keep = np.ones((len(fy), len(fx)), dtype=bool)
    for r in step["exclude"]:
        ex = (sx >= r["x"] - 1) & (sx <= r["x"] + r["width"] + 1)
        ey = (sy >= r["y"] - 1) & (sy <= r["y"] + r["height"] + 1)
        keep &= ~np.outer(ey, ex)
    values = load(os.path.join(directory, s["file"]), read_exr)[np.ix_(fy, fx)]
    if s["mapFile"]:
        want = load(os.path.join(directory, s["mapFile"]), read_png)[np.ix_(fy, fx)].astype(np.int32)
        tolerance, what = MAP_TOLERANCE, s["mapFile"]
        # Control: the image under the map would not pass for it.
        control = srgb8(values, s["stops"])
    else:
        want = srgb8(values, s["stops"])
        tolerance, what = IMAGE_TOLERANCE, f"{s['file']} at {s['stops']:+.1f} stops"
        # Control: the same image one stop brighter would not pass for it.
        control = srgb8(values, s["stops"] + 1)
    diff = np.abs(got - want).max(axis=-1)
    diff[~keep] = 0
    worst = int(diff.max())
    n = int(keep.sum())
    off = int((diff > 0).sum())
    control_worst = int(np.where(keep, np.abs(got - control).max(axis=-1), 0).max())
    message = (
        f"{step['name']}: {what}, zoom {zoom:g}, {n} film pixels "
        f"({len(fx)}×{len(fy)} from ({fx[0]}, {fy[0]})), largest difference {worst} "
        f"(tolerance {tolerance}; {off} pixels off by any), control {control_worst}"
    )
    if control_worst <= tolerance:
        return 1, message + "; the control passes too: this step cannot tell what it shows"
    if worst > tolerance:
        j, i = np.unravel_index(np.argmax(diff), diff.shape)
        message += f"; film pixel ({fx[i]}, {fy[j]}): screen {got[j, i].tolist()}, expected {want[j, i].tolist()}"
        return 1, message
    return 0, message


def check_inspector(base, step, previous):
    s = previous["state"]
    directory = os.path.join(base, step["page"]) if not os.path.isabs(step["page"]) else step["page"]
    x, y = step["pixel"]
    names = {label: None for label in s["images"]}
    report = json.load(open(os.path.join(directory, "report.json")))
    files = {"reference": report["files"].get("reference", "reference.exr")}
    for m in report["methods"]:
        files[m["name"]] = m["image"]
    bad = []
    for row in step["inspector"]:
        label, values = row[0], [float(t.replace("∞", "inf").replace("—", "nan")) for t in row[1:4]]
        want = load(os.path.join(directory, files[label]), read_exr)[y, x]
        for got, v in zip(values, want):
            if not (math.isclose(got, float(v), rel_tol=1e-3, abs_tol=1e-7) or (math.isnan(got) and math.isnan(v))):
                bad.append(f"{label}: {values} for {want.tolist()}")
                break
        names.pop(label, None)
    if names:
        bad.append(f"no row for {list(names)}")
    if bad:
        return 1, f"inspector at ({x}, {y}): " + "; ".join(bad)
    return 0, f"inspector at ({x}, {y}): {len(step['inspector'])} images' linear RGB within 1e-3"


def main():
    path = sys.argv[1]
    base = os.path.dirname(os.path.abspath(path))
    record = json.load(open(path))
    failed = 0
    checked = 0
    previous = None
    for step in record["steps"]:
        if "inspector" in step:
            bad, message = check_inspector(base, step, previous)
        else:
            bad, message = check_step(base, step)
            previous = step
        failed += bad
        checked += 1
        print(("FAIL: " if bad else "ok    ") + message)
    print(f"verify: {checked} steps, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
