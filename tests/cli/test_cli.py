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
        for n in ("sl1", "sl1s", "generic-fdm"):
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
