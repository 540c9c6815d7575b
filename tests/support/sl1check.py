#!/usr/bin/env python3
"""sl1check - verify a resin archive (.sl1/.sl1s, or a generic PNG-stack .zip).

Independent of the writer: Python's zipfile and zlib plus a small PNG
decoder (chunk CRCs, IHDR, all five row filters).  Checks what the SL1
firmware, PrusaSlicer and UVtools need (docs/formats.md):

  * the archive opens, every entry's CRC is right, layer PNGs are stored;
  * config.ini holds every key, printerModel is SL1/SL1S/M1, jobDir is
    not a prefix of "thumbnail/", layers are <jobDir>00000.png.. without
    gaps, numFast + numSlow = layer count;
  * prusaslicer.ini holds the display keys, and the layer images have
    the size its orientation implies;
  * every layer decodes as 8-bit gray, with filter 0 on every row;
  * usedMaterial (ml) = sum(pixel / 255) * pixel area * layerHeight / 1000;
  * thumbnails thumbnail/thumbnail400x400.png and 800x480.png are RGBA of
    that size and not empty.
Generic zips: 1.png .. N.png and manifest.json.

Use as a module (check_archive(path, ...) -> Report, raises CheckError)
or as a command:
  sl1check.py FILE [--expect-layers N] [--printer sl1|sl1s]
              [--expect-volume-mm3 V [--volume-rel 0.01]]
              [--expect-sum K:S] [--expect-bbox K:ROW0,COL0,ROW1,COL1]
              [--expect-pixel K:ROW:COL:VALUE] [--expect-key KEY=VALUE] [--json]
Exit status 0 when every check passes, 1 otherwise (problems on stderr).
"""

import argparse
import io
import json
import re
import struct
import sys
import zipfile
import zlib

PNG_SIG = b"\x89PNG\r\n\x1a\n"

CONFIG_KEYS = (
    "action", "jobDir", "expTime", "expTimeFirst", "expUserProfile", "layerHeight",
    "numFade", "numSlow", "numFast", "usedMaterial", "printTime", "printerModel",
    "printerVariant", "printerProfile", "printProfile", "materialName",
    "fileCreationTimestamp", "prusaSlicerVersion", "hollow",
)
PRUSASLICER_KEYS = (
    "display_pixels_x", "display_pixels_y", "display_width", "display_height",
    "display_orientation", "display_mirror_x", "display_mirror_y", "layer_height",
    "exposure_time", "initial_exposure_time", "printer_model", "printer_technology",
)
THUMBNAILS = ((400, 400), (800, 480))
PRINTERS = {  # what the profiles must write (PrusaSlicer 2.5 values)
    "sl1": {"printerModel": "SL1", "display_pixels_x": "2560", "display_pixels_y": "1440",
            "display_width": "120.96", "display_height": "68.04",
            "display_orientation": "portrait", "display_mirror_x": "1",
            "display_mirror_y": "0", "png_size": (1440, 2560)},
    "sl1s": {"printerModel": "SL1S", "display_pixels_x": "2560", "display_pixels_y": "1620",
             "display_width": "128", "display_height": "81",
             "display_orientation": "portrait", "display_mirror_x": "1",
             "display_mirror_y": "0", "png_size": (1620, 2560)},
}


class CheckError(Exception):
    """The archive is not what a consumer accepts; str() lists the problems."""


