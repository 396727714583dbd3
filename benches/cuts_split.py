#!/usr/bin/env python3
"""Where the MSE of `benches/cuts.sh`'s runs comes from: for each run
directory, the MSE of `halton-tree` and `halton-tree_nocut` against the
reference over the whole image and split by the reference's luminance
(mean of R, G, B) at THRESHOLD (default 0.3): in `cornell_lights` the pixels
above it are the lamps seen directly and their silhouettes, whose error is
the film's (anti-aliasing) variance, not the lighting's.

Usage: benches/cuts_split.py [--threshold T] RUN_DIR...
Needs numpy. Reads the EXRs mdas writes (scanline, float32, uncompressed
or ZIP) with the small reader below."""
import struct
import sys
import zlib

import numpy as np


def read_exr(path):
    """RGB float64 image (H, W, 3) of a scanline float32 EXR."""
    b = open(path, "rb").read()
    assert b[:4] == b"\x76\x2f\x31\x01", f"{path}: not an EXR"
    i, attrs = 8, {}
    while b[i] != 0:
        j = b.index(0, i); name = b[i:j].decode(); i = j + 1
        j = b.index(0, i); i = j + 1
        size = struct.unpack("<i", b[i:i + 4])[0]; i += 4
        attrs[name] = b[i:i + size]; i += size
    i += 1
    comp = attrs["compression"][0]
    x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    cb, chans, k = attrs["channels"], [], 0
    while cb[k] != 0:
        j = cb.index(0, k); n = cb[k:j].decode(); k = j + 1
        assert struct.unpack("<i", cb[k:k + 4])[0] == 2, "float32 channels only"
        k += 16
        chans.append(n)
    lines = {0: 1, 2: 1, 3: 16}[comp]
    blocks = (h + lines - 1) // lines
    offsets = struct.unpack("<%dQ" % blocks, b[i:i + 8 * blocks])
    out = {n: np.zeros((h, w), np.float32) for n in chans}
    for o in offsets:
        y, size = struct.unpack("<ii", b[o:o + 8])
        data = b[o + 8:o + 8 + size]
        nl = min(lines, h - (y - y0))
        if comp != 0 and len(data) != nl * w * 4 * len(chans):
            t = bytearray(zlib.decompress(data))
            for q in range(1, len(t)):
                t[q] = (t[q - 1] + t[q] - 128) & 255
            half = (len(t) + 1) // 2
            raw = bytearray(len(t)); raw[0::2] = t[:half]; raw[1::2] = t[half:]
            data = bytes(raw)
        p = 0
        for line in range(nl):
            for n in chans:
                out[n][y - y0 + line] = np.frombuffer(data[p:p + 4 * w], "<f4"); p += 4 * w
    return np.stack([out["R"], out["G"], out["B"]], -1).astype(np.float64)


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
