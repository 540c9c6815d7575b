#!/usr/bin/env python3
"""Round growth drawn with grey edge pixels: would the verifier pass it?

docs/hollow.md (4.3, 11 limit 3): on binary pixels a front at 45 degrees to the
pixel axes advances 0.707 px a layer where the rule allows 1.064 (the fill's
mitred corners make up for it on a ball, not on the diagonal fronts, and no
binary pixel follows a slope under one pixel a layer).  A fill whose fronts are
sub-pixel level sets drawn as grey edge pixels, read back by the verifier's
anti-aliased model, would lift both.  This script measures that fill's two
premises before anyone builds it, apart from the engine:

- it runs the round-growth model of hollow_axisym.py (the fill's top-down
  greedy, axisymmetric: voids as annuli grown by layer tan(alpha) a layer,
  walls, births) at the print layers of an SL1 (0.05 mm) on a ball;
- it draws every layer on a pixel grid (0.047 mm, the SL1's pitch) with the
  exact coverage of every edge pixel (the pixel square cut by the circle's
  tangent line: the anti-aliasing an exact rasteriser writes; 8 x 8 samples
  where a circle is under 3 px across), the outer surface too;
- it writes them as an SL1-layout zip (config.ini, prusaslicer.ini, PNGs) for
  `infilld verify`, and prints the void's share of the drawn ball (sum of
  coverage), which the bench sets beside the verifier's report.

Usage: hollow_grey.py OUT.sl1 [R_mm [lone_mm [grow_deg]]]  (R 25, lone 3.0:
the fill's HL_FILL_LONE_MM; grow_deg 45: the fronts advance layer tan(grow_deg)
a layer, so 50 draws a roof 0.20 px a layer too flat for alpha 45: the control
the verifier must fail).  Needs PIL (Debian's python3-pil, `make deps`).
"""
import io
import math
import os
import sys
import zipfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hollow_axisym import layout  # noqa: E402

from PIL import Image  # noqa: E402

PX = 0.047     # mm per pixel (the SL1's)
LAYER = 0.05   # mm per print layer
T, W, ALPHA = 1.0, 0.8, 45.0  # the bench's walls and slope


def half_plane(t, nx, ny):
    """Area of the unit pixel (centre 0) on the side n . x <= t (|n| = 1)."""
    a, b = abs(nx), abs(ny)
    if a < b:
        a, b = b, a
    s2 = 0.5 * (a + b)
    if t >= s2:
        return 1.0
    if t <= -s2:
        return 0.0
    s1 = 0.5 * (a - b)
    if abs(t) <= s1 or b < 1e-12:
        return min(1.0, max(0.0, 0.5 + t / a))
    if t > 0:
        return 1.0 - (s2 - t) ** 2 / (2 * a * b)
    return (t + s2) ** 2 / (2 * a * b)


def disc(x, y, rho):
    """Coverage of the pixel centred (x, y) (px, axis at 0) by the disc of
    radius rho (px)."""
    d = math.hypot(x, y)
    if d - rho >= 0.75:
        return 0.0
    if rho - d >= 0.75:
        return 1.0
    if rho < 1.5:  # small disc: the tangent line is not close enough
        n = 0
        for i in range(8):
            for j in range(8):
                sx, sy = x - 0.5 + (i + 0.5) / 8, y - 0.5 + (j + 0.5) / 8
                n += sx * sx + sy * sy <= rho * rho
        return n / 64.0
    return half_plane(rho - d, x / d, y / d)