class Image:
    """A decoded PNG: width, height, channels (1 gray, 4 RGBA), rows (bytes each)."""

    def __init__(self, width, height, channels, rows, filters, raw=None):
        self.width, self.height, self.channels = width, height, channels
        self.rows, self.filters = rows, filters
        # rows that can hold nonzero pixels: from the inflated stream when
        # every filter byte is 0 (then a zero byte is a zero pixel)
        self.row_range = range(height)
        if raw is not None and filters == {0}:
            head = len(raw) - len(raw.lstrip(b"\x00"))
            tail = len(raw.rstrip(b"\x00"))
            stride = width * channels + 1
            self.row_range = range(head // stride, (tail + stride - 1) // stride)

    def bbox(self):
        """(row0, col0, row1, col1) of nonzero gray pixels, inclusive, or None."""
        r0 = c0 = 1 << 30
        r1 = c1 = -1
        for y in self.row_range:
            row = self.rows[y]
            s = row.lstrip(b"\x00")
            if not s:
                continue
            r0, r1 = min(r0, y), y
            c0 = min(c0, len(row) - len(s))
            c1 = max(c1, len(row.rstrip(b"\x00")) - 1)
        return None if r1 < 0 else (r0, c0, r1, c1)

    def pixel_sum(self):
        """Sum of gray values (only rows with content are summed)."""
        total = 0
        for y in self.row_range:
            s = self.rows[y].strip(b"\x00")
            if s:
                total += sum(s)
        return total


def _paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    if pa <= pb and pa <= pc:
        return a
    return b if pb <= pc else c


def png_decode(data):
    """Decode an 8-bit gray or RGBA, non-interlaced PNG; CheckError if malformed."""
    if data[:8] != PNG_SIG:
        raise CheckError("not a PNG (bad signature)")
    pos, ihdr, idat, seen_end = 8, None, [], False
    while pos + 12 <= len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        ctype = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])
        if len(body) != length or zlib.crc32(ctype + body) & 0xFFFFFFFF != crc:
            raise CheckError("PNG chunk %r: bad length or CRC" % ctype)
        if ctype == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif ctype == b"IDAT":
            idat.append(body)
        elif ctype == b"IEND":
            seen_end = True
            break
        pos += 12 + length
    if ihdr is None or not idat or not seen_end:
        raise CheckError("PNG lacks IHDR, IDAT or IEND")
    width, height, depth, color, comp, filt, interlace = ihdr
    if depth != 8 or color not in (0, 6) or comp or filt or interlace:
        raise CheckError("PNG is not 8-bit gray/RGBA non-interlaced: depth %d colour %d "
                         "interlace %d" % (depth, color, interlace))
    channels = 1 if color == 0 else 4
    try:
        raw = zlib.decompress(b"".join(idat))  # checks the Adler-32 too
    except zlib.error as exc:
        raise CheckError("PNG image data does not inflate: %s" % exc)
    stride = width * channels
    if len(raw) != height * (stride + 1):
        raise CheckError("PNG image data is %d bytes, expected %d"
                         % (len(raw), height * (stride + 1)))
    rows, filters, prev = [], set(), bytes(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)]
        filters.add(f)
        if f == 0:
            cur = line
        else:
            cur = bytearray(line)
            for i in range(stride):
                a = cur[i - channels] if i >= channels else 0
                b = prev[i]
                c = prev[i - channels] if i >= channels else 0
                if f == 1:
                    cur[i] = (cur[i] + a) & 255
                elif f == 2:
                    cur[i] = (cur[i] + b) & 255
                elif f == 3:
                    cur[i] = (cur[i] + ((a + b) >> 1)) & 255
                elif f == 4:
                    cur[i] = (cur[i] + _paeth(a, b, c)) & 255
                else:
                    raise CheckError("PNG row %d has filter type %d" % (y, f))
            cur = bytes(cur)
        rows.append(cur)
        prev = cur
    return Image(width, height, channels, rows, filters, raw)


def parse_ini(text):
    """`key = value` lines -> dict (blank lines and # comments skipped)."""
    out = {}
    for n, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if " = " not in line and "=" not in line:
            raise CheckError("ini line %d has no '=': %r" % (n, line))
        k, v = line.split("=", 1)
        out[k.strip()] = v.strip()
    return out


class Report:
    """What check_archive() found."""

    def __init__(self):
        self.kind = None           # "sl1" or "zip"
        self.config = {}           # config.ini
        self.prusaslicer = {}      # prusaslicer.ini
        self.manifest = {}         # manifest.json of generic zips
        self.layers = []           # layer entry names, in print order
        self.sums = []             # per-layer pixel sums
        self.bboxes = []           # per-layer (row0, col0, row1, col1) or None
        self.size = None           # (width, height) of the layer images
        self.volume_mm3 = 0.0      # from the pixels
        self.pixel_mm = None       # (along image columns, along image rows)
        self.thumbnails = {}       # name -> (width, height)
        self.images = {}           # layer index -> Image, for keep_images

    def as_dict(self):
        """Plain figures: layers (count), size, volume_mm3 (from the pixels),
        used_material_ml and print_time_s (config.ini, or manifest.json of a
        generic zip), kind, config, prusaslicer, manifest, sums, bboxes,
        thumbnails."""
        src = self.config if self.kind == "sl1" else self.manifest
        if self.kind == "sl1":
            used = _float_or(src.get("usedMaterial", "nan"))
            ptime = _float_or(src.get("printTime", "nan"))
        else:
            used = src.get("material_volume_mm3", float("nan")) / 1000.0
            ptime = src.get("print_time_s", float("nan"))
        return {"kind": self.kind, "layers": len(self.layers), "size": self.size,
                "volume_mm3": self.volume_mm3, "used_material_ml": used,
                "print_time_s": ptime, "config": self.config,
                "prusaslicer": self.prusaslicer, "manifest": self.manifest,
                "sums": self.sums, "bboxes": self.bboxes,
                "thumbnails": {k: list(v) for k, v in self.thumbnails.items()}}

    def __getitem__(self, key):
        return self.as_dict()[key]


