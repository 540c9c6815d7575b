#!/usr/bin/python3
"""plot_xy.py - draw x-y series as a PNG line plot (benchmarks' figures).

usage: plot_xy.py OUT.png --title T --xlabel X --ylabel Y FILE.csv:LABEL...

Each FILE.csv holds "x,y" rows (a header row that is not numeric is
skipped).  Series are drawn as polylines with a marker per point, in the
order given, with a legend.  Needs Pillow (Debian python3-pil, installed
by `make deps`); run with /usr/bin/python3.
"""
import argparse
import csv
import math
import sys

from PIL import Image, ImageDraw, ImageFont

COLOURS = [(0, 114, 178), (213, 94, 0), (0, 158, 115), (204, 121, 167), (86, 180, 233),
           (230, 159, 0)]


def read_series(spec):
    path, _, label = spec.partition(":")
    pts = []
    with open(path, newline="") as f:
        for row in csv.reader(f):
            try:
                pts.append((float(row[0]), float(row[1])))
            except (ValueError, IndexError):
                continue
    return label or path, pts


def nice_ticks(lo, hi, n=6):
    if hi <= lo:
        hi = lo + 1.0
    raw = (hi - lo) / n
    mag = 10 ** math.floor(math.log10(raw))
    step = min((s * mag for s in (1, 2, 2.5, 5, 10) if s * mag >= raw), default=10 * mag)
    t = math.floor(lo / step) * step
    out = [t]
    while t < hi - 1e-9 * step:  # the last tick at or above hi: the axis holds every point
        t += step
        out.append(t)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("series", nargs="+")
    ap.add_argument("--title", default="")
    ap.add_argument("--xlabel", default="x")
    ap.add_argument("--ylabel", default="y")
    a = ap.parse_args()
    series = [read_series(s) for s in a.series]
    xs = [p[0] for _, pts in series for p in pts]
    ys = [p[1] for _, pts in series for p in pts]
    if not xs:
        sys.exit("plot_xy.py: no data points")
    xt, yt = nice_ticks(min(xs), max(xs)), nice_ticks(min(ys), max(ys))
    x0, x1, y0, y1 = xt[0], xt[-1], yt[0], yt[-1]
    W, H, L, R, T, B = 900, 600, 90, 30, 50, 70
    img = Image.new("RGB", (W, H), "white")
    d = ImageDraw.Draw(img)
    font = ImageFont.load_default()

    def px(x, y):
        return (L + (x - x0) / (x1 - x0) * (W - L - R), H - B - (y - y0) / (y1 - y0) * (H - T - B))

    for t in xt:
        u, _ = px(t, y0)
        d.line([(u, T), (u, H - B)], fill=(225, 225, 225))
        d.text((u - 12, H - B + 6), f"{t:g}", fill="black", font=font)
    for t in yt:
        _, v = px(x0, t)
        d.line([(L, v), (W - R, v)], fill=(225, 225, 225))
        d.text((L - 50, v - 6), f"{t:g}", fill="black", font=font)
    d.rectangle([L, T, W - R, H - B], outline="black")
    d.text((L, 15), a.title, fill="black", font=font)
    d.text(((W - len(a.xlabel) * 6) / 2, H - 30), a.xlabel, fill="black", font=font)
    d.text((10, T - 20), a.ylabel, fill="black", font=font)
    for i, (label, pts) in enumerate(series):
        c = COLOURS[i % len(COLOURS)]
        q = [px(x, y) for x, y in sorted(pts)]
        if len(q) > 1:
            d.line(q, fill=c, width=2)
        for u, v in q:
            d.ellipse([u - 3, v - 3, u + 3, v + 3], outline=c, fill=c)
        d.line([(W - R - 200, T + 15 + 18 * i), (W - R - 170, T + 15 + 18 * i)], fill=c, width=2)
        d.text((W - R - 165, T + 9 + 18 * i), label, fill="black", font=font)
    img.save(a.out)


if __name__ == "__main__":
    main()
