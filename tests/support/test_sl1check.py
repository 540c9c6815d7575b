"""test_sl1check.py - the archive verifier itself: it must accept a
well-formed archive built here by hand, decode all five PNG row filters,
and reject each kind of defect the writers could make.
Stdlib only; run by tests/run.sh (py suite) or directly.
"""
import io
import os
import struct
import sys
import unittest
import zipfile
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sl1check  # noqa: E402


def chunk(kind, body):
    return (struct.pack(">I", len(body)) + kind + body
            + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))


def png(width, height, channels, rows, filters=None):
    """Encode rows (bytes each) with the given per-row filter types."""
    color = 0 if channels == 1 else 6
    raw, prev = bytearray(), bytes(width * channels)
    for y, row in enumerate(rows):
        f = filters[y % len(filters)] if filters else 0
        out = bytearray(len(row))
        for i, v in enumerate(row):
            a = row[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            pred = (0, a, b, (a + b) >> 1, sl1check._paeth(a, b, c))[f]
            out[i] = (v - pred) & 255
        raw += bytes([f]) + out
        prev = row
    return (sl1check.PNG_SIG
            + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, color, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(bytes(raw)))
            + chunk(b"IEND", b""))


W, H = 6, 10  # a tiny portrait display: 10 x 6 pixels of 0.5 mm, stored 6 wide


def layer_rows(k):
    rows = [bytes(W) for _ in range(H)]
    rows[3] = bytes([0, 255, 255, 128, 0, 0])
    rows[4 + k % 2] = bytes([0, 0, 255, 0, 0, 0])
    return rows


_thumbs = {}


def thumbnail(w, h):
    """An RGBA image: a transparent left margin, an orange block (cached)."""
    if (w, h) not in _thumbs:
        row = bytes(4 * (w // 4)) + bytes([255, 128, 64, 255]) * (w - w // 4)
        _thumbs[w, h] = png(w, h, 4, [row] * h, None)
    return _thumbs[w, h]


def build(path, *, config=None, drop=(), filters=None, layer_names=None, thumb_size=None,
          bad_crc=False):
    """Write an archive; keyword arguments inject one defect each."""
    names = layer_names or ["part%05d.png" % k for k in range(3)]
    total = sum(sum(sum(r) for r in layer_rows(k)) for k in range(len(names)))
    cfg = {"action": "print", "jobDir": "part", "expTime": "7.5", "expTimeFirst": "35",
           "expUserProfile": "0", "layerHeight": "0.05", "numFade": "10", "numSlow": "0",
           "numFast": str(len(names)), "usedMaterial": "%.6f" % (total / 255 * 0.25 * 0.05 / 1000),
           "printTime": "100", "printerModel": "SL1", "printerVariant": "default",
           "printerProfile": "x", "printProfile": "y", "materialName": "z",
           "fileCreationTimestamp": "2023-11-14 at 22:13:20 UTC",
           "prusaSlicerVersion": "infilld test", "hollow": "0"}
    cfg.update(config or {})
    ps = {"display_pixels_x": str(H), "display_pixels_y": str(W), "display_width": str(H * 0.5),
          "display_height": str(W * 0.5), "display_orientation": "portrait",
          "display_mirror_x": "1", "display_mirror_y": "0", "layer_height": "0.05",
          "exposure_time": "7.5", "initial_exposure_time": "35", "printer_model": "SL1",
          "printer_technology": "SLA"}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as z:
        for k, n in enumerate(names):
            data = png(W, H, 1, layer_rows(k), filters)
            if bad_crc and k == 1:
                data = data[:-20] + bytes([data[-20] ^ 1]) + data[-19:]
            z.writestr(n, data)
        for tw, th in sl1check.THUMBNAILS:
            z.writestr("thumbnail/thumbnail%dx%d.png" % (tw, th), thumbnail(*(thumb_size or (tw, th))))
        if "config.ini" not in drop:
            z.writestr("config.ini", "".join("%s = %s\n" % kv for kv in cfg.items()
                                             if kv[0] not in drop))
        z.writestr("prusaslicer.ini", "".join("%s = %s\n" % kv for kv in ps.items()))
    return total


class Sl1CheckTest(unittest.TestCase):
    def setUp(self):
        self.path = os.path.join(os.environ.get("TMPDIR", "/tmp"), "sl1check-%d.sl1" % os.getpid())

    def tearDown(self):
        if os.path.exists(self.path):
            os.remove(self.path)

    def rejects(self, text, **defect):
        build(self.path, **defect)
        with self.assertRaises(sl1check.CheckError) as cm:
            sl1check.check_archive(self.path)
        self.assertIn(text, str(cm.exception))

    def test_accepts_and_measures(self):
        total = build(self.path)
        rep = sl1check.check_archive(self.path, expect_layers=3)
        self.assertEqual(rep["layers"], 3)
        self.assertEqual(rep.size, (W, H))
        self.assertEqual(sum(rep.sums), total)
        self.assertEqual(rep.bboxes[0], (3, 1, 4, 3))
        self.assertEqual(rep.thumbnails["thumbnail/thumbnail800x480.png"], (800, 480))
        self.assertAlmostEqual(rep["used_material_ml"], total / 255 * 0.25 * 0.05 / 1000, 6)

    def test_filtered_png_decodes(self):
        rows = [bytes((x * 37 + y * 11) & 255 for x in range(9 * 4)) for y in range(7)]
        img = sl1check.png_decode(png(9, 7, 4, rows, [0, 1, 2, 3, 4]))
        self.assertEqual(img.rows, rows)
        self.assertEqual(img.filters, {0, 1, 2, 3, 4})

    def test_rejects_defects(self):
        self.rejects("lacks printTime", drop=("printTime",))
        self.rejects("usedMaterial", config={"usedMaterial": "1.0"})
        self.rejects("row filters", filters=[0, 2])
        self.rejects("expected 'part00001.png'",
                     layer_names=["part00000.png", "part00002.png", "part00003.png"])
        self.rejects("prefix of thumbnail/", config={"jobDir": "thumb"})
        self.rejects("printerModel", config={"printerModel": "SL2"})
        self.rejects("numFast + numSlow", config={"numFast": "2"})
        self.rejects("fileCreationTimestamp", config={"fileCreationTimestamp": "yesterday"})
        self.rejects("expected 400x400 RGBA", thumb_size=(40, 40))
        self.rejects("bad length or CRC", bad_crc=True)

    def test_rejects_truncated(self):
        build(self.path)
        with open(self.path, "rb") as f:
            data = f.read()
        with open(self.path, "wb") as f:
            f.write(data[: len(data) // 2])
        with self.assertRaises(sl1check.CheckError):
            sl1check.check_archive(self.path)

    def test_command_line(self):
        build(self.path)
        self.assertEqual(sl1check.main([self.path, "--expect-layers", "3",
                                        "--expect-bbox", "1:3,1,5,3",
                                        "--expect-pixel", "0:3:3:128"]), 0)
        self.assertEqual(sl1check.main([self.path, "--expect-layers", "4"]), 1)
        self.assertEqual(sl1check.main([self.path, "--expect-pixel", "0:3:3:255"]), 1)


if __name__ == "__main__":
    unittest.main()
