"""test_rhombic.py - `infilld run ... --engine rhombic` end to end.

Self-support: SL1 outputs of three shared meshes at 50 mm, at alpha 45
and 30 degrees, read back by `infilld verify --alpha-deg A --solid
SOLID.sl1` (the solid engine's stack of the same part): no interior
overhang, no island the solid part does not have, and walls (between
cavities, and to the outside) at least wall_mm less one pixel, or the
solid part's own reading where the solid already reads less (its own
rasterisation specks).  Mesh output: a closed 2-manifold (every edge in
exactly two faces, counted here from the STL) whose volume equals the
part less the cavities and the layer output's volume within 1 %.  The
paper's beam (Fig. 12) and the letter P standing (Fig. 13), bad
parameters (one-line errors naming the parameter).

Run by tests/run.sh; standalone: python3 tests/rhombic/test_rhombic.py
"""
import configparser
import json
import os
import struct
import subprocess
import sys
import tempfile
import unittest
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
from meshgen import write_box_stl  # noqa: E402

# mesh: placement (50 mm, coarse layers so that verify reads few images)
PARTS = {
    "femur.off": ["--set", "height_mm=50", "--set", "layer_mm=0.2"],
    "camel.off": ["--set", "height_mm=50", "--set", "up=y", "--set", "layer_mm=0.2"],
    "armadillo.off": ["--set", "height_mm=50", "--set", "layer_mm=0.2"],
}
WALL = 0.5  # resin walls; the skin as thick
# the initial structure refined uniformly once or twice (objective=stability
# with refine=uniform refines without an FEA solve)
GEOMETRY = ["--engine", "rhombic", "--set", f"wall_mm={WALL}", "--set", f"skin_mm={WALL}",
            "--set", "refine=uniform", "--set", "volume_fraction=0.95",
            "--set", "objective=stability"]


def run(*args, check=True):
    p = subprocess.run([BIN, *args], capture_output=True, text=True, timeout=600)
    if check and p.returncode != 0:
        raise AssertionError(f"infilld {' '.join(args)} failed ({p.returncode}): {p.stderr}")
    return p


def pixel_mm(sl1):
    with zipfile.ZipFile(sl1) as z:
        ini = configparser.ConfigParser()
        ini.read_string("[x]\n" + z.read("prusaslicer.ini").decode())
    x = ini["x"]
    return max(float(x["display_width"]) / float(x["display_pixels_x"]),
               float(x["display_height"]) / float(x["display_pixels_y"]))


def read_stl(path):
    """Binary STL -> (triangles as vertex-index triples, vertices)."""
    with open(path, "rb") as f:
        data = f.read()
    n = struct.unpack_from("<I", data, 80)[0]
    index, verts, tris = {}, [], []
    for t in range(n):
        vals = struct.unpack_from("<12f", data, 84 + 50 * t)
        tri = []
        for c in range(3):
            p = vals[3 + 3 * c: 6 + 3 * c]
            if p not in index:
                index[p] = len(verts)
                verts.append(p)
            tri.append(index[p])
        tris.append(tri)
    return tris, verts


# Fig. 12: 100 x 50 x 6.25 mm standing on its 100 x 6.25 face; left bottom
# end fixed, right bottom end on a roller, 62 N down on the top middle.
# Boxes in mm from the part's minimum corner (docs/fea.md).
BEAM_LOADS = ("fixed box=0,0,-0.5,2,6.25,0.5 axes=xyz; fixed box=98,0,-0.5,100,6.25,0.5 axes=z; "
              "force box=48,0,49.5,52,6.25,50.5 n=0,0,-62")
BEAM = ["--engine", "rhombic", "--printer", "generic-fdm", "--set", "orient_deg=0",
        "--set", "wall_mm=0.5", "--set", "skin_mm=0.5", "--set", "fea_voxel_mm=1",
        "--set", f"loads={BEAM_LOADS}"]


def signed_volume(tris, verts):
    s = 0.0
    for a, b, c in tris:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = verts[a], verts[b], verts[c]
        s += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    return s / 6


