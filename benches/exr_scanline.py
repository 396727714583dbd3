"""A reader for the EXRs mdas writes (scanline, float32 channels,
uncompressed or ZIP), in plain Python, shared by the bench scripts that
split an image's error (cuts_split.py, cuts_equal_count_split.py)."""
import struct
import zlib
from array import array


def read_exr(path):
    """(w, h, [R, G, B] as flat float lists) of a scanline float32 EXR."""
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
    out = {n: [0.0] * (w * h) for n in chans}
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
                a = array("f"); a.frombytes(data[p:p + 4 * w]); p += 4 * w
                row = (y - y0 + line) * w
                out[n][row:row + w] = list(a)
    return w, h, [out["R"], out["G"], out["B"]]
