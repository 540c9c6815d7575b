"""test_hybrid.py - `infilld run ... --engine hybrid` end to end (paper 003).

The cow stood on its feet at 60 mm (0.1 mm layers to keep the test short):
the partition gives its four legs as VCol components with near-vertical
axes and the body as the one largest NCol component; the weight fraction
at the defaults is between 30 and 50 %; `infilld verify --solid` (the
verifier's own island reading, computed apart from the engine) finds no
island the solid part does not have.  structure=tcs and structure=mfs
build one structure everywhere; the mesh output is a closed 2-manifold
counted here from the STL; G-code runs; bad parameters give one-line
errors naming the parameter.

Run by tests/run.sh; standalone: python3 tests/hybrid/test_hybrid.py
"""
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
from meshgen import write_box_stl  # noqa: E402
COW = ["--set", "height_mm=60", "--set", "up=y", "--set", "layer_mm=0.1"]


def run(*args, check=True):
    p = subprocess.run([BIN, *args], capture_output=True, text=True, timeout=900)
    if check and p.returncode != 0:
        raise AssertionError(f"infilld {' '.join(args)} failed ({p.returncode}): {p.stderr}")
    return p


def stl_edges(path):
    """Binary STL -> (undirected edge -> count, directed edge set, volume)."""
    with open(path, "rb") as f:
        data = f.read()
    n = struct.unpack_from("<I", data, 80)[0]
    index, count, directed, vol = {}, {}, {}, 0.0
    for t in range(n):
        vals = struct.unpack_from("<12f", data, 84 + 50 * t)
        ids, pts = [], []
        for c in range(3):
            p = vals[3 + 3 * c: 6 + 3 * c]
            ids.append(index.setdefault(p, len(index)))
            pts.append(p)
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = pts
        vol += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
        for a, b in ((ids[0], ids[1]), (ids[1], ids[2]), (ids[2], ids[0])):
            key = (min(a, b), max(a, b))
            count[key] = count.get(key, 0) + 1
            directed[(a, b)] = directed.get((a, b), 0) + 1
    return count, directed, vol / 6, n


