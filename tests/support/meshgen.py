"""meshgen.py - small meshes written by tests and benches (binary STL)."""
import math
import struct


def write_stl(path, tris):
    """Binary STL of triangles ((x, y, z) * 3), zero normals (readers recompute them)."""
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", len(tris)))
        for t in tris:
            f.write(struct.pack("<3f", 0, 0, 0))
            for p in t:
                f.write(struct.pack("<3f", *p))
            f.write(b"\0\0")


def write_box_stl(path, x, y, z):
    """A closed box [0, x] x [0, y] x [0, z], outward triangles."""
    v = [(i * x, j * y, k * z) for k in (0, 1) for j in (0, 1) for i in (0, 1)]
    faces = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
             (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)]
    write_stl(path, [tuple(v[i] for i in face) for face in faces])


def write_ball_stl(path, R, nu=96):
    """A closed UV ball of radius R (mm) about the origin: nu x nu/2 quads,
    pole rows as single triangles (nu = 96: 9,024 triangles), outward; the
    seam and the poles share their vertices exactly."""
    nv = nu // 2

    def p(i, j):
        if j == 0 or j == nv:
            return (0.0, 0.0, R if j == 0 else -R)
        th, ph = math.pi * j / nv, 2 * math.pi * (i % nu) / nu
        return (R * math.sin(th) * math.cos(ph), R * math.sin(th) * math.sin(ph), R * math.cos(th))

    tris = []
    for j in range(nv):
        for i in range(nu):
            a, b, c, d = p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)
            if j > 0:  # a != b: off the top pole
                tris.append((a, c, b))
            if j < nv - 1:  # c != d: off the bottom pole
                tris.append((a, d, c))
    write_stl(path, tris)
