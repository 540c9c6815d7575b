"""test_cli.py - the `infilld` command line contract (README "Command line").

Drives the real binary (env INFILLD_BIN) on the shared meshes and checks
outputs with the independent checkers in tests/support/ (sl1check.py,
gcodecheck.py).  Run by tests/run.sh; standalone: python3 tests/cli/test_cli.py
"""
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
import gcodecheck  # noqa: E402
import sl1check  # noqa: E402

BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")


def load(path):
    with open(path) as f:
        return json.load(f)


def run(*args, check=False):
    p = subprocess.run([BIN, *args], capture_output=True, text=True, timeout=600)
    if check and p.returncode != 0:
        raise AssertionError(f"infilld {' '.join(args)} failed ({p.returncode}): {p.stderr}")
    return p


class CliTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = cls.tmp.name

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def path(self, name):
        return os.path.join(self.dir, name)

    def assert_one_line_error(self, p, *needles):
        self.assertEqual(p.returncode, 1, p.stderr)
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, p.stderr)
        self.assertTrue(lines[0].startswith("infilld: "), lines[0])
        for n in needles:
            self.assertIn(n, lines[0])

    # ---- engines / analyze -------------------------------------------------
    def test_engines_json(self):
        p = run("engines", check=True)
        d = json.loads(p.stdout)
        names = [e["name"] for e in d["engines"]]
        self.assertIn("solid", names)
        keys = {c["name"] for c in d["common_params"]}
        for k in ("units", "scale", "height_mm", "up", "layer_mm", "shell_mm", "alpha_deg"):
            self.assertIn(k, keys)
        printers = {p["name"]: p for p in d["printers"]}
        for n in ("sl1", "sl1s", "generic-resin", "generic-fdm"):
            self.assertIn(n, printers)
        self.assertEqual({f["name"] for f in d["formats"]},
                         {"sl1", "sl1s", "zip", "gcode", "stl", "obj"})
        for e in d["engines"]:
            for prm in e["params"]:
                self.assertIn(prm["type"], ("bool", "int", "number", "enum", "string", "vec3"))
                self.assertTrue(prm["help"], prm["name"])

    def test_analyze_open_and_closed(self):
        d = json.loads(run("analyze", os.path.join(MESHES, "bunny.stl"),
                           "--set", "units=m", check=True).stdout)
        self.assertEqual(d["mesh"]["triangles"], 69451)
        self.assertEqual(d["mesh"]["border_edges"], 223)
        self.assertFalse(d["mesh"]["watertight"])
        d = json.loads(run("analyze", os.path.join(MESHES, "femur.off"),
                           "--set", "height_mm=50", check=True).stdout)
        self.assertTrue(d["mesh"]["watertight"])
        self.assertAlmostEqual(d["size_mm"]["z"], 50.0, places=6)
        self.assertAlmostEqual(d["bbox_mm"]["min"]["z"], 0.0, places=9)
        self.assertTrue(d["fits_printer"])
        self.assertGreater(d["mesh"]["volume_mm3"], 0)

    def test_analyze_does_not_fit(self):
        d = json.loads(run("analyze", os.path.join(MESHES, "femur.off"),
                           "--set", "height_mm=400", check=True).stdout)
        self.assertFalse(d["fits_printer"])
        self.assertIn("too large", d["fit_error"])

    # ---- run: resin -----------------------------------------------------------
    def test_run_sl1_femur(self):
        out, met = self.path("femur.sl1"), self.path("femur-sl1.json")
        run("run", os.path.join(MESHES, "femur.off"), "-o", out, "--set", "height_mm=50",
            "--metrics", met, "--quiet", check=True)
        m = load(met)
        self.assertEqual(m["layers"], math.ceil(50 / 0.05))
        self.assertEqual(m["engine"], "solid")
        for k in ("layers", "layer_mm", "bbox_mm", "part_volume_mm3", "material_volume_mm3",
                  "material_fraction", "elapsed_s", "peak_rss_mb", "solid"):
            self.assertIn(k, m)
        # Sliced material within 1% of the mesh's volume at 47 um pixels.
        self.assertAlmostEqual(m["material_volume_mm3"] / m["part_volume_mm3"], 1.0, delta=0.01)
        rep = sl1check.check_archive(out, expect_layers=m["layers"], printer="sl1")
        self.assertAlmostEqual(rep["used_material_ml"] * 1000.0, m["material_volume_mm3"],
                               delta=0.01 * m["material_volume_mm3"])
        self.assertFalse(os.path.exists(out + ".part"))

    def test_layer_count_rule(self):
        for layer in ("0.1", "0.07", "0.025"):
            met = self.path(f"cube-{layer}.json")
            run("run", os.path.join(MESHES, "misc", "cube.bin.stl"), "-o",
                self.path(f"c{layer}.zip"), "--set", "height_mm=10", "--set",
                f"layer_mm={layer}", "--metrics", met, "--quiet", check=True)
            self.assertEqual(load(met)["layers"], math.ceil(10 / float(layer) - 1e-9))

    def test_thumbnail_in_the_job_name(self):
        """PrusaSlicer's SL1 importer skips every entry whose lower-cased name
        contains "thumbnail": a job named after MyThumbnailHolder.stl must
        still give layers it imports."""
        import shutil
        import zipfile
        mesh = self.path("MyThumbnailHolder.stl")
        shutil.copy(os.path.join(MESHES, "misc", "cube.bin.stl"), mesh)
        out = self.path("holder.sl1")
        run("run", mesh, "-o", out, "--set", "height_mm=2", "--quiet", check=True)
        with zipfile.ZipFile(out) as z:
            names = z.namelist()
            ini = dict(l.split(" = ", 1) for l in z.read("config.ini").decode().splitlines()
                       if " = " in l)
        layers = [n for n in names if n.endswith(".png") and not n.startswith("thumbnail/")]
        self.assertEqual(len(layers), 40)
        self.assertEqual(ini["jobDir"], "MyThumbHolder")
        for n in names:
            if n.startswith("thumbnail/"):
                continue
            self.assertNotIn("thumbnail", n.lower(), n)
            self.assertTrue(all(c.isalnum() and c.isascii() or c in "._-" for c in n), n)
        # what PrusaSlicer's importer keeps: the layers, all of them
        kept = [n for n in names if n.endswith(".png") and "thumbnail" not in n.lower()]
        self.assertEqual(kept, layers)
        sl1check.check_archive(out, expect_layers=40, printer="sl1")

    # ---- run: FDM -------------------------------------------------------------
    def test_run_gcode_femur_contained(self):
        placed = self.path("femur50.stl")
        run("run", os.path.join(MESHES, "femur.off"), "-o", placed, "--set", "height_mm=50",
            "--printer", "generic-fdm", "--quiet", check=True)
        out, met = self.path("femur.gcode"), self.path("femur-gc.json")
        run("run", placed, "-o", out, "--metrics", met, "--quiet", check=True)
        m = load(met)
        self.assertEqual(m["layers"], math.ceil(50 / 0.2))
        rep = gcodecheck.check_file(out, mesh=placed)
        self.assertEqual(rep["layers"], m["layers"])
        self.assertEqual(rep["containment_violations"], 0)
        self.assertAlmostEqual(rep["extruded_volume_mm3"], m["material_volume_mm3"],
                               delta=0.01 * m["material_volume_mm3"])

    def test_gcode_to_stdout(self):
        p = subprocess.run([BIN, "run", os.path.join(MESHES, "misc", "cube.bin.stl"), "-o", "-",
                            "--format", "gcode", "--set", "height_mm=2", "--quiet"],
                           capture_output=True, timeout=120)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertTrue(p.stdout.startswith(b"; generated by infilld"))

    # ---- run: generic-resin zip ----------------------------------------------
    GENERIC = ["--printer", "generic-resin", "--format", "zip", "--set", "height_mm=10",
               "--set", "layer_mm=0.2", "--set", "display_px_x=3840", "--set",
               "display_px_y=2400", "--set", "display_mm_x=153.36", "--set", "display_mm_y=95.76"]

    @staticmethod
    def png_size(data):
        """(width, height) from a PNG's IHDR."""
        import struct
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
        return struct.unpack(">II", data[16:24])

    def generic_zip(self, name, *sets):
        out = self.path(name)
        args = ["run", os.path.join(MESHES, "P.off"), "-o", out, *self.GENERIC, "--quiet"]
        for kv in sets:
            args += ["--set", kv]
        run(*args, check=True)
        return out

    def test_generic_resin_zip_display_and_mirror(self):
        import zipfile
        plain = self.generic_zip("p-plain.zip", "mirror_x=false")
        flip = self.generic_zip("p-flip.zip", "mirror_x=true")
        firsts = []
        for out in (plain, flip):
            rep = sl1check.check_archive(out)
            self.assertEqual(rep.kind, "zip")
            self.assertEqual(len(rep.layers), math.ceil(10 / 0.2))
            with zipfile.ZipFile(out) as zf:
                for n in rep.layers:
                    self.assertEqual(self.png_size(zf.read(n)), (3840, 2400), n)
                firsts.append(sl1check.png_decode(zf.read("1.png")))
            man = rep.manifest
            self.assertAlmostEqual(man["pixel_um"][0], 1000 * 153.36 / 3840, places=3)
            self.assertAlmostEqual(man["pixel_um"][1], 1000 * 95.76 / 2400, places=3)
        a, b = firsts
        W = a.width
        ba, bb = a.bbox(), b.bbox()
        self.assertIsNotNone(ba)
        # rows stay, columns map c -> W - 1 - c
        self.assertLessEqual(abs(ba[0] - bb[0]), 1)
        self.assertLessEqual(abs(ba[2] - bb[2]), 1)
        self.assertLessEqual(abs((W - 1 - ba[3]) - bb[1]), 1)
        self.assertLessEqual(abs((W - 1 - ba[1]) - bb[3]), 1)
        self.assertAlmostEqual(a.pixel_sum(), b.pixel_sum(), delta=0.01 * a.pixel_sum())
        # per row, the lit extents are each other's mirror image within a pixel
        asym = 0
        for y in range(ba[0], ba[2] + 1):
            ra, rb = a.rows[y], b.rows[y]
            if not ra.strip(b"\x00"):
                continue
            la, ha = len(ra) - len(ra.lstrip(b"\x00")), len(ra.rstrip(b"\x00")) - 1
            lb, hb = len(rb) - len(rb.lstrip(b"\x00")), len(rb.rstrip(b"\x00")) - 1
            self.assertLessEqual(abs((W - 1 - ha) - lb), 1, y)
            self.assertLessEqual(abs((W - 1 - la) - hb), 1, y)
            # the part is not symmetric, so the test can tell a flip from none
            asym += sum(1 for x in range(la, ha + 1) if (ra[x] > 127) != (ra[W - 1 - x] > 127))
        self.assertGreater(asym, 100)

    def test_generic_resin_errors(self):
        p_off = os.path.join(MESHES, "P.off")
        base = ["run", p_off, "-o", self.path("bad.zip"), "--printer", "generic-resin",
                "--format", "zip", "--set", "height_mm=10"]
        for kv, key in (("display_px_x=0", "display_px_x"), ("display_px_y=-5", "display_px_y"),
                        ("display_px_x=20000", "display_px_x"),
                        ("display_mm_x=0", "display_mm_x"),
                        ("display_mm_y=1", "display_mm_y"),     # 0.4 um pixels
                        ("display_px_y=100", "display_mm_y")):  # 0.96 mm pixels
            self.assert_one_line_error(run(*base, "--set", kv), key)
        # the SL1's display is its firmware's
        self.assert_one_line_error(
            run("run", p_off, "-o", self.path("bad.sl1"), "--set", "height_mm=10",
                "--set", "display_px_x=3840"), "display_px_x", "generic-resin")
        self.assert_one_line_error(
            run("run", p_off, "-o", self.path("bad2.sl1"), "--set", "height_mm=10",
                "--set", "mirror_x=false"), "mirror_x")
        # and generic-resin writes no SL1 archive
        self.assert_one_line_error(
            run("run", p_off, "-o", self.path("bad3.sl1"), "--printer", "generic-resin",
                "--set", "height_mm=10"), "printer")

    # ---- errors -----------------------------------------------------------
    def test_errors_are_one_line(self):
        femur = os.path.join(MESHES, "femur.off")
        self.assert_one_line_error(run("run", self.path("nope.stl"), "-o", self.path("x.sl1")),
                                   "nope.stl")
        self.assert_one_line_error(run("run", femur, "-o", self.path("x.sl1"), "--set",
                                       "wobble=3"), "wobble")
        self.assert_one_line_error(run("run", femur, "-o", self.path("x.sl1"), "--set",
                                       "layer_mm=-1"), "layer_mm")
        self.assert_one_line_error(run("run", femur, "-o", self.path("x.sl1"), "--engine",
                                       "magic"), "magic")
        self.assert_one_line_error(run("run", femur, "-o", self.path("x.foo")), "--format")
        p = run("run", femur, "-o", self.path("big.sl1"), "--set", "height_mm=200")
        self.assert_one_line_error(p, "does not fit", "too large in Z")
        self.assertFalse(os.path.exists(self.path("big.sl1")))
        self.assertFalse(os.path.exists(self.path("big.sl1.part")))
        self.assertEqual(run("run").returncode, 2)
        self.assertEqual(run("run", femur).returncode, 2)
        self.assertEqual(run("frobnicate").returncode, 2)

    def test_broken_meshes_never_crash(self):
        broken = os.path.join(MESHES, "broken")
        for name in sorted(os.listdir(broken)):
            p = run("run", os.path.join(broken, name), "-o", self.path("b.zip"), "--quiet")
            self.assertIn(p.returncode, (0, 1), f"{name}: {p.returncode} {p.stderr}")
            if p.returncode == 1:
                self.assert_one_line_error(p)

    def test_too_small_part_warns(self):
        """femur.off is 1 unit tall: as millimetres it prints 20 layers of a
        speck; run and analyze warn on stderr and in the metrics' warnings,
        naming height_mm and units (--quiet: in the metrics only); a 50 mm
        part does not."""
        femur = os.path.join(MESHES, "femur.off")
        met = self.path("small.json")
        p = run("run", femur, "-o", self.path("small.sl1"), "--metrics", met, check=True)
        warn = [l for l in p.stderr.splitlines() if l.startswith("infilld: warning: ")]
        self.assertEqual(len(warn), 1, p.stderr)
        for needle in ("height_mm", "units", "5 mm"):
            self.assertIn(needle, warn[0])
        w = load(met)["warnings"]
        self.assertEqual(len(w), 1)
        self.assertIn("height_mm", w[0])
        p = run("run", femur, "-o", self.path("small.sl1"), "--metrics", met, "--quiet",
                check=True)
        self.assertEqual(p.stderr, "")
        self.assertEqual(len(load(met)["warnings"]), 1)
        p = run("analyze", femur, check=True)
        self.assertIn("height_mm", json.loads(p.stdout)["warnings"][0])
        self.assertIn("infilld: warning: ", p.stderr)
        p = run("run", femur, "-o", self.path("big.sl1"), "--metrics", met, "--quiet",
                "--set", "height_mm=50", "--set", "layer_mm=0.5", check=True)
        self.assertEqual(p.stderr, "")
        self.assertNotIn("warnings", load(met))

    def test_quiet_is_silent(self):
        p = run("run", os.path.join(MESHES, "misc", "cube.bin.stl"), "-o", self.path("q.zip"),
                "--set", "height_mm=1", "--quiet")
        self.assertEqual(p.returncode, 0)
        self.assertEqual(p.stderr, "")

    def test_params_file(self):
        pf = self.path("params.json")
        with open(pf, "w") as f:
            json.dump({"height_mm": 5, "up": "y", "exposure_s": 3.5}, f)
        met = self.path("pf.json")
        run("run", os.path.join(MESHES, "femur.off"), "-o", self.path("pf.sl1"), "--params", pf,
            "--metrics", met, "--quiet", check=True)
        self.assertAlmostEqual(load(met)["bbox_mm"]["max"]["z"], 5.0, places=6)
        with open(pf, "w") as f:
            json.dump({"height_mm": "five"}, f)
        self.assert_one_line_error(run("run", os.path.join(MESHES, "femur.off"), "-o",
                                       self.path("pf.sl1"), "--params", pf), "height_mm")


if __name__ == "__main__":
    unittest.main(verbosity=2)
