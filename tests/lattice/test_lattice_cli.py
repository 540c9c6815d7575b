"""test_lattice_cli.py - `infilld run ... --engine lattice` end to end.

Lattice files (text and binary, written here from the format spec in
docs/lattice.md, not with infilld's writer) are printed to SL1 and the
layer images are checked against geometry computed independently: between
two node layers of a grid lattice only the vertical struts cross the plane,
each a disc of exactly the strut's radius.  A mesh is filled with a
generated lattice and its self-support metrics must fall SO -> SO+PO.
Run by tests/run.sh; standalone: python3 tests/lattice/test_lattice_cli.py
"""
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import unittest
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
import gcodecheck  # noqa: E402
import sl1check  # noqa: E402

BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")

N, SPACING, RADIUS, SUPPORT = 4, 3.0, 0.4, 0.6  # grid lattice: 4^3 nodes, 3 mm apart


def run(*args):
    return subprocess.run([BIN, *args], capture_output=True, text=True, timeout=600)


def grid_lattice():
    nodes = [(i * SPACING, j * SPACING, k * SPACING)
             for k in range(N) for j in range(N) for i in range(N)]
    idx = lambda i, j, k: (k * N + j) * N + i  # noqa: E731
    edges = []
    for k in range(N):
        for j in range(N):
            for i in range(N):
                for di, dj, dk in ((1, 0, 0), (0, 1, 0), (0, 0, 1)):
                    if i + di < N and j + dj < N and k + dk < N:
                        edges.append((idx(i, j, k), idx(i + di, j + dj, k + dk)))
    return nodes, edges


def write_text(path, nodes, edges):
    with open(path, "w") as f:
        f.write("infilld-lattice 1\n# a 4x4x4 grid\nsupport_mm %g\nnodes %d\n" % (SUPPORT, len(nodes)))
        for p in nodes:
            f.write("%r %r %r\n" % p)
        f.write("edges %d\n" % len(edges))
        for a, b in reversed(edges):  # any order
            f.write("%d %d %r\n" % (b, a, RADIUS))


def write_binary(path, nodes, edges):
    # nodes sorted by z (they already are), edges by lower node, a < b
    quantum = RADIUS / 65535
    es = sorted((min(a, b), max(a, b)) for a, b in edges)
    lo = [min(p[i] for p in nodes) for i in range(3)]
    hi = [max(p[i] for p in nodes) for i in range(3)]
    head = b"INFILLDL" + struct.pack("<IIQQddd", 1, 128, len(nodes), len(es), SUPPORT,
                                     quantum, RADIUS)
    head += struct.pack("<6d", *lo, *hi) + struct.pack("<III", 0, 12, 10)
    head += b"\0" * (128 - len(head))
    with open(path, "wb") as f:
        f.write(head)
        for p in nodes:
            f.write(struct.pack("<3f", *p))
        for a, b in es:
            f.write(struct.pack("<IIH", a, b, 65535))


class LatticeCliTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = cls.tmp.name
        cls.nodes, cls.edges = grid_lattice()

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def path(self, name):
        return os.path.join(self.dir, name)

    def print_lattice(self, src, name, *extra):
        out, met = self.path(name + ".sl1"), self.path(name + ".json")
        p = run("run", src, "-o", out, "--engine", "lattice", "--metrics", met, "--quiet", *extra)
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(met) as f:
            return out, json.load(f)

    def layer_image(self, sl1, k):
        with zipfile.ZipFile(sl1) as z:
            names = sorted(n for n in z.namelist() if n.endswith(".png") and "/" not in n)
            return sl1check.png_decode(z.read(names[k])), len(names)

    def check_grid_print(self, src, name):
        sl1, m = self.print_lattice(src, name)
        self.assertEqual(m["lattice"]["struts"], len(self.edges))
        self.assertEqual(m["lattice"]["nodes"], len(self.nodes))
        self.assertAlmostEqual(m["lattice"]["support_mm"], SUPPORT, places=6)
        # placed like a mesh: the solid's bottom (lowest node - radius) on the
        # plate; the schedule reaches the top node + R (the support bounds the
        # solid), the archive ends with the last lit layer: the top node's
        # solid, below the support (empty layers above it are not written)
        top = (N - 1) * SPACING + RADIUS
        self.assertEqual(m["layers_scheduled"], math.ceil((top + SUPPORT) / 0.05 - 1e-9))
        written = m["sl1"]["layers"]
        self.assertEqual(m["layers"], written)
        self.assertLess(written, m["layers_scheduled"])
        self.assertGreaterEqual(written, math.ceil(top / 0.05 - 1e-9))
        sl1check.check_archive(sl1, expect_layers=written)
        # z = 1.475 mm (layer 29): nodes at z = 0.4, 3.4, ...: farther than R
        # from every node layer, so
        # the plane cuts only the 16 vertical struts, far from their ends:
        # 16 discs of radius RADIUS exactly (weight <-> radius map)
        img, count = self.layer_image(sl1, 29)
        self.assertEqual(count, written)
        px_mm2 = 0.04725 ** 2
        area = img.pixel_sum() / 255.0 * px_mm2
        expect = N * N * math.pi * RADIUS ** 2
        self.assertAlmostEqual(area / expect, 1.0, delta=0.01)
        # near a node layer (z = 3.425, layer 68) the horizontal struts add
        img2, _ = self.layer_image(sl1, 68)
        self.assertGreater(img2.pixel_sum(), 5 * img.pixel_sum())
        return m

    def test_text_lattice_to_sl1(self):
        src = self.path("grid.lat")
        write_text(src, self.nodes, self.edges)
        m = self.check_grid_print(src, "text")
        self.assertEqual(m["lattice"]["sort_runs"], 0)

    def test_binary_lattice_streamed(self):
        src = self.path("grid.bin")
        write_binary(src, self.nodes, self.edges)
        m = self.check_grid_print(src, "binary")
        self.assertIn("stream_window_nodes", m["lattice"])
        self.assertLess(m["lattice"]["stream_window_nodes"], len(self.nodes))

    def test_pillars_to_gcode_inside_their_discs(self):
        # 16 vertical struts 3 mm apart (no blending: R = 0.6 mm): every FDM
        # layer's material is 16 discs of the strut radius; the independent
        # G-code checker verifies every extrusion lies inside them
        src, out, met = self.path("pillars.lat"), self.path("pillars.gcode"), self.path("p.json")
        r = 0.5
        with open(src, "w") as f:
            f.write("infilld-lattice 1\nsupport_mm 0.75\nnodes 32\n")
            for z in (0, 8):
                for j in range(4):
                    for i in range(4):
                        f.write("%d %d %d\n" % (3 * i, 3 * j, z))
            f.write("edges 16\n")
            for k in range(16):
                f.write("%d %d %r\n" % (k, k + 16, r))
        p = run("run", src, "-o", out, "--engine", "lattice", "--format", "gcode",
                "--metrics", met, "--quiet")
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(met) as f:
            m = json.load(f)
        bb = m["bbox_mm"]
        cx = 0.5 * (bb["min"]["x"] + bb["max"]["x"]) - 4.5
        cy = 0.5 * (bb["min"]["y"] + bb["max"]["y"]) - 4.5
        shapes = [{"kind": "circle", "cx": cx + 3 * i, "cy": cy + 3 * j, "r": r + 0.005,
                   "op": "add"} for j in range(4) for i in range(4)]
        rep = gcodecheck.check_file(out, regions={"layers": [{"from": 0, "to": -1,
                                                              "shapes": shapes}]})
        self.assertEqual(rep["containment_violations"], 0)
        self.assertEqual(rep["layers"], m["gcode"]["layers"])
        self.assertLessEqual(m["gcode"]["layers"], m["layers"])
        self.assertGreater(rep["extruded_volume_mm3"], 0)

    def test_bad_lattice_file(self):
        src = self.path("bad.lat")
        with open(src, "w") as f:
            f.write("infilld-lattice 1\nnodes 2\n0 0 0\n1 1 1\nedges 1\n0 7 0.5\n")
        p = run("run", src, "-o", self.path("bad.sl1"), "--engine", "lattice")
        self.assertEqual(p.returncode, 1)
        self.assertIn("line 6", p.stderr)
        self.assertIn("edge 0", p.stderr)
        # a radius not below the support is refused, not sliced into garbage
        with open(src, "w") as f:
            f.write("infilld-lattice 1\nsupport_mm 0.5\nnodes 2\n0 0 0\n0 0 5\nedges 1\n0 1 0.6\n")
        p = run("run", src, "-o", self.path("bad.sl1"), "--engine", "lattice")
        self.assertEqual(p.returncode, 1)
        self.assertIn("support", p.stderr)

    def test_mesh_generates_self_supporting_lattice(self):
        out, met = self.path("camel.sl1"), self.path("camel.json")
        p = run("run", os.path.join(MESHES, "camel.off"), "-o", out, "--engine", "lattice",
                "--set", "height_mm=45", "--set", "up=y", "--set", "layer_mm=0.1",
                "--metrics", met, "--quiet")
        self.assertEqual(p.returncode, 0, p.stderr)
        with open(met) as f:
            m = json.load(f)
        lat = m["lattice"]
        self.assertTrue(lat["generated"])
        self.assertGreater(lat["struts"], 100)
        self.assertLess(lat["gamma_so"], lat["gamma_raw"])
        self.assertLessEqual(lat["gamma_so_po"], lat["gamma_so"])
        self.assertGreater(lat["psi_so_po"], lat["psi_raw"])
        self.assertLess(lat["density_error_mean"], 0.05)
        self.assertGreater(m["material_volume_mm3"], 0)
        self.assertLess(m["material_volume_mm3"], m["mesh"]["volume_mm3"])
        sl1check.check_archive(out, expect_layers=m["sl1"]["layers"])
        self.assertLessEqual(m["sl1"]["layers"], m["layers"])

    def test_skinned_lattice_prints_the_part_to_its_top(self):
        # The camel's skeleton ends below its head (46.8 of 50 mm at 50 mm);
        # with the default skin the print is the part's box: the G-code's last
        # printed Z and its layer count equal the solid part's, measured in
        # the G-code text here, not from the engine's metrics.
        def last_z_and_count(engine):
            with tempfile.TemporaryDirectory() as tmp:
                out = os.path.join(tmp, "c.gcode")
                p = run("run", os.path.join(MESHES, "camel.off"), "-o", out, "--engine", engine,
                        "--set", "height_mm=50", "--set", "up=y", "--quiet")
                self.assertEqual(p.returncode, 0, p.stderr)
                text = open(out).read()
            zs = [float(l[3:]) for l in text.splitlines() if l.startswith(";Z:")]
            count = int(text.split(";LAYER_COUNT:", 1)[1].split()[0])
            return max(zs), count, len(zs)
        sz, scount, sn = last_z_and_count("solid")
        lz, lcount, ln = last_z_and_count("lattice")
        self.assertAlmostEqual(sz, 50.0, delta=0.2 + 1e-9)
        self.assertAlmostEqual(lz, sz, delta=0.2 + 1e-9)  # within one 0.2 mm layer
        self.assertEqual(lcount, ln)
        self.assertEqual(scount, sn)


if __name__ == "__main__":
    unittest.main()
