#!/usr/bin/env python3
"""Writes the PLY meshes of the Mitsuba cross-check scenes (deterministic).

    python tests/crosscheck/make_meshes.py        # rewrites meshes/*.ply

The outputs are committed; rerunning this script must reproduce them byte
for byte (numpy only, no randomness).

- ``uv_sphere.ply``: unit sphere at the origin, 48 longitude segments x 24
  latitude rings (2,208 triangles, 1,106 vertices), binary little-endian,
  float x y z nx ny nz (vertex normals = exact sphere normals, so a loader
  that interpolates them shades it smooth), ``list uchar int
  vertex_indices``; triangles wound counter-clockwise seen from outside.
- ``uv_sphere_cw.ply``: the same sphere with every face wound clockwise
  seen from outside, against its (outward) vertex normals.
- ``wedge.ply``: ASCII triangular prism, no normals, eight triangles wound
  counter-clockwise seen from outside. Its base is the triangle (-1,-1)
  (1,-1) (0,1) in z = 0, extruded to z = 1 (see WEDGE_VERTS).
- ``wedge.obj``: the same prism as an OBJ with its three sides as planar
  quads (``f a b c d``, no ``vn``), to exercise polygon triangulation.
  Mitsuba 3.9's PLY reader takes triangles only (an ASCII PLY with a quad
  fails with "trailing tokens after end of PLY file", a binary one with
  "is this a triangle mesh?!"), so quads are tested through OBJ.

Mitsuba computes smooth vertex normals for a PLY/OBJ without normals unless
``face_normals`` is true; the scenes set ``face_normals`` on the wedge so
that its shading does not depend on how a loader would smooth it.
"""
import math
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def uv_sphere(n_lon=48, n_lat=24):
    verts = [(0.0, 0.0, 1.0)]  # north pole
    for i in range(1, n_lat):
        theta = math.pi * i / n_lat
        for j in range(n_lon):
            phi = 2.0 * math.pi * j / n_lon  # math, not numpy: scalar libm, no SIMD variants
            verts.append((math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)))
    verts.append((0.0, 0.0, -1.0))  # south pole
    v = np.array(verts, dtype=np.float64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)

    def ring(i, j):  # vertex index of ring i (1..n_lat-1), segment j
        return 1 + (i - 1) * n_lon + (j % n_lon)

    south = len(verts) - 1
    faces = []
    for j in range(n_lon):
        faces.append((0, ring(1, j), ring(1, j + 1)))
    for i in range(1, n_lat - 1):
        for j in range(n_lon):
            a, b = ring(i, j), ring(i, j + 1)
            c, d = ring(i + 1, j), ring(i + 1, j + 1)
            faces.append((a, c, d))
            faces.append((a, d, b))
    for j in range(n_lon):
        faces.append((ring(n_lat - 1, j), south, ring(n_lat - 1, j + 1)))
    f = np.array(faces, dtype=np.int32)
    # Check the winding: every face normal points away from the centre.
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    n = np.cross(p1 - p0, p2 - p0)
    assert np.all(np.einsum("ij,ij->i", n, p0 + p1 + p2) > 0), "inward-facing triangle"
    return v, f


def write_binary_ply(path, v, n, f):
    vert = np.empty(len(v), dtype=[(k, "<f4") for k in ("x", "y", "z", "nx", "ny", "nz")])
    for k, col in zip(("x", "y", "z"), v.T):
        vert[k] = col
    for k, col in zip(("nx", "ny", "nz"), n.T):
        vert[k] = col
    face = np.empty(len(f), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    face["n"] = 3
    face["i"] = f
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        "comment mdas cross-check mesh, written by make_meshes.py\n"
        f"element vertex {len(v)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        f"element face {len(f)}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii"))
        fh.write(vert.tobytes())
        fh.write(face.tobytes())


# Triangular prism: the triangle (-1,-1,0) (1,-1,0) (0,1,0) in z = 0, extruded to z = 1.
WEDGE_VERTS = [
    (-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0),
    (-1.0, -1.0, 1.0), (1.0, -1.0, 1.0), (0.0, 1.0, 1.0),
]
WEDGE_FACES = [
    (0, 2, 1),        # bottom (normal -z)
    (3, 4, 5),        # top (normal +z)
    (0, 1, 4, 3),     # y = -1 side (normal -y)
    (1, 2, 5, 4),     # right slanted side
    (2, 0, 3, 5),     # left slanted side
]


def write_ascii_ply(path):
    v = np.array(WEDGE_VERTS)
    c = v.mean(axis=0)
    for face in WEDGE_FACES:  # outward, planar
        p = v[list(face)]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        assert np.dot(n, p.mean(axis=0) - c) > 0, face
        assert all(abs(np.dot(n, q - p[0])) < 1e-12 for q in p)
    lines = [
        "ply", "format ascii 1.0", "comment mdas cross-check mesh, written by make_meshes.py",
        f"element vertex {len(v)}", "property float x", "property float y", "property float z",
        f"element face {len(triangulate(WEDGE_FACES))}", "property list uchar int vertex_indices", "end_header",
    ]
    lines += ["%g %g %g" % tuple(p) for p in WEDGE_VERTS]
    lines += ["3 %d %d %d" % tri for tri in triangulate(WEDGE_FACES)]
    with open(path, "w", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


def triangulate(faces):
    """Fan triangulation (a b c d -> a b c, a c d), as OBJ readers do."""
    return [(f[0], f[i], f[i + 1]) for f in faces for i in range(1, len(f) - 1)]


def write_obj(path):
    lines = ["# mdas cross-check mesh, written by make_meshes.py"]
    lines += ["v %g %g %g" % p for p in WEDGE_VERTS]
    lines += ["f " + " ".join(str(i + 1) for i in face) for face in WEDGE_FACES]
    with open(path, "w", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


def main():
    out = os.path.join(HERE, "meshes")
    os.makedirs(out, exist_ok=True)
    v, f = uv_sphere()
    write_binary_ply(os.path.join(out, "uv_sphere.ply"), v, v, f)
    # The same sphere wound against its normals (outward normals, faces
    # clockwise seen from outside), as real assets often are: Mitsuba
    # shades it by its normals, exactly as uv_sphere.ply.
    write_binary_ply(os.path.join(out, "uv_sphere_cw.ply"), v, v, f[:, [0, 2, 1]])
    write_ascii_ply(os.path.join(out, "wedge.ply"))
    write_obj(os.path.join(out, "wedge.obj"))
    print(f"uv_sphere.ply, uv_sphere_cw.ply: {len(v)} vertices, {len(f)} triangles; "
          "wedge.ply: 6 vertices, 8 triangles; wedge.obj: 2 triangles, 3 quads")


if __name__ == "__main__":
    main()
