"""test_hollow_meshes.py - the top-down fill of the `hollow` engine on a
shared mesh at the paper's scale (issue 5's acceptance: 50 mm, alpha 45 and
30).  The camel stood on +y, fill alone (rounds=0), SL1 layers checked by
engine/verify (the very images written, independent of the fill).

Asserts: zero interior overhang, no islands beyond the part's own (the
plain `solid` slicing of the same placement), walls to the outside >=
wall_mm and vertical walls >=
wall_next_mm less one pixel / layer of rasterisation, every fill void enclosed, alpha 30 never hollows more than
alpha 45, and a floor on the reduction at 45 degrees (measured 52.7 %;
the old fill reached 38 %, so a regression to it fails).  The femur stood on
+z: a floor on its reduction (43.7 %, 42.1 with standing walls, whose run
is asserted to remove less; 21.7 % while ghost cells, solid that
a receded void's carried distance turned void a pixel at a time, were
walled off in its head).  Both: fins (solid one or two pixels thick
between enclosed voids, measured by the verifier) under a bound that the
fill failed before its fins receded (camel 0.14, femur 1.32 mm3), and walls
between two voids (the verifier's min_wall_between_mm, in the layer and along
columns) >= wall_next_mm less one pixel / layer.  The open bunny: the
overhang of its own sealed scan pockets is reported as the part's, and
hollowing adds none.
Standalone: python3 tests/hollow/test_hollow_meshes.py
"""
import json
import os
import subprocess
import tempfile
import sys
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
from hollowcheck import optimised_slopes_ok  # noqa: E402
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")
COMMON = ["height_mm=50", "up=y"]


def run(tmp, engine, *sets, mesh="camel", common=COMMON):
    """mesh: a name under meshes/ (.off when it has no extension)."""
    name, ext = os.path.splitext(mesh)
    out = os.path.join(tmp, name + engine + ".sl1")
    met = os.path.join(tmp, name + engine + ".json")
    args = [BIN, "run", os.path.join(MESHES, mesh if ext else mesh + ".off"), "-o", out,
            "--engine", engine,
            "--threads", "2", "--quiet", "--metrics", met]
    for kv in common + list(sets):
        args += ["--set", kv]
    p = subprocess.run(args, capture_output=True, text=True, timeout=1800)
    if p.returncode != 0:
        raise AssertionError(f"{' '.join(args)}: {p.stderr}")
    with open(met) as f:
        return json.load(f), out


def check_between(t, v, required):
    """Walls between two voids >= wall_next_mm (0.8) less one pixel (0.047 mm)
    or layer (0.05 mm); measured camel 0.927, femur 0.922 mm in the layer.
    required: the part has two voids side by side in some layer (null
    otherwise)."""
    if required:
        t.assertIsNotNone(v["min_wall_between_mm"], v)
    if v["min_wall_between_mm"] is not None:
        t.assertGreaterEqual(v["min_wall_between_mm"], 0.8 - 0.06, v)
    if v["min_wall_between_vertical_mm"] is not None:
        t.assertGreaterEqual(v["min_wall_between_vertical_mm"], 0.8 - 0.06, v)