def _num(d, key, problems, kind=float):
    try:
        return kind(d[key])
    except (KeyError, ValueError):
        problems.append("%s = %r is not a %s" % (key, d.get(key), kind.__name__))
        return None


def _check_layers(zf, names, rep, problems, keep_images):
    for k, name in enumerate(names):
        info = zf.getinfo(name)
        if info.compress_type != zipfile.ZIP_STORED:
            problems.append("%s is compressed (method %d), expected stored"
                            % (name, info.compress_type))
        try:
            img = png_decode(zf.read(name))
        except CheckError as exc:
            problems.append("%s: %s" % (name, exc))
            rep.sums.append(0)
            rep.bboxes.append(None)
            continue
        if img.channels != 1:
            problems.append("%s is not 8-bit gray" % name)
        if img.filters != {0}:
            problems.append("%s uses row filters %s, expected only 0" % (name, sorted(img.filters)))
        if rep.size is None:
            rep.size = (img.width, img.height)
        elif rep.size != (img.width, img.height):
            problems.append("%s is %dx%d, the first layer %dx%d"
                            % (name, img.width, img.height, rep.size[0], rep.size[1]))
        rep.sums.append(img.pixel_sum())
        rep.bboxes.append(img.bbox())
        if keep_images is not None and k in keep_images:
            rep.images[k] = img


