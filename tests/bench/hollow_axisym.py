#!/usr/bin/env python3
"""What round growth would give: a model of the top-down fill on a ball.

The fill (docs/hollow.md section 4) grows each void by the exact rule on binary
pixels: grown round (`mitre_corners=false`) a front advances one pixel a layer
along the pixel axes and none diagonally, so a void grown from a point is a
diamond, not a disc, in every layer (with its convex corners mitred, the
default, it tends to a square instead, docs/hollow.md 4.3).  This script
measures what round growth gives on a ball by running the same top-down greedy
in continuous, axisymmetric form.

Model (units mm; rho = distance from the vertical axis, z = height from the
ball's centre):
- the region is the ball of radius R less the wall t (radius r = R - t);
- each layer dz, every void is an annulus [a, b] in rho (a = 0 on the axis);
- growth: a -= dz tan(alpha), b += dz tan(alpha), clipped to [0, rho_max(z)],
  so every ceiling rises at alpha: the layout is support-free;
- two voids closer than w / cos(alpha) (the horizontal width of a wall w thick
  normal to a 45 degree face; thicker than a standing wall needs, so the model
  errs on the side of less void) stop at the gap's middle plus or minus half
  of it, and the wall between them stands from there down;
- births: a gap wider than two such walls plus `lone` gets a new void at its
  middle (on the axis when the gap reaches it); `lone` plays the part of the
  fill's HL_FILL_LONE_MM (docs/hollow.md 4.2, "births").
Self-check: with one void only, the void is the cone from the ball's top down to
the equator plus the lower half ball, pi r^3 (checked within 0.1 %).

Prints one line per birth distance: reduction (void / ball volume), voids; then
the same at the rate of round growth on binary pixels.  With h tan(alpha)
between 1 and sqrt(2) pixels (SL1: 0.05 mm layers, 0.047 mm pixels, alpha 45:
1.064 px) growth by the distance threshold takes only a void's four-neighbours
a layer: a void grown from a point is a diamond gaining one pixel a layer at its
corners, whose area is that of a disc gaining sqrt(2 / pi) = 0.798 px a layer.
The model run at that equal-area rate estimates what the fill keeps grown
round; mitred corners are not modelled.
`hollow_axisym.py --write-ball PATH [R]` writes instead the ball the bench
hollows for comparison (tests/support/meshgen.py write_ball_stl: closed,
9,024 triangles, radius R mm, 25 by default).
"""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from meshgen import write_ball_stl  # noqa: E402


def layout(R, t, w, alpha_deg, lone, dz=0.01, births=True, z0=None, on_layer=None,
           grow_mm_per_mm=None):
    """Run the model from z0 (r by default) down in steps of dz; on_layer(z,
    voids) sees every step's annuli after growth, walls and births.
    grow_mm_per_mm: the fronts' horizontal advance per mm of height
    (tan(alpha) by default); walls keep alpha's width either way."""
    r = R - t
    dd = dz * (math.tan(math.radians(alpha_deg)) if grow_mm_per_mm is None else grow_mm_per_mm)
    wall = w / math.cos(math.radians(alpha_deg))
    voids = []  # [a, b]
    vol = 0.0
    made = 0
    z = r if z0 is None else z0
    while z > -r:
        rmax = math.sqrt(max(r * r - z * z, 0.0))
        for v in voids:
            v[0] = max(0.0, v[0] - dd)
            v[1] = min(rmax, v[1] + dd)
        voids.sort()
        for A, B in zip(voids, voids[1:]):
            if B[0] - A[1] < wall:
                mid = 0.5 * (A[1] + B[0])
                A[1] = min(A[1], mid - wall / 2)
                B[0] = max(B[0], mid + wall / 2)
        voids = [v for v in voids if v[1] >= v[0]]
        if births or not made:
            lo = -wall  # the axis needs no wall: a void may sit on it
            gaps = []
            for v in voids:
                gaps.append((lo, v[0]))
                lo = v[1]
            gaps.append((lo, rmax))
            for g0, g1 in gaps:
                inner = g0 + wall
                outer = g1 if g1 >= rmax else g1 - wall  # the ball: t is off already
                if outer - inner > 2 * dd + lone:
                    c = 0.0 if g0 < 0 else 0.5 * (inner + outer)
                    voids.append([c, c])
                    made += 1
                    if not births:
                        break
            voids.sort()
        for a, b in voids:
            vol += math.pi * (b * b - a * a) * dz
        if on_layer:
            on_layer(z, [tuple(v) for v in voids if v[1] > v[0]])
        z -= dz
    return vol / (4.0 / 3.0 * math.pi * R ** 3), made


def main():
    if len(sys.argv) > 2 and sys.argv[1] == "--write-ball":
        write_ball_stl(sys.argv[2], float(sys.argv[3]) if len(sys.argv) > 3 else 25.0)
        return 0
    R = float(sys.argv[1]) if len(sys.argv) > 1 else 25.0
    t, w, alpha = 1.0, 0.8, 45.0
    one, n = layout(R, t, w, alpha, 0.0, births=False)
    cone = math.pi * (R - t) ** 3 / (4.0 / 3.0 * math.pi * R ** 3)
    if abs(one - cone) > 1e-3:
        print("axisym self-check FAILED: one void %.4f, cone and half ball %.4f" % (one, cone))
        return 1
    print("axisym ball %g mm, walls %g / %g mm, alpha %g: one void %.2f %% (cone + half ball %.2f %%)"
          % (2 * R, t, w, alpha, 100 * one, 100 * cone))
    for lone in (0.5, 1.5, 3.0, 4.5, 6.0):
        red, n = layout(R, t, w, alpha, lone)
        print("axisym round growth, births beyond %.1f mm: %.2f %% in %d voids" % (lone, 100 * red, n))
    pixel_mm, layer_mm = 0.047, 0.05  # the SL1's
    rate = math.sqrt(2 / math.pi) * pixel_mm / layer_mm
    red, n = layout(R, t, w, alpha, 3.0, grow_mm_per_mm=rate)
    print("axisym at round binary growth's rate (SL1 pitch: diamonds, equal-area %.3f mm a layer, "
          "%.1f deg), births beyond 3.0 mm: %.2f %% in %d voids"
          % (rate * layer_mm, math.degrees(math.atan(rate)), 100 * red, n))
    return 0


if __name__ == "__main__":
    sys.exit(main())