class HollowMeshTest(unittest.TestCase):
    def test_camel_optimiser_alone(self):
        # the paper's optimiser alone (no fill): strips rebuilt with the
        # support-free start keep every group (none failed: 11 before), the
        # voids print support-free, and the beads the layers split off
        # them (a pixel or two from their void) are painted solid, so walls
        # between cavities stay >= wall_next_mm (0.10 mm before)
        with tempfile.TemporaryDirectory() as tmp:
            m, _ = run(tmp, "hollow", "alpha_deg=45", "rounds=1", "fill=false",
                       "optimise_s=0", "wall_mm=1.0", "wall_next_mm=0.8",
                       mesh="camel", common=["height_mm=50", "up=y"])
            h = m["hollow"]
            v = h["verify"]
            self.assertEqual(h["groups_failed"], 0, h)
            self.assertGreaterEqual(h["voids_optimised"], 3, h)  # 5 measured
            self.assertEqual(h["voids_fill"], 0)
            # 23 px read over before the mending (0.43 px), 0.44 mm3 of gray
            # added by it (8,855 pixels); polygons: 0.0011 mm2 on 2 layers
            # (void tops)
            optimised_slopes_ok(self, h, max_polygon_mm2=0.003)
            self.assertGreaterEqual(v["min_wall_mm"], 1.0 - 0.06, v)
            check_between(self, v, required=False)
            self.assertEqual(v["specks"], 0, v)
            # beads are tiny (16, 0.007 mm3 measured); the voids are what
            # the layers hold, to a pixel's rim (enclosed 177.46 mm3 against
            # 177.82 from the mesh)
            self.assertLess(h["fragment_mm3"], 0.05, h)
            self.assertGreater(h["volume_reduction"], 0.02)
            self.assertAlmostEqual(v["enclosed_void_mm3"], h["void_volume_mm3"],
                                   delta=0.01 * h["void_volume_mm3"])

    def test_camel_fill_at_45_and_30(self):
        with tempfile.TemporaryDirectory() as tmp:
            _, solid_out = run(tmp, "solid")
            p = subprocess.run([BIN, "verify", solid_out], capture_output=True, text=True,
                               timeout=600)
            self.assertEqual(p.returncode, 0, p.stderr)
            own_islands = json.loads(p.stdout)["islands"]
            res = {}
            # alpha 30 allows 0.029 mm a layer, under the 0.047 mm pixel: no
            # whole pixel may hang over a void, so the pixel fill alone
            # closes no roof (tests/hollow/test_hollow.py, docs/hollow.md)
            m, _ = run(tmp, "hollow", "alpha_deg=30", "rounds=0", "fill=true",
                       "wall_mm=1.0", "wall_next_mm=0.8")
            self.assertEqual(m["hollow"]["voids"], 0)
            self.assertIn("less than the 0.047 mm pixel", m["hollow"]["note"])
            for a in (45,):
                m, _ = run(tmp, "hollow", f"alpha_deg={a}", "rounds=0", "fill=true",
                           "wall_mm=1.0", "wall_next_mm=0.8")
                h = m["hollow"]
                v = h["verify"]
                res[a] = h
                self.assertGreaterEqual(h["voids_fill"], 1)
                self.assertEqual(h["interior_overhang_mm2"], 0.0, v)
                self.assertLessEqual(v["islands"], own_islands, v)
                # less one pixel (0.047 mm) of rasterisation: the 1 mm offset
                # reads 0.946 mm
                self.assertGreaterEqual(v["min_wall_mm"], 1.0 - 0.06, v)
                self.assertGreaterEqual(v["min_wall_vertical_mm"], 0.8 - 0.06, v)
                self.assertAlmostEqual(v["enclosed_void_mm3"], h["fill_volume_mm3"],
                                       delta=1e-3 * h["fill_volume_mm3"])
                check_between(self, v, required=(a == 45))
            # 50.5 % at the exact slope rule with the corners mitred (47.4
            # grown round; 53.5 round with a pixel of slack)
            self.assertGreater(res[45]["volume_reduction"], 0.45)
            # fins (docs/verify.md): 0.14 mm3 while kept R pixels and
            # staircase patches stood to the floor, 0.03 since they recede
            self.assertLess(res[45]["verify"]["fin_mm3"], 0.08, res[45]["verify"])
            # slivers (fins standing free, not bumps on walls): 0.0016 mm3
            # measured with a pixel of slack, 0.0116 at the exact rule
            self.assertLessEqual(res[45]["verify"]["sliver_px"], res[45]["verify"]["fin_px"])
            self.assertLess(res[45]["verify"]["sliver_mm3"], 0.02, res[45]["verify"])
            # shelves (fins' vertical counterpart): 0.002 mm3 measured
            self.assertLess(res[45]["verify"]["shelf_mm3"], 0.01, res[45]["verify"])

    def test_femur_fill(self):
        # leaning walls (the default) and standing ones (lean_walls=false)
        res = {}
        with tempfile.TemporaryDirectory() as tmp:
            for lean in ("true", "false"):
                m, _ = run(tmp, "hollow", "alpha_deg=45", "rounds=0", "fill=true",
                           "wall_mm=1.0", "wall_next_mm=0.8", f"lean_walls={lean}",
                           mesh="femur", common=["height_mm=50", "up=z"])
                h = m["hollow"]
                v = h["verify"]
                res[lean] = h
                self.assertEqual(h["interior_overhang_mm2"], 0.0, v)
                self.assertGreaterEqual(v["min_wall_mm"], 1.0 - 0.06, v)
                self.assertGreaterEqual(v["min_wall_vertical_mm"], 0.8 - 0.06, v)
                self.assertAlmostEqual(v["enclosed_void_mm3"], h["fill_volume_mm3"],
                                       delta=1e-3 * h["fill_volume_mm3"])
                self.assertGreater(h["volume_reduction"], 0.38)
                # fins: 1.32 mm3 before they receded, 0.09 since (0.12
                # leaning); 0.16 / 0.38 at the exact slope rule; standing,
                # 0.45 once the walls between voids are cut to wall_next
                # (docs/hollow.md 4.2)
                self.assertLess(v["fin_mm3"], 0.5, v)
                # slivers: 0.103 (leaning) / 0.190 mm3 (standing) measured
                # with the exact slope rule (0.025 leaning with a pixel of
                # slack): fronts that may advance one pixel, not 1.98, a
                # layer leave more of them (issue 22)
                self.assertLess(v["sliver_mm3"], 0.25, v)
                self.assertLess(v["shelf_mm3"], 0.02, v)  # 0.005 measured
                check_between(self, v, required=True)
        # the wall between the head's and the trochanter's voids leans and
        # ends instead of standing down the shaft: 43.7 % against 42.1 %
        self.assertGreater(res["true"]["volume_reduction"],
                           res["false"]["volume_reduction"] + 0.01)

    def test_bunny_scan_pockets(self):
        # the open Stanford bunny (the paper's Rabbit): the slicer closes
        # the holes in its base into small sealed pockets, and at 50 mm
        # one pocket's ceiling hangs (33 px on layer 41 of the plain part).
        # Hollowing does not make it and cannot print it away: the engine
        # reads its layers against the plain part, so the pockets are the
        # part's own air, their ceilings the part's own overhang, and the
        # interior's overhang is 0.  The plain `solid` slicing read by
        # `infilld verify` (no reference: the pockets read as enclosed)
        # must agree with the engine's measure of the part's own.
        with tempfile.TemporaryDirectory() as tmp:
            common = ["height_mm=50", "up=y"]
            _, solid_out = run(tmp, "solid", mesh="bunny.stl", common=common)
            p = subprocess.run([BIN, "verify", solid_out], capture_output=True, text=True,
                               timeout=600)
            self.assertEqual(p.returncode, 0, p.stderr)
            own = json.loads(p.stdout)
            self.assertGreater(own["interior_overhang_mm2"], 0, own)
            self.assertGreater(own["enclosed_void_mm3"], 0, own)
            m, out = run(tmp, "hollow", "alpha_deg=45", "rounds=0", "fill=true",
                         "wall_mm=1.0", "wall_next_mm=0.8", mesh="bunny.stl", common=common)
            h = m["hollow"]
            v = h["verify"]
            self.assertAlmostEqual(h["part_interior_overhang_mm2"], own["interior_overhang_mm2"],
                                   delta=1e-9, msg=h)
            self.assertEqual(v["part_overhang_mm2"], h["part_interior_overhang_mm2"], v)
            self.assertEqual(h["interior_overhang_mm2"], 0.0, v)
            self.assertLessEqual(v["islands"], own["islands"], v)
            self.assertGreaterEqual(v["min_wall_mm"], 1.0 - 0.06, v)
            # the enclosed voids are the fill's alone (the pockets are the
            # part's air)
            self.assertAlmostEqual(v["enclosed_void_mm3"], h["fill_volume_mm3"],
                                   delta=1e-3 * h["fill_volume_mm3"])
            # `infilld verify --solid` reads the written stack the same way
            p = subprocess.run([BIN, "verify", out, "--solid", solid_out], capture_output=True,
                               text=True, timeout=600)
            self.assertEqual(p.returncode, 0, p.stderr)
            ref = json.loads(p.stdout)
            self.assertEqual(ref["interior_overhang_mm2"], 0.0, ref)
            self.assertAlmostEqual(ref["part_overhang_mm2"], own["interior_overhang_mm2"],
                                   delta=1e-9, msg=ref)
            self.assertAlmostEqual(ref["enclosed_void_mm3"], v["enclosed_void_mm3"], delta=1e-6)
            self.assertTrue(ref["printable"], ref)
            # 63.8 % measured (the paper's Rabbit: 73.47 %; uniform 1 mm
            # hollowing, overhangs and all, removes 76.8 %)
            self.assertGreater(h["volume_reduction"], 0.62, h)


if __name__ == "__main__":
    unittest.main()