def _check_sl1(zf, names, rep, problems, printer, keep_images):
    cfg = rep.config = parse_ini(zf.read("config.ini").decode("utf-8"))
    for key in CONFIG_KEYS:
        if key not in cfg:
            problems.append("config.ini lacks %s" % key)
    if cfg.get("action") != "print":
        problems.append("config.ini action = %r, expected print" % cfg.get("action"))
    if cfg.get("printerModel") not in ("SL1", "SL1S", "M1"):
        problems.append("printerModel %r is not SL1, SL1S or M1" % cfg.get("printerModel"))
    if not re.fullmatch(r"\d{4}-\d\d-\d\d at \d\d:\d\d:\d\d UTC",
                        cfg.get("fileCreationTimestamp", "")):
        problems.append("fileCreationTimestamp %r is not 'YYYY-MM-DD at HH:MM:SS UTC'"
                        % cfg.get("fileCreationTimestamp"))
    job = cfg.get("jobDir", "")
    if not job or "thumbnail/".startswith(job):
        problems.append("jobDir %r is empty or a prefix of thumbnail/" % job)
    layers = sorted(n for n in names if n.lower().endswith(".png") and n.startswith(job))
    rep.layers = layers
    for k, n in enumerate(layers):
        if n != "%s%05d.png" % (job, k):
            problems.append("layer %d is named %r, expected %r" % (k, n, "%s%05d.png" % (job, k)))
            break
    fast, slow = _num(cfg, "numFast", problems, int), _num(cfg, "numSlow", problems, int)
    if fast is not None and slow is not None and fast + slow != len(layers):
        problems.append("numFast + numSlow = %d, but %d layers" % (fast + slow, len(layers)))
    for key in ("expTime", "expTimeFirst", "layerHeight", "usedMaterial", "printTime"):
        _num(cfg, key, problems)
    for key in ("numFade", "expUserProfile", "hollow"):
        _num(cfg, key, problems, int)

    if "prusaslicer.ini" not in names:
        problems.append("prusaslicer.ini is missing")
        return
    ps = rep.prusaslicer = parse_ini(zf.read("prusaslicer.ini").decode("utf-8"))
    for key in PRUSASLICER_KEYS:
        if key not in ps:
            problems.append("prusaslicer.ini lacks %s" % key)
    if printer:
        want = PRINTERS[printer]
        for key, val in want.items():
            if key == "png_size":
                continue
            got = cfg.get(key) if key == "printerModel" else ps.get(key)
            if got is None or (got != val and _float_or(got) != _float_or(val)):
                problems.append("%s = %r, expected %r for %s" % (key, got, val, printer))

    _check_layers(zf, layers, rep, problems, keep_images)
    try:
        px, py = int(ps["display_pixels_x"]), int(ps["display_pixels_y"])
        dw, dh = float(ps["display_width"]), float(ps["display_height"])
        portrait = ps["display_orientation"] == "portrait"
        lh = float(cfg["layerHeight"])
    except (KeyError, ValueError) as exc:
        problems.append("display geometry unreadable: %s" % exc)
        return
    want_size = (py, px) if portrait else (px, py)
    if rep.size is not None and rep.size != want_size:
        problems.append("layer images are %dx%d, prusaslicer.ini implies %dx%d"
                        % (rep.size + want_size))
    rep.pixel_mm = (dh / py, dw / px) if portrait else (dw / px, dh / py)
    area = rep.pixel_mm[0] * rep.pixel_mm[1]
    rep.volume_mm3 = sum(rep.sums) / 255.0 * area * lh
    used = _num(cfg, "usedMaterial", problems)
    if used is not None and abs(used - rep.volume_mm3 / 1000.0) > 1e-4 + 1e-4 * used:
        problems.append("usedMaterial = %s ml, the pixels give %.6f ml"
                        % (cfg["usedMaterial"], rep.volume_mm3 / 1000.0))

    for w, h in THUMBNAILS:
        name = "thumbnail/thumbnail%dx%d.png" % (w, h)
        if name not in names:
            problems.append("%s is missing" % name)
            continue
        try:
            img = png_decode(zf.read(name))
        except CheckError as exc:
            problems.append("%s: %s" % (name, exc))
            continue
        rep.thumbnails[name] = (img.width, img.height)
        if (img.width, img.height, img.channels) != (w, h, 4):
            problems.append("%s is %dx%d with %d channels, expected %dx%d RGBA"
                            % (name, img.width, img.height, img.channels, w, h))
        elif not any(any(row[3::4]) for row in img.rows):
            problems.append("%s is fully transparent" % name)


def _check_zip(zf, names, rep, problems, keep_images):
    pngs = [n for n in names if re.fullmatch(r"[1-9][0-9]*\.png", n)]
    pngs.sort(key=lambda n: int(n[:-4]))
    rep.layers = pngs
    for k, n in enumerate(pngs):
        if n != "%d.png" % (k + 1):
            problems.append("layer %d is named %r, expected %d.png" % (k, n, k + 1))
            break
    if "manifest.json" in names:
        rep.manifest = json.loads(zf.read("manifest.json").decode("utf-8"))
        if rep.manifest.get("layers") != len(pngs):
            problems.append("manifest.json says %r layers, the archive has %d"
                            % (rep.manifest.get("layers"), len(pngs)))
    else:
        problems.append("manifest.json is missing")
    _check_layers(zf, pngs, rep, problems, keep_images)
    man = rep.manifest
    if man and rep.size and (man.get("image_width_px"), man.get("image_height_px")) != rep.size:
        problems.append("manifest.json image size differs from the PNGs")
    if man.get("pixel_um") and man.get("layer_height_mm"):
        px = [v / 1000.0 for v in man["pixel_um"]]
        rep.pixel_mm = (px[0], px[1])
        rep.volume_mm3 = sum(rep.sums) / 255.0 * px[0] * px[1] * man["layer_height_mm"]
        if abs(rep.volume_mm3 - man.get("material_volume_mm3", -1)) > 0.01 + 1e-4 * rep.volume_mm3:
            problems.append("manifest material_volume_mm3 = %r, the pixels give %.3f"
                            % (man.get("material_volume_mm3"), rep.volume_mm3))


def _float_or(s):
    try:
        return float(s)
    except ValueError:
        return s


