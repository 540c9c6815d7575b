"""test_gcode_meshes.py - G-code of real meshes through the CLI, verified by
the independent checker (tests/support/gcodecheck.py): zero containment
violations (every bead inside the mesh's own section at the layer's mid
height), E consistent move by move and with the metrics, thumbnails that
decode, and deposited volumes that fit the mesh.

Each case places the mesh at 50 mm with the generic FDM profile and writes
it as STL (the part in the printer frame), then prints that STL with the
solid engine: sparse infill with skins, all-solid (infill_pct=100), or a
uniform 1.2 mm shell (shell_mm: every region LAYER_FILL_SOLID).  The subset
covers what broke containment before: pin-holes and notches (femur),
overlapping shells (camel), open meshes (bunny, mushroom), sharp CAD edges
(fandisk), bent thin shells (P), genus 1 (knot1).  Stdlib only; env
INFILLD_BIN, INFILLD_SHARED as tests/cli/test_cli.py.
"""
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest
from concurrent.futures import ThreadPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
import gcodecheck  # noqa: E402

BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")

# (name, file, placement keys, print mode)
CASES = [
    ("femur", "femur.off", [], "sparse"),
    ("femur", "femur.off", [], "shell"),
    ("femur", "femur.off", [], "dense"),
    ("camel", "camel.off", ["up=y"], "sparse"),
    ("bunny", "bunny.stl", ["units=m", "up=y"], "sparse"),
    ("mushroom", "mushroom.off", [], "shell"),
    ("fandisk", "fandisk.off", [], "shell"),
    ("P", "P.off", ["up=y"], "shell"),
    ("knot1", "knot1.off", [], "sparse"),
]
MODE_KEYS = {"sparse": [], "shell": ["shell_mm=1.2"], "dense": ["infill_pct=100"]}
ROLES = ("external_perimeter", "perimeter", "gap_fill", "internal_infill", "solid_infill",
         "top_solid_infill", "bridge_infill")
W, H = 0.45, 0.2  # generic-fdm line width, layer height


def run(*args):
    p = subprocess.run([BIN, *args], capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        raise AssertionError("infilld %s failed (%d): %s" % (" ".join(args), p.returncode, p.stderr))


class GcodeMeshesTest(unittest.TestCase):
    results = {}

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        d = cls.tmp.name
        # place each mesh once (the STL is the part in the printer frame)
        placed = {}
        for name, fname, keys, _ in CASES:
            if name in placed:
                continue
            stl = os.path.join(d, name + ".stl")
            args = ["run", os.path.join(MESHES, fname), "-o", stl, "--printer", "generic-fdm",
                    "--quiet", "--set", "height_mm=50"]
            for k in keys:
                args += ["--set", k]
            run(*args)
            placed[name] = stl

        def one(case):
            name, _, _, mode = case
            stl = placed[name]
            g = os.path.join(d, "%s.%s.gcode" % (name, mode))
            args = ["run", stl, "-o", g, "--quiet", "--threads", "1", "--metrics", g + ".json"]
            for k in MODE_KEYS[mode]:
                args += ["--set", k]
            run(*args)
            with open(g + ".json") as f:
                m = json.load(f)
            rep = gcodecheck.check_file(g, mesh=stl, raise_on_error=False)
            return (name, mode), (m, rep)

        with ThreadPoolExecutor(2) as ex:
            cls.results = dict(ex.map(one, CASES))
        for (name, mode), (m, rep) in sorted(cls.results.items()):
            print("%-9s %-6s layers %3d  part %8.1f mm3  mesh %8.1f mm3  ratio %.3f  errors %s"
                  % (name, mode, rep["layers"], m["gcode"]["part_material_mm3"],
                     m["mesh"]["volume_mm3"],
                     m["gcode"]["part_material_mm3"] / m["mesh"]["volume_mm3"],
                     rep["error_counts"] or "none"), file=sys.stderr)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def each(self):
        self.assertEqual(len(self.results), len(CASES))
        for key in sorted(self.results):
            with self.subTest(case="%s/%s" % key):
                yield key, self.results[key][0], self.results[key][1]

    def test_checker_passes(self):
        """No failure of any kind: containment, E per move, layers, Z only on
        travels, header/footer agreement, M73, thumbnails."""
        for key, m, rep in self.each():
            self.assertEqual(rep["containment_violations"], 0, rep["errors"][:5])
            self.assertTrue(rep["ok"], rep["errors"][:5])
            self.assertEqual(rep["layers"], 250)

    def test_e_consistent_with_metrics(self):
        for key, m, rep in self.each():
            g = m["gcode"]
            # the moves' E, the footer and the metrics are one sum (1e-5 mm units)
            self.assertAlmostEqual(g["filament_mm"], rep["extruded_e_mm"], delta=0.006)
            self.assertAlmostEqual(m["material_volume_mm3"], rep["extruded_volume_mm3"],
                                   delta=0.02)
            part = sum(rep.get("volume." + r, 0.0) for r in ROLES)
            self.assertAlmostEqual(g["part_material_mm3"], part, delta=0.02)
            self.assertLess(g["part_material_mm3"],
                            m["material_volume_mm3"] - g["volume_mm3"]["skirt"] + 1e-6)
            self.assertIsInstance(g["bytes"], int)
            self.assertEqual(g["thumbnails"], 2)
            self.assertEqual(rep["thumbnails"], 2)

    def test_volume_plausible(self):
        for (name, mode), m, rep in self.each():
            part = m["gcode"]["part_material_mm3"]
            if mode == "dense":
                # Slic3r beads tile the section except a band of (w - s)/2
                # along the outline (the outer bead's rounded edge); the
                # zigzag joins between infill lines come on top (counted
                # by the checker).  Section area and outline: the
                # checker's own slices.
                s = W - H * (1 - math.pi / 4)
                want = rep["region_volume_mm3"] - rep["region_outline_mm2"] * (W - s) / 2
                joins = sum(v for k, v in rep.items() if k.endswith("infill_connector_volume_mm3"))
                self.assertAlmostEqual((part - joins) / want, 1.0, delta=0.02)
                self.assertLess(joins, 0.03 * want)
            elif mode == "shell":
                # all of the designed material (the engine's sliced shell)
                # less the outline bands and unprintable slivers
                ratio = part / m["solid"]["sliced_volume_mm3"]
                self.assertGreater(ratio, 0.88)
                self.assertLess(ratio, 1.02)
            else:
                # perimeters, skins and 15 % of the rest
                ratio = part / m["mesh"]["volume_mm3"]
                self.assertGreater(ratio, 0.2)
                self.assertLess(ratio, 0.9)


if __name__ == "__main__":
    unittest.main()