def quadrant(q, radii_out, annuli):
    """One layer's quadrant (q x q, pixel (i, j) centred (i + .5, j + .5) px
    from the axis): the rows of solid coverage 0..255, their sum (pixels of
    solid) and the same sum for the disc of radius radii_out alone (the
    unhollowed part's section)."""
    circles = [radii_out] + [r for a, b in annuli for r in (a, b) if r > 0]
    rows = []
    solid_sum = part_sum = 0.0
    for j in range(q):
        y = j + 0.5
        row = bytearray(q)
        # centre classification: solid between 0 and radii_out outside
        # every annulus; edge pixels (within 0.75 px of a circle) exactly
        spans = [(0.0, radii_out)]
        for a, b in annuli:
            nxt = []
            for s0, s1 in spans:
                if b <= s0 or a >= s1:
                    nxt.append((s0, s1))
                    continue
                if a > s0:
                    nxt.append((s0, a))
                if b < s1:
                    nxt.append((b, s1))
            spans = nxt
        # the part's section: centres inside radii_out count whole, then
        # the edge pixels below trade that for their coverage
        if radii_out > y:
            part_in = min(q, int(math.floor(math.sqrt(radii_out ** 2 - y * y) - 0.5)) + 1)
        else:
            part_in = 0
        part_sum += part_in
        for s0, s1 in spans:
            if s1 <= y:
                continue
            x0 = math.sqrt(max(0.0, s0 * s0 - y * y))
            x1 = math.sqrt(s1 * s1 - y * y)
            i0 = max(0, int(math.ceil(x0 - 0.5)))
            i1 = min(q - 1, int(math.floor(x1 - 0.5)))
            if i1 >= i0:
                row[i0:i1 + 1] = b"\xff" * (i1 - i0 + 1)
        edge = set()
        for rho in circles:
            if rho + 0.75 <= y - 0.5:
                continue
            lo = math.sqrt(max(0.0, (rho - 0.75) ** 2 - y * y)) if rho > 0.75 else 0.0
            hi = math.sqrt(max(0.0, (rho + 0.75) ** 2 - y * y))
            for i in range(max(0, int(lo - 1)), min(q, int(hi + 1))):
                edge.add(i)
        for i in edge:
            x = i + 0.5
            c = disc(x, y, radii_out)
            part_sum += c - (i < part_in)
            for a, b in annuli:
                c -= disc(x, y, b) - (disc(x, y, a) if a > 0 else 0.0)
            c = min(1.0, max(0.0, c))
            row[i] = int(round(255 * c))
        rows.append(row)
        solid_sum += sum(row) / 255.0
    return rows, solid_sum, part_sum


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    out = sys.argv[1]
    R = float(sys.argv[2]) if len(sys.argv) > 2 else 25.0
    lone = float(sys.argv[3]) if len(sys.argv) > 3 else 3.0
    grow = float(sys.argv[4]) if len(sys.argv) > 4 else ALPHA
    r = R - T
    n_layers = int(math.ceil(2 * R / LAYER))
    q = int(math.ceil(R / PX)) + 4          # quadrant size, px
    npx = 2 * q
    # the model at the print layers' mid-planes (z from the ball's centre)
    k_top = int(math.floor((R + r) / LAYER - 0.5))
    state = {}

    def on_layer(z, voids):
        k = int(round((z + R) / LAYER - 0.5))
        state[k] = voids

    red_model, made = layout(R, T, W, grow, lone, dz=LAYER, z0=(k_top + 0.5) * LAYER - R,
                             on_layer=on_layer)
    zf = zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED)
    zf.writestr("config.ini", "layerHeight = %g\nnumFade = 0\nnumFast = %d\n"
                % (LAYER, n_layers))
    zf.writestr("prusaslicer.ini",
                "display_width = %.6f\ndisplay_height = %.6f\ndisplay_pixels_x = %d\n"
                "display_pixels_y = %d\ndisplay_orientation = landscape\n"
                % (npx * PX, npx * PX, npx, npx))
    part = hollow = 0.0
    for k in range(n_layers):
        zc = (k + 0.5) * LAYER - R
        ro = math.sqrt(max(0.0, R * R - zc * zc)) / PX
        voids = [(a / PX, b / PX) for a, b in state.get(k, [])]
        rows, s_hol, s_full = quadrant(q, ro, voids)
        part += s_full
        hollow += s_hol
        img = bytearray()
        quad = [bytes(reversed(rw)) + bytes(rw) for rw in rows]
        for rw in reversed(quad):
            img += rw
        for rw in quad:
            img += rw
        buf = io.BytesIO()
        Image.frombytes("L", (npx, npx), bytes(img)).save(buf, "PNG")
        zf.writestr("ball%05d.png" % k, buf.getvalue())
    zf.close()
    print("grey round growth at %g deg, %g mm ball drawn at %.3f mm / %.2f mm: model %.2f %% "
          "in %d voids, layers %.2f %% (void coverage / part coverage)"
          % (grow, 2 * R, PX, LAYER, 100 * red_model, made, 100 * (1 - hollow / part)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