def check_archive(path, expect_layers=None, printer=None, keep_images=None):
    """Verify the archive at path; returns a Report or raises CheckError.

    keep_images: layer indices whose decoded Image to keep in Report.images.
    """
    rep, problems = Report(), []
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise CheckError("cannot open %s as a zip archive: %s" % (path, exc))
    with zf:
        bad = zf.testzip()
        if bad is not None:
            raise CheckError("entry %s has a bad CRC" % bad)
        names = zf.namelist()
        if len(set(names)) != len(names):
            problems.append("duplicate entry names")
        if "config.ini" in names:
            rep.kind = "sl1"
            _check_sl1(zf, names, rep, problems, printer, keep_images)
        else:
            rep.kind = "zip"
            _check_zip(zf, names, rep, problems, keep_images)
    if not rep.layers:
        problems.append("no layer images")
    if expect_layers is not None and len(rep.layers) != expect_layers:
        problems.append("%d layers, expected %d" % (len(rep.layers), expect_layers))
    if problems:
        raise CheckError("; ".join(problems))
    return rep


def _pairs(items, sep, n):
    out = []
    for s in items or []:
        parts = s.split(sep, n - 1)
        if len(parts) != n:
            raise SystemExit("sl1check: malformed argument %r" % s)
        out.append(parts)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description="verify a resin archive")
    ap.add_argument("archive")
    ap.add_argument("--expect-layers", type=int)
    ap.add_argument("--printer", choices=sorted(PRINTERS))
    ap.add_argument("--expect-volume-mm3", type=float)
    ap.add_argument("--volume-rel", type=float, default=0.01)
    ap.add_argument("--expect-sum", action="append", metavar="K:S",
                    help="pixel sum of layer K (0-based)")
    ap.add_argument("--expect-bbox", action="append", metavar="K:R0,C0,R1,C1",
                    help="nonzero box of layer K (inclusive; 'none' for empty)")
    ap.add_argument("--expect-pixel", action="append", metavar="K:ROW:COL:V")
    ap.add_argument("--expect-key", action="append", metavar="KEY=VALUE",
                    help="config.ini value (or prusaslicer.ini if not in config.ini)")
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    a = ap.parse_args(argv)

    pixel_checks = _pairs(a.expect_pixel, ":", 4)
    keep = {int(k) for k, _, _, _ in pixel_checks}
    try:
        rep = check_archive(a.archive, a.expect_layers, a.printer, keep)
    except CheckError as exc:
        print("sl1check: %s: %s" % (a.archive, exc), file=sys.stderr)
        return 1
    problems = []
    if a.expect_volume_mm3 is not None:
        if abs(rep.volume_mm3 - a.expect_volume_mm3) > a.volume_rel * abs(a.expect_volume_mm3):
            problems.append("volume %.4f mm3, expected %.4f (rel %g)"
                            % (rep.volume_mm3, a.expect_volume_mm3, a.volume_rel))
    for k, s in _pairs(a.expect_sum, ":", 2):
        k = int(k)
        if k >= len(rep.sums) or rep.sums[k] != int(s):
            problems.append("layer %d pixel sum %s, expected %s"
                            % (k, rep.sums[k] if k < len(rep.sums) else "-", s))
    for k, box in _pairs(a.expect_bbox, ":", 2):
        k = int(k)
        want = None if box == "none" else tuple(int(v) for v in box.split(","))
        got = rep.bboxes[k] if k < len(rep.bboxes) else "missing"
        if got != want:
            problems.append("layer %d nonzero box %s, expected %s" % (k, got, want))
    for k, row, col, v in pixel_checks:
        img = rep.images.get(int(k))
        got = img.rows[int(row)][int(col)] if img else None
        if got != int(v):
            problems.append("layer %s pixel (row %s, col %s) = %s, expected %s"
                            % (k, row, col, got, v))
    for key, val in _pairs(a.expect_key, "=", 2):
        got = rep.config.get(key, rep.prusaslicer.get(key))
        if got != val:
            problems.append("%s = %r, expected %r" % (key, got, val))
    if problems:
        print("sl1check: %s: %s" % (a.archive, "; ".join(problems)), file=sys.stderr)
        return 1
    if a.json:
        print(json.dumps(rep.as_dict()))
    else:
        print("sl1check: %s: OK, %s, %d layers of %dx%d, %.3f mm3"
              % (a.archive, rep.kind, len(rep.layers), rep.size[0], rep.size[1],
                 rep.volume_mm3))
    return 0


if __name__ == "__main__":
    sys.exit(main())
