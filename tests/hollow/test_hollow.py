"""test_hollow.py - the `hollow` engine end to end (issue 5's acceptance).

Drives the real binary (env INFILLD_BIN) and reads its metrics; the
interior-overhang figure comes from engine/verify, which checks the very
layer images written (independent of the optimiser).  Kept small for
`make test`: 8 and 12 mm cubes, the letter P at 50 mm and a too-thin
tetrahedron; the 50 mm models and the letter at 100 mm (which reaches the
offset hull: asserted there) run in `make bench` (tests/bench/hollow.sh).
Standalone: python3 tests/hollow/test_hollow.py
"""
import json
import os
import struct
import subprocess
import tempfile
import sys
import unittest
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
from hollowcheck import optimised_slopes_ok  # noqa: E402
from meshgen import write_ball_stl, write_box_stl  # noqa: E402


def hollow(tmp, mesh, fmt="sl1", threads=2, **sets):
    out = os.path.join(tmp, "out." + fmt)
    met = os.path.join(tmp, "m.json")
    args = [BIN, "run", os.path.join(MESHES, mesh), "-o", out, "--engine", "hollow",
            "--format", fmt, "--threads", str(threads), "--quiet", "--metrics", met]
    for k, v in sets.items():
        args += ["--set", f"{k}={v}"]
    p = subprocess.run(args, capture_output=True, text=True, timeout=900)
    if p.returncode != 0:
        raise AssertionError(f"{' '.join(args)}: {p.stderr}")
    with open(met) as f:
        m = json.load(f)
    if fmt in ("sl1", "sl1s", "zip"):
        # the archive read back by `infilld verify`, apart from the engine:
        # the same interior overhang and islands as the engine's own check
        a = str(sets.get("alpha_deg", 45))
        p = subprocess.run([BIN, "verify", out, "--alpha-deg", a], capture_output=True,
                           text=True, timeout=900)
        if p.returncode != 0:
            raise AssertionError(f"infilld verify {out}: {p.stderr}")
        rep = json.loads(p.stdout)
        own = m["hollow"]["verify"]
        for k in ("interior_overhang_px", "islands", "islands_interior"):
            if rep[k] != own[k]:
                raise AssertionError(f"{mesh}: {k} {rep[k]} read back, {own[k]} by the engine")
        m["reread"] = rep
    return m


def stl_volume_mm3(path):
    """Signed volume of a binary STL (divergence theorem over its
    triangles), read here, independently of the engine."""
    with open(path, "rb") as f:
        d = f.read()
    n = struct.unpack_from("<I", d, 80)[0]
    vol = 0.0
    for i in range(n):
        v = struct.unpack_from("<9f", d, 84 + 50 * i + 12)
        a, b, c = v[0:3], v[3:6], v[6:9]
        vol += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                a[2] * (b[0] * c[1] - b[1] * c[0])) / 6
    return vol


def between_walls_ok(t, v):
    """Walls between two voids (verify min_wall_between_mm: in the layer and
    along columns; null when no layer holds two voids) >= wall_next_mm 0.8
    less one pixel or layer of rasterisation."""
    for k in ("min_wall_between_mm", "min_wall_between_vertical_mm"):
        if v[k] is not None:
            t.assertGreaterEqual(v[k], 0.8 - 0.06, (k, v))


class HollowTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()

    def tearDown(self):
        self.tmp.cleanup()

    def test_cube_support_free_at_45_and_30(self):
        # an 8 mm cube: the optimiser's cost is not monotone in size (12 mm
        # at alpha 30 took 72 s, 8 mm 4 s) and these checks need no more
        res = {}
        # the images read 2 and 13 px over before the mending, which adds
        # 0.015 and 0.109 mm3 of gray (measured)
        for a in (45, 30):
            # optimise_s=0: no wall-clock guard, so what is checked does not
            # depend on the machine's speed (under ASan on shared cores the
            # round once outran a 60 s budget); the work budget is
            # deterministic
            # fill=false: the optimiser's voids alone (with the fill, the
            # fill alone hollows this cube more and is kept: test below)
            m = hollow(self.tmp.name, "misc/cube.ascii.stl", height_mm=8, alpha_deg=a,
                       rounds=1, optimise_s=0, fill="false")
            h = m["hollow"]
            res[a] = h
            self.assertGreaterEqual(h["voids_optimised"], 1)
            self.assertEqual(h["voids_fill"], 0)
            self.assertFalse(h["budget_spent"])
            optimised_slopes_ok(self, h)
            self.assertGreater(h["mended"]["pixels"], 0, h["mended"])
            self.assertEqual(h["verify"]["islands"], 0)
            # walls never thinner than allowed (1 pixel of rasterisation)
            self.assertGreaterEqual(h["min_wall_3d_mm"], 0.8 - 0.06)
            self.assertGreaterEqual(h["verify"]["min_wall_vertical_mm"], 1.0 - 0.06)
            between_walls_ok(self, h["verify"])
            # groin vaults: 0.25 at alpha 45, 0.16 at 30 measured
            self.assertGreater(h["volume_reduction"], 0.12)
            self.assertLess(h["volume_reduction"], 1.0)
        # a smaller alpha never hollows more
        self.assertLessEqual(res[30]["volume_reduction"], res[45]["volume_reduction"] + 1e-9)

    def test_default_keeps_the_larger_hollowing(self):
        # lightweight, optimiser then fill: the fill keeps wall_next_mm from
        # the optimised voids; when the fill alone hollows more (this cube:
        # 884 against 761 mm3 at alpha 45) it is kept and the optimised
        # voids are dropped, reported
        m = hollow(self.tmp.name, "misc/cube.ascii.stl", height_mm=12, rounds=1,
                   optimise_s=0)
        h = m["hollow"]
        both, alone = h["optimised_and_fill_volume_mm3"], h["fill_alone_volume_mm3"]
        self.assertGreater(h["optimised_volume_mm3"], 0)
        self.assertGreater(both, h["optimised_volume_mm3"])
        self.assertAlmostEqual(h["void_volume_mm3"], max(both, alone), delta=1e-6 * both)
        # on this cube the fill alone wins: the choice is checked, never skipped
        self.assertGreater(alone, both, h)
        self.assertEqual(h["voids_optimised"], 0)
        self.assertGreaterEqual(h["voids_dropped_for_fill"], 1)
        self.assertEqual(h["rounds"], 0)  # no optimised round is in the output
        self.assertAlmostEqual(h["volume_reduction"], alone / h["part_volume_mm3"],
                               delta=1e-9)
        self.assertEqual(h["interior_overhang_mm2"], 0.0, h["verify"])
        # with 2 threads the fill alone runs on a helper thread beside the
        # fill around the optimised voids; on one thread they run in turn:
        # the same two candidates, the same choice
        m1 = hollow(self.tmp.name, "misc/cube.ascii.stl", threads=1, height_mm=12, rounds=1,
                    optimise_s=0)
        h1 = m1["hollow"]
        for k in ("fill_alone_volume_mm3", "optimised_and_fill_volume_mm3", "void_volume_mm3",
                  "voids", "voids_dropped_for_fill"):
            self.assertEqual(h1[k], h[k], k)

    def test_cube_fill_alone_at_45_and_30(self):
        # the top-down fill alone (rounds=0): support-free on the very
        # pixels written (the exact rule, no slack), no islands, walls to
        # the outside >= wall_mm less one pixel
        m = hollow(self.tmp.name, "misc/cube.ascii.stl", height_mm=12, alpha_deg=45,
                   rounds=0, fill="true")
        h = m["hollow"]
        self.assertGreaterEqual(h["voids_fill"], 1)
        self.assertEqual(h["voids_optimised"], 0)
        self.assertTrue(h["fill_applied"])
        self.assertNotIn("note", h)
        self.assertEqual(h["interior_overhang_mm2"], 0.0, h["verify"])
        self.assertEqual(h["verify"]["slope_excess_px"], 0.0, h["verify"])
        self.assertEqual(h["verify"]["islands"], 0)
        self.assertGreaterEqual(h["verify"]["min_wall_mm"], 1.0 - 0.06)
        self.assertGreaterEqual(h["verify"]["min_wall_vertical_mm"], 1.0 - 0.06)
        between_walls_ok(self, h["verify"])
        # every fill void is enclosed: the checker finds all of it
        self.assertAlmostEqual(h["verify"]["enclosed_void_mm3"], h["fill_volume_mm3"],
                               delta=1e-6 * h["fill_volume_mm3"])
        self.assertGreater(h["volume_reduction"], 0.3)
        # alpha 30 at 0.05 mm layers allows 0.029 mm a layer, under the
        # 0.047 mm pixel: a whole pixel over a void always overhangs, so
        # the pixel fill alone can close no roof, and says why
        m = hollow(self.tmp.name, "misc/cube.ascii.stl", height_mm=12, alpha_deg=30,
                   rounds=0, fill="true")
        h30 = m["hollow"]
        self.assertEqual(h30["voids"], 0)
        self.assertEqual(h30["volume_reduction"], 0.0)
        self.assertIn("less than the 0.047 mm pixel", h30["note"])

    def test_too_thin_returns_part_with_note(self):
        m = hollow(self.tmp.name, "misc/tetrahedron.ascii.stl", fmt="stl", height_mm=3)
        h = m["hollow"]
        self.assertEqual(h["voids"], 0)
        self.assertIn("too thin", h["note"])
        self.assertAlmostEqual(h["volume_reduction"], 0.0)
        self.assertAlmostEqual(m["material_volume_mm3"], m["part_volume_mm3"], delta=1e-6)

    def test_optimiser_alone_says_why_it_kept_nothing(self):
        # a bulky part the optimiser alone cannot hollow (its chains end
        # at their top pairs: docs/hollow.md, known limits) is not called
        # too thin: the note says the optimiser kept no void, how many
        # loops it had, and that the fill hollows it, as it does
        m = hollow(self.tmp.name, "cow.off", fmt="stl", height_mm=20, up="y", fill="false")
        h = m["hollow"]
        self.assertEqual(h["voids"], 0)
        self.assertNotIn("too thin", h["note"])
        self.assertRegex(h["note"], r"^the optimiser kept no void: [1-9][0-9]* loops inside the wall")
        self.assertIn("fill=true hollows the interior", h["note"])
        # every dropped or unmade group is accounted for, the unmade ones
        # (runs of loops no support-free strip joins) by name and count
        self.assertGreater(h["groups_small"] + h["groups_failed"] + h["voids_too_close"] +
                           h["groups_unbuilt"], 0, h)
        self.assertIn("%d runs of loops no support-free strip could join" % h["groups_unbuilt"],
                      h["note"])
        m = hollow(self.tmp.name, "cow.off", fmt="stl", height_mm=20, up="y", rounds=0)
        self.assertGreater(m["hollow"]["volume_reduction"], 0.25)
        self.assertNotIn("note", m["hollow"])

    def test_adaptive_slices_and_contour_smoothing(self):
        # the paper's step 2 with adaptive thickness (opt_layer_min_mm) and
        # section 6's smoothing P -> P~ (smooth_passes), optimiser alone
        ball = os.path.join(self.tmp.name, "ball.stl")
        write_ball_stl(ball, 10.0)
        opt = dict(fill="false", rounds=1, optimise_s=0)
        uni = hollow(self.tmp.name, ball, **opt)["hollow"]
        ada = hollow(self.tmp.name, ball, opt_layer_min_mm=0.25, opt_layer_mm=1.0, **opt)["hollow"]
        # uniform: every slab 0.5 mm; adaptive: thick round the equator,
        # thinner towards the poles, where the sections shrink fastest
        self.assertEqual(uni["opt_layer_min_used_mm"], 0.5)
        self.assertEqual(ada["opt_layer_mm"], 1.0)
        self.assertLess(ada["slices"], uni["slices"])
        self.assertGreater(ada["slices"], 20 / 1.0)
        self.assertLess(ada["opt_layer_min_used_mm"], 1.0)
        # a box is straight in z: every slab the thickest (the last one may
        # be cut by the top)
        box = os.path.join(self.tmp.name, "box.stl")
        write_box_stl(box, 12, 12, 12)
        bx = hollow(self.tmp.name, box, opt_layer_min_mm=0.25, opt_layer_mm=1.0, **opt)["hollow"]
        self.assertLessEqual(bx["slices"], 13)
        self.assertGreaterEqual(bx["voids_optimised"], 1)
        optimised_slopes_ok(self, bx)
        # smoothing: a 12 mm ball, whose top pairs fail unsmoothed (no void),
        # keeps a void from 10 passes; corners are only cut inward, so walls
        # keep their thickness and the polygons the exact rule
        small = os.path.join(self.tmp.name, "ball12.stl")
        write_ball_stl(small, 6.0)
        h0 = hollow(self.tmp.name, small, **opt)["hollow"]
        h10 = hollow(self.tmp.name, small, smooth_passes=10, **opt)["hollow"]
        self.assertEqual(h0["voids"], 0)
        self.assertGreaterEqual(h10["voids_optimised"], 1)
        self.assertGreater(h10["volume_reduction"], 0.01)
        self.assertEqual(h10["polygon_slopes"]["excess_mm2"], 0.0)
        self.assertGreaterEqual(h10["min_wall_3d_mm"], 1.0 - 0.06)
        # its rasterised collapsed top draws a one-pixel speck of solid
        # (gray 171) over the void's gray in layer 106, an island of
        # 0.002 mm2 for the verifier's threshold: the mending holds it up
        # (docs/hollow.md 3.8), so no island is left; the 13 px the
        # images read over before the mending read none
        self.assertEqual(h10["verify"]["islands_part"], 0)
        self.assertEqual(h10["verify"]["islands_interior"], 0, h10["verify"])
        self.assertEqual(h10["verify"]["islands_added"], 0, h10["verify"])
        optimised_slopes_ok(self, h10)

    def test_mesh_output_is_what_its_metrics_say(self):
        # an STL carries every void the layers carve (the optimised ones
        # and the fill, as pixels: tests/hollow/test_hollow_mesh.py): the
        # figures describe that mesh
        out = os.path.join(self.tmp.name, "out.stl")
        m = hollow(self.tmp.name, "misc/cube.ascii.stl", fmt="stl", height_mm=12, rounds=1)
        h = m["hollow"]
        self.assertTrue(h["fill_applied"])
        self.assertGreaterEqual(h["voids"], 1)
        self.assertEqual(h["interior_overhang_mm2"], 0.0, h["verify"])
        self.assertTrue(m["result_mesh"]["watertight"])
        vol = stl_volume_mm3(out)
        self.assertAlmostEqual(vol, m["part_volume_mm3"] - h["void_volume_mm3"],
                               delta=1e-2 * m["part_volume_mm3"])
        self.assertAlmostEqual(h["volume_reduction"], 1 - vol / m["part_volume_mm3"], delta=1e-2)
        self.assertAlmostEqual(m["material_volume_mm3"], vol, delta=1e-4 * vol)

    def test_gcode_output_carries_the_hollowing(self):
        # G-code: the fill is designed and checked on the engine's own
        # 0.05 mm grid, and the toolpaths leave the voids out: the filament
        # deposited (E) against the solid part's at 100 % infill follows
        # the reduction (perimeters round the voids and bead overlap: 0.1)
        m = hollow(self.tmp.name, "misc/cube.ascii.stl", fmt="gcode", height_mm=12)
        h = m["hollow"]
        self.assertTrue(h["fill_applied"])
        self.assertGreaterEqual(h["voids"], 1)
        self.assertEqual(h["interior_overhang_mm2"], 0.0, h["verify"])
        self.assertGreater(h["volume_reduction"], 0.3)
        out = os.path.join(self.tmp.name, "solid.gcode")
        met = os.path.join(self.tmp.name, "solid.json")
        subprocess.run([BIN, "run", os.path.join(MESHES, "misc/cube.ascii.stl"), "-o", out,
                        "--set", "height_mm=12", "--set", "infill_pct=100", "--quiet",
                        "--metrics", met], check=True, timeout=300)
        with open(met) as f:
            dense = json.load(f)["material_volume_mm3"]
        self.assertAlmostEqual(m["material_volume_mm3"] / dense, 1 - h["volume_reduction"],
                               delta=0.1)

    def test_gcode_fill_prints_what_it_checks(self):
        # On the 0.05 mm grid under 0.2 mm FDM layers the slope is 3.9 px a
        # layer; carried inside distances (sig) once broke diagonal fronts
        # into checkerboards there: a 20 mm ball's design held 47.8 mm3 of
        # slivers (1.9 % of its void) that the G-code's thin-wall planning
        # dropped (402 mm2 over the layers against the plain ball's 21), so
        # what was printed was not what was checked.  Fill alone, G-code:
        # support-free, no interior island, slivers under 0.1 % of the
        # void, and the planner drops little more than for the plain ball.
        ball = os.path.join(self.tmp.name, "ball20.stl")
        write_ball_stl(ball, 10.0)
        m = hollow(self.tmp.name, ball, fmt="gcode", rounds=0, up="z")
        h, v = m["hollow"], m["hollow"]["verify"]
        self.assertTrue(h["fill_applied"])
        self.assertEqual(v["interior_overhang_px"], 0, v)
        self.assertEqual(v["islands_interior"], 0, v)
        self.assertGreater(h["volume_reduction"], 0.5)
        self.assertLess(v["sliver_mm3"], 1e-3 * h["void_volume_mm3"], v)
        self.assertGreaterEqual(v["min_wall_mm"], 0.95, v)
        solid = os.path.join(self.tmp.name, "ball20.json")
        subprocess.run([BIN, "run", ball, "-o", os.path.join(self.tmp.name, "ball20.gcode"),
                        "--quiet", "--metrics", solid], check=True, timeout=300)
        with open(solid) as f:
            plain = json.load(f)["gcode"]["thin_dropped_mm2"]
        self.assertLess(m["gcode"]["thin_dropped_mm2"], plain + 100, m["gcode"])

    def test_check_reads_the_parts_own_air(self):
        # The check reads each layer against the plain part drawn beside
        # it.  Under 0.2 mm layers on the 0.05 mm grid a slanted crevice of
        # the camel (layer 228) is a slit whose pixels lie over no void of
        # the layer below: linked alone it read as a sealed void 0.35 mm
        # from the outside, so a 1 mm wall was reported as 0.35 mm.
        # Against the part it is the part's own air: the wall reads the
        # designed 1 mm less the pixel, and the enclosed void is exactly the
        # fill's.
        m = hollow(self.tmp.name, "camel.off", fmt="gcode", rounds=0, up="y", height_mm=50,
                   wall_mm=1.0, wall_next_mm=0.8)
        h, v = m["hollow"], m["hollow"]["verify"]
        self.assertGreaterEqual(h["min_wall_mm"], 0.95, v)
        self.assertGreaterEqual(v["min_wall_vertical_mm"], 0.95, v)
        self.assertAlmostEqual(v["enclosed_void_mm3"], h["fill_volume_mm3"],
                               delta=1e-6 * h["fill_volume_mm3"])
        self.assertEqual(h["interior_overhang_mm2"], 0.0, v)
        self.assertEqual(v["islands_added"], 0, v)

    def test_optimiser_time_budget(self):
        # a budget spent before any solve: no solver iteration, and no void
        # but support-free starts (the first round may have begun); the
        # fill hollows the rest, still support-free; the flag says so
        m = hollow(self.tmp.name, "misc/cube.ascii.stl", height_mm=12, rounds=8,
                   optimise_s=1e-6)
        h = m["hollow"]
        self.assertTrue(h["budget_spent"])
        self.assertEqual(h["solver_iterations"], 0)
        self.assertLessEqual(h["rounds"], 1)
        self.assertEqual(h["voids_optimised"], h["voids_fallback"])
        self.assertGreaterEqual(h["voids_fill"], 1)
        self.assertEqual(h["interior_overhang_mm2"], 0.0, h["verify"])
        self.assertGreater(h["volume_reduction"], 0.3)

    # The work budget (optimise_work) caps every solve of a round at the same
    # iteration count, the budget left over the round's offsets, so what is
    # solved is the same on one thread or two, under any load; the wall-clock
    # guard is off here (optimise_s=0).  The letter's one round uncapped,
    # then with a third of that work: capped, never over the budget, the
    # same result on 1 and 2 threads (solves finish in another order), and
    # still support-free (a capped solve is checked like any other).
    def test_optimiser_work_budget_is_reproducible(self):
        def run(threads, work):
            d = os.path.join(self.tmp.name, "w%d_%g" % (threads, work))
            os.makedirs(d, exist_ok=True)
            m = hollow(d, "P.off", threads=threads, height_mm=50, up="y", rounds=1,
                       fill="false", optimise_s=0, optimise_work=work)
            with zipfile.ZipFile(os.path.join(d, "out.sl1")) as z:
                layers = [z.read(n) for n in sorted(z.namelist()) if n.endswith(".png")]
            return m["hollow"], layers
        free, _ = run(2, 0)
        self.assertFalse(free["work_spent"])
        self.assertGreater(free["solver_work"], 0)
        budget = round(free["solver_work"] / 3, 3)
        a, la = run(1, budget)
        b, lb = run(2, budget)
        for h in (a, b):
            self.assertTrue(h["work_spent"], h)
            self.assertLessEqual(h["solver_work"], budget)
            # solved up to the cap, not skipped (a cap under 20 iterations
            # would solve nothing, and the layers would agree trivially)
            self.assertGreater(h["solver_work"], budget / 2)
            self.assertGreater(h["solver_iterations"], 0)
            self.assertLess(h["solver_iterations"], free["solver_iterations"])
            # support-free on the polygons the layers are drawn from and
            # on the layers (the capped optima fail their check and the
            # voids keep their start, which the pixel model read at up to
            # 0.75 px before the mending, docs/hollow.md known limit 2)
            optimised_slopes_ok(self, h)
            self.assertEqual(h["verify"]["islands"], 0)
        for k in ("solver_work", "solver_iterations", "voids", "voids_fallback",
                  "optimised_volume_mm3", "volume_reduction"):
            self.assertEqual(a[k], b[k], k)
        self.assertEqual(la, lb, "the same layers on 1 and 2 threads")

    # P stood upright (up=y) on its stem at the 50 mm.  The solid
    # letter tips over (centre of mass 1.67 mm beyond the stem).  Stability
    # keeps only optimised voids that move the centre of mass towards the
    # contact hull and fills only behind it, so the letter stands.  It does
    # not reach the offset hull H_r (r = 2.5 mm): no hollowing with 1 mm
    # walls can, as docs/hollow.md shows from the uniform 1 mm hollowing.
    # No wall-clock guard (optimise_s=0): with one, how far the solve gets
    # depends on the machine's load, and a solve cut short left a corner
    # reading 0.2001 px against the 0.2 px tolerance on a loaded CI run.
    # The work budget (default) does not cut it (asserted: work_spent).
    def test_P_stands_after_stability(self):
        m = hollow(self.tmp.name, "P.off", height_mm=50, up="y", objective="stability",
                   rounds=1, opt_layer_mm=1.0, optimise_s=0)
        h = m["hollow"]
        self.assertFalse(h["work_spent"], h["solver_work"])
        self.assertFalse(h["stands_before"])
        self.assertLess(h["com_before_mm"], 0)
        # stands: the projected centre of mass is inside the contact hull
        # (0.47 mm in with the exact slope rule)
        self.assertGreater(h["com_after_mm"], 0.25, h)
        # short of the offset hull H_r (see above), and reported so
        self.assertFalse(h["com_inside_hull"], h)
        self.assertLess(h["com_after_mm"], h["hull_offset_mm"] + 1e-6, h)
        self.assertGreaterEqual(h["voids"], 1)
        self.assertEqual(h["interior_overhang_mm2"], 0.0, h["verify"])
        self.assertEqual(h["verify"]["islands"], 0)
        self.assertGreaterEqual(h["min_wall_mm"], 1.0 - 0.06)
        self.assertGreaterEqual(h["verify"]["min_wall_vertical_mm"], 0.8 - 0.06)
        between_walls_ok(self, h["verify"])
        # the lightweight objective hollows the stem too (more volume):
        # stability's fill is selective
        lw = hollow(self.tmp.name, "P.off", height_mm=50, up="y", rounds=0)["hollow"]
        self.assertGreater(lw["volume_reduction"], h["volume_reduction"] + 0.1)

    # The optimiser alone on the letter (lightweight, no fill): all 5
    # groups failed before strips were rebuilt with the support-free start
    # (docs/hollow.md, known issue 1); now none does and voids are kept,
    # support-free on the layers
    def test_P_optimiser_keeps_its_groups(self):
        m = hollow(self.tmp.name, "P.off", height_mm=50, up="y", rounds=1, fill="false",
                   optimise_s=0)
        h = m["hollow"]
        self.assertEqual(h["groups_failed"], 0, h)
        self.assertGreaterEqual(h["voids_optimised"], 2, h)  # 3 measured, 18.4 %
        self.assertGreater(h["volume_reduction"], 0.1)
        optimised_slopes_ok(self, h)  # 1.71 mm3 mended (33,068 px)
        self.assertEqual(h["verify"]["islands"], 0)
        self.assertGreaterEqual(h["min_wall_mm"], 1.0 - 0.06)
        between_walls_ok(self, h["verify"])


if __name__ == "__main__":
    unittest.main()