class RhombicCli(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = cls.tmp.name

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def path(self, name):
        return os.path.join(self.dir, name)

    def job(self, src, out, *extra):
        met = out + ".json"
        run("run", src, "-o", out, "--quiet", "--metrics", met, *extra)
        with open(met) as f:
            return json.load(f)

    def test_self_supporting(self):
        for mesh, place in PARTS.items():
            src = os.path.join(MESHES, mesh)
            solid = self.path(mesh + ".solid.sl1")
            run("run", src, "-o", solid, "--quiet", *place)
            own = json.loads(run("verify", solid).stdout)
            px = pixel_mm(solid)
            for alpha in (45, 30):
                with self.subTest(mesh=mesh, alpha=alpha):
                    out = self.path(f"{mesh}.{alpha}.sl1")
                    m = self.job(src, out, *place, *GEOMETRY, "--set", f"alpha_deg={alpha}")
                    r = m["rhombic"]
                    rep = json.loads(run("verify", out, "--alpha-deg", str(alpha),
                                         "--solid", solid).stdout)
                    print(f"{mesh} alpha {alpha}: orientation {r['orientation_deg']}, "
                          f"{r['leaves']} cavities on {r['levels']} levels, fraction "
                          f"{r['volume_fraction_initial']:.3f} -> {r['volume_fraction']:.3f}; "
                          f"overhang {rep['interior_overhang_mm2']} mm2, islands "
                          f"{rep['islands']} (solid {own['islands']}, added "
                          f"{rep['islands_added']}), walls {rep['min_wall_mm']} / between "
                          f"{rep['min_wall_between_mm']} mm, enclosed "
                          f"{rep['enclosed_void_mm3']:.0f} mm3")
                    self.assertGreater(r["leaves"], 20)
                    self.assertEqual(rep["interior_overhang_mm2"], 0, rep)
                    self.assertEqual(rep["islands_added"], 0, rep)
                    self.assertEqual(rep["first_solid_layer"], 0, rep)
                    # the cavities are there, as designed (sliced, then rasterised)
                    self.assertAlmostEqual(rep["enclosed_void_mm3"], r["cavity_volume_mm3"],
                                           delta=0.05 * r["cavity_volume_mm3"])
                    floor = WALL - px
                    self.assertGreaterEqual(rep["min_wall_between_mm"], floor, rep)
                    if own["min_wall_mm"] is None or own["min_wall_mm"] >= floor:
                        self.assertGreaterEqual(rep["min_wall_mm"], floor, rep)
                    else:
                        self.assertGreaterEqual(rep["min_wall_mm"], own["min_wall_mm"] - 1e-9,
                                                rep)

    def test_mesh_output(self):
        src = os.path.join(MESHES, "armadillo.off")
        place = PARTS["armadillo.off"]
        stl, sl1 = self.path("arm.stl"), self.path("arm.sl1")
        ms = self.job(src, stl, *place, *GEOMETRY, "--set", "orient_deg=30")
        ml = self.job(src, sl1, *place, *GEOMETRY, "--set", "orient_deg=30")
        tris, verts = read_stl(stl)
        uses = {}
        for a, b, c in tris:
            for e in ((a, b), (b, c), (c, a)):
                k = (min(e), max(e))
                uses[k] = uses.get(k, 0) + 1
        self.assertTrue(all(n == 2 for n in uses.values()),
                        {k: n for k, n in uses.items() if n != 2})
        vol = signed_volume(tris, verts)
        r = ms["rhombic"]
        self.assertEqual(len(tris), ms["mesh"]["triangles"] + 12 * r["leaves"])
        self.assertAlmostEqual(vol, ms["part_volume_mm3"] - r["cavity_volume_mm3"],
                               delta=1e-4 * vol)
        self.assertAlmostEqual(vol, ml["rhombic"]["sliced_volume_mm3"], delta=0.01 * vol)
        print(f"armadillo mesh: {len(tris)} triangles, {r['leaves']} cavities, volume "
              f"{vol:.1f} mm3, layers {ml['rhombic']['sliced_volume_mm3']:.1f} mm3")

    def test_stability_letter_p(self):
        """Fig. 13: the letter P stood upright tips over as solid; refined
        for standing, its centre of mass projects into the contact hull."""
        src = os.path.join(MESHES, "P.off")
        m = self.job(src, self.path("p.sl1"), "--set", "up=y", "--set", "height_mm=100",
                     "--engine", "rhombic", "--set", "objective=stability",
                     "--set", "wall_mm=0.6", "--set", "skin_mm=0.6")
        r = m["rhombic"]
        print(f"P: centre of mass {r['com_before_mm']} (solid) -> {r['com_initial_mm']} "
              f"(initial) -> {r['com_after_mm']}, hull centre {r['hull_center_mm']}, "
              f"fraction {r['volume_fraction_initial']:.3f} -> {r['volume_fraction']:.3f}, "
              f"{r['stability_splits']} splits")
        self.assertFalse(r["com_solid_inside_hull"])
        self.assertTrue(r["com_inside_hull"])
        self.assertGreater(r["com_hull_distance_mm"], 0)
        self.assertLess(r["volume_fraction"], 1)

    def test_beam_adaptive_vs_uniform(self):
        """Fig. 12: uniform refinement to about 0.6, then the stiffness
        optimisation at the uniform result's fraction.  Paper: normalised
        compliance 1.94 (uniform) vs 1.25 (adaptive), ratio 1.55.  Measured
        here (1 mm elements, split_pct 5 to keep the test short): 2.00 vs
        1.60, ratio 1.25, max displacement 0.047 vs 0.035 mm; at the default
        2 %: 1.57, ratio 1.27 (docs/rhombic.md section 8)."""
        beam = self.path("beam.stl")
        write_box_stl(beam, 100, 6.25, 50)
        u = self.job(beam, self.path("beam_u.stl"), *BEAM, "--set", "refine=uniform",
                     "--set", "volume_fraction=0.6")["rhombic"]
        vf = u["volume_fraction"]
        self.assertGreaterEqual(vf, 0.6)
        self.assertLess(vf, 0.65)
        a = self.job(beam, self.path("beam_a.stl"), *BEAM, "--set", "split_pct=5",
                     "--set", f"volume_fraction={vf!r}", "--set", "bound=true")["rhombic"]
        ratio = u["compliance_normalized"] / a["compliance_normalized"]
        print(f"beam: initial {u['volume_fraction_initial']:.3f}; uniform {vf:.4f} "
              f"C/C_solid {u['compliance_normalized']:.3f} max |u| "
              f"{u['max_displacement_mm']:.4f} mm; adaptive {a['volume_fraction']:.4f} "
              f"C/C_solid {a['compliance_normalized']:.3f} max |u| "
              f"{a['max_displacement_mm']:.4f} mm in {a['iterations']} iterations "
              f"({a['fea_solve_s']:.1f} s of solves); ratio {ratio:.3f}; no refinement "
              f"of the initial structure with this material below "
              f"{a['compliance_bound_normalized']:.3f} (ratio at most "
              f"{u['compliance_normalized'] / a['compliance_bound_normalized']:.3f}; "
              f"{a['bound_iterations']} solves, gap {a['bound_gap']:.4f})")
        self.assertLessEqual(a["volume_fraction"], vf + 1e-9)
        self.assertGreater(a["volume_fraction"], vf - 0.01)
        self.assertEqual(a["volume_fraction_initial"], u["volume_fraction_initial"])
        self.assertGreater(a["iterations"], 3)
        self.assertGreaterEqual(ratio, 1.2)
        self.assertLess(a["max_displacement_mm"], 0.8 * u["max_displacement_mm"])
        # the bound (fea_relax_bound) holds for the design found; converged
        # to its 0.2 % gap
        self.assertLessEqual(a["compliance_bound_normalized"], a["compliance_normalized"])
        self.assertGreater(a["compliance_bound_normalized"], 1.0)
        self.assertLessEqual(a["bound_gap"], 0.002)
        self.assertNotIn("compliance_bound_normalized", u)
        # the compliance falls with every refinement (the history's last
        # entry is the solid part's solve)
        hist = [tuple(map(float, h.split())) for h in a["history"]]
        self.assertEqual(len(hist), a["fea_solves"])
        self.assertEqual(hist[-1][0], 1.0)
        for (f0, c0, _), (f1, c1, _) in zip(hist[:-2], hist[1:-1]):
            self.assertGreater(f1, f0)
            self.assertLess(c1, c0)
        self.assertAlmostEqual(hist[-1][1], a["compliance_solid_nmm"],
                               delta=1e-5 * a["compliance_solid_nmm"])

    def test_bad_parameters(self):
        src = os.path.join(MESHES, "femur.off")
        cases = [
            (["--set", "alpha_deg=0"], "alpha_deg"),
            (["--set", "alpha_deg=90"], "alpha_deg"),
            (["--set", "skin_mm=0.5", "--set", "wall_mm=1"], "skin_mm"),
            (["--set", "orient_deg=-0.5"], "orient_deg"),
            (["--set", "orient_deg=180"], "orient_deg"),
            (["--set", "volume_fraction=0"], "volume_fraction"),
            (["--set", "objective=stiff"], "objective"),
            (["--set", "wall_mm=20", "--set", "skin_mm=20"], "wall_mm"),
            (["--set", "loads=fixed plate; force box=0,0,60,5,5,61 n=0,0,-10",
              "--set", "fea_voxel_mm=2"], "loads"),
            (["--set", "loads=fixed plate; force nowhere"], "loads"),
            (["--set", "bound=true", "--set", "refine=uniform"], "bound"),
            (["--set", "bound=true", "--set", "objective=stability"], "bound"),
        ]
        for extra, field in cases:
            with self.subTest(extra=extra):
                p = run("run", src, "-o", self.path("bad.sl1"), "--quiet", "--engine",
                        "rhombic", "--set", "height_mm=50", *extra, check=False)
                self.assertNotEqual(p.returncode, 0)
                lines = p.stderr.strip().splitlines()
                self.assertEqual(len(lines), 1, p.stderr)
                self.assertIn(field, lines[0])


if __name__ == "__main__":
    unittest.main()