class HybridCli(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = cls.tmp.name
        cls.cow = os.path.join(MESHES, "cow.off")
        cls.cow_sl1 = os.path.join(cls.dir, "cow.sl1")
        cls.cow_metrics = cls.job(cls.cow, cls.cow_sl1, *COW)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def job(cls, src, out, *extra):
        met = out + ".json"
        run("run", src, "-o", out, "--quiet", "--metrics", met, "--engine", "hybrid", *extra)
        with open(met) as f:
            return json.load(f)

    def path(self, name):
        return os.path.join(self.dir, name)

    def test_cow_partition(self):
        h = self.cow_metrics["hybrid"]
        comps = h["components"]
        for c in comps:
            print(f"cow: {c['class']} {c['facets']} facets, {c['area_mm2']:.0f} mm2, axis "
                  f"{c['axis']}, base {c['base_mm']}, mean stress {c['mean_stress_mpa']} MPa, "
                  f"dominance {c['dominance']:.2f} / {c['dominance_45']:.2f}")
        ncol = [c for c in comps if c["class"] == "NCol"]
        self.assertEqual(len(ncol), 1, "the body is one NCol component")
        self.assertEqual(max(comps, key=lambda c: c["area_mm2"])["class"], "NCol")
        # legs: VCol, axis within 30 degrees of vertical, base at the leg tops
        legs = []
        for c in comps:
            ax = [float(v) for v in c["axis"].split(",")]
            base_z = float(c["base_mm"].split(",")[2])
            if c["class"] == "VCol" and abs(ax[2]) >= math.cos(math.radians(30)) \
                    and base_z < 30:
                legs.append(c)
        self.assertEqual(len(legs), 4, comps)
        for c in legs:
            sz = abs(float(c["mean_stress_mpa"].split(",")[2]))
            self.assertGreater(c["dominance"], 2)
            self.assertGreater(sz, 1, "a leg carries the load axially")

    def test_elephant_partition(self):
        # This elephant rears on its two hind feet (the two feet within 5 %
        # of the height of the plate); its raised front legs carry nothing
        # under a load on its top, so section 4.2 makes them NCol.
        out = self.path("elephant.sl1")
        m = self.job(os.path.join(MESHES, "elephant.off"), out, "--set", "height_mm=60",
                     "--set", "up=y", "--set", "layer_mm=0.2", "--set", "compliance=false")
        comps = m["hybrid"]["components"]
        for c in comps:
            print(f"elephant: {c['class']} {c['area_mm2']:.0f} mm2, axis {c['axis']}, base "
                  f"{c['base_mm']}, mean stress {c['mean_stress_mpa']} MPa, dominance "
                  f"{c['dominance']:.2f} / {c['dominance_45']:.2f}")
        self.assertEqual(len([c for c in comps if c["class"] == "NCol"]), 1)
        self.assertEqual(max(comps, key=lambda c: c["area_mm2"])["class"], "NCol")
        standing = [c for c in comps if c["class"] == "VCol"
                    and float(c["axis"].split(",")[2]) < -math.cos(math.radians(30))
                    and float(c["base_mm"].split(",")[2]) < 20]
        self.assertEqual(len(standing), 2, comps)
        self.assertLess(m["hybrid"]["weight_fraction"], 0.6)

    def test_cow_weight_and_islands(self):
        h = self.cow_metrics["hybrid"]
        print(f"cow: weight fraction {h['weight_fraction']:.4f}, filled by the support rule "
              f"{h['support_filled_mm3']:.0f} mm3, strut overhang {h['interior_overhang_mm2']:.0f}"
              f" mm2, {h['extended_columns']} extended columns, seconds {h['seconds']}")
        self.assertGreaterEqual(h["weight_fraction"], 0.30)
        self.assertLessEqual(h["weight_fraction"], 0.50)
        self.assertGreater(h["extended_columns"], 0)
        self.assertGreater(h["transient_mm2"], 0)
        solid = self.path("cow.solid.sl1")
        run("run", self.cow, "-o", solid, "--quiet", *COW)
        rep = json.loads(run("verify", self.cow_sl1, "--solid", solid).stdout)
        print(f"cow verify: islands {rep['islands']} (added {rep['islands_added']}), interior "
              f"overhang {rep['interior_overhang_mm2']:.1f} mm2, enclosed voids "
              f"{rep['enclosed_void_mm3']:.0f} mm3")
        self.assertEqual(rep["islands_added"], 0, rep)
        self.assertEqual(rep["first_solid_layer"], 0, rep)
        # the design's voids are there: the printed volume is the metric's
        self.assertGreater(rep["enclosed_void_mm3"], 0.4 * h["part_grid_mm3"])

    def test_single_structures(self):
        box = self.path("box.stl")
        write_box_stl(box, 16, 14, 12)
        for s in ("tcs", "mfs"):
            with self.subTest(structure=s):
                out = self.path(f"box.{s}.sl1")
                m = self.job(box, out, "--set", f"structure={s}", "--set", "layer_mm=0.1",
                             "--set", "compliance=false")
                h = m["hybrid"]
                self.assertEqual(h["structure"], s)
                self.assertNotIn("components", h)
                self.assertGreater(h["weight_fraction"], 0.2)
                self.assertLess(h["weight_fraction"], 0.9)
                solid = self.path("box.solid.sl1")
                run("run", box, "-o", solid, "--quiet", "--set", "layer_mm=0.1")
                rep = json.loads(run("verify", out, "--solid", solid).stdout)
                self.assertEqual(rep["islands_added"], 0, rep)
                if s == "mfs":
                    # vertical fibres closed at alpha under the roof: no overhang
                    self.assertEqual(h["interior_overhang_mm2"], 0, h)

    def test_mesh_output(self):
        box = self.path("box_m.stl")
        write_box_stl(box, 14, 12, 10)
        out = self.path("box.stl")
        m = self.job(box, out, "--set", "structure=mfs", "--set", "layer_mm=0.1",
                     "--set", "compliance=false")
        count, directed, vol, nt = stl_edges(out)
        bad = [e for e, c in count.items() if c != 2]
        self.assertEqual(bad, [], "every edge in exactly two triangles")
        self.assertTrue(all(c == 1 for c in directed.values()), "consistent orientation")
        mat = m["hybrid"]["material_mm3"]
        print(f"mesh: {nt} triangles, volume {vol:.1f} mm3 vs material {mat:.1f} mm3")
        # the iso level is chosen for the volume (+2.4 % at 1/2 on this box)
        self.assertAlmostEqual(vol, mat, delta=0.005 * mat)
        self.assertAlmostEqual(m["hybrid"]["mesh"]["volume_mm3"], vol, delta=1e-3 * vol)
        self.assertTrue(0.25 <= m["hybrid"]["mesh"]["iso"] <= 0.75, m["hybrid"]["mesh"])
        # at the printer's default 0.05 mm layers a mesh output designs on
        # layers of pixel / tan(alpha) (0.1 mm here): the same hollow design,
        # not a part filled solid by a support rule that cannot widen a
        # cavity by half a pixel (weight fraction 1.0 before)
        out2 = self.path("box_default_layers.stl")
        m2 = self.job(box, out2, "--set", "structure=mfs", "--set", "compliance=false")
        w, w2 = m["hybrid"]["weight_fraction"], m2["hybrid"]["weight_fraction"]
        print(f"mesh at default layers: weight fraction {w2:.4f} (0.1 mm layers {w:.4f})")
        self.assertLess(w2, 0.8)
        self.assertAlmostEqual(w2, w, delta=0.01)
        count2, _, vol2, _ = stl_edges(out2)
        self.assertEqual([e for e, c in count2.items() if c != 2], [])
        self.assertAlmostEqual(vol2, m2["hybrid"]["material_mm3"],
                               delta=0.005 * m2["hybrid"]["material_mm3"])

    def test_gcode(self):
        box = self.path("box_g.stl")
        write_box_stl(box, 20, 16, 10)
        out = self.path("box.gcode")
        m = self.job(box, out, "--set", "structure=tcs")
        self.assertGreater(m["hybrid"]["weight_fraction"], 0.2)
        with open(out) as f:
            self.assertIn("G1", f.read())

    def test_bad_parameters(self):
        box = self.path("box_b.stl")
        write_box_stl(box, 10, 10, 10)
        cases = [("tcs_stick_mm=3", "tcs_stick_mm"), ("wall_mm=5", "wall_mm"),
                 ("tcs_ball_mm=3", "tcs_ball_mm"), ("structure=foam", "structure"),
                 ("loads=fixed nowhere", "loads")]
        for kv, field in cases:
            with self.subTest(kv=kv):
                p = run("run", box, "-o", self.path("b.sl1"), "--engine", "hybrid",
                        "--set", kv, check=False)
                self.assertNotEqual(p.returncode, 0)
                self.assertIn(field, p.stderr)
                self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)

    def test_sub_pixel_slope_warns(self):
        # alpha 30 at 0.05 mm layers on the SL1's 0.047 mm pixel: a layer may
        # overhang 0.029 mm, under a pixel, so the cells fill; the job says so
        box = self.path("box_w.stl")
        write_box_stl(box, 12, 10, 8)
        warn = "less than the 0.047 mm design pixel"
        for alpha, warned in (("30", True), ("45", False)):
            with self.subTest(alpha=alpha):
                m = self.job(box, self.path(f"w{alpha}.sl1"), "--set", "structure=mfs",
                             "--set", f"alpha_deg={alpha}", "--set", "compliance=false")
                hits = [w for w in m.get("warnings", []) if warn in w]
                self.assertEqual(bool(hits), warned, m.get("warnings"))
                if warned:
                    self.assertGreater(m["hybrid"]["weight_fraction"], 0.9)
                else:
                    self.assertLess(m["hybrid"]["weight_fraction"], 0.8)


if __name__ == "__main__":
    unittest.main(verbosity=2)
