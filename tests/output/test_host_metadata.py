"""test_host_metadata.py - what print hosts read from our files, read by the
hosts' own code, and declared layer counts against the layers that carry
material.

Moonraker: its metadata extractor (../shared/thirdparty/moonraker_metadata.py,
unmodified) runs as a subprocess on G-code of the solid, lattice and hollow
engines; every field its PrusaSlicer parser reads must be present and agree
with the file itself and the printer profile (object_height = the top of the
highest layer that extrudes, within one layer of the part's top;
temperatures = the profile's).  The extractor needs Pillow: the interpreter
running the tests, or the system's /usr/bin/python3 (python3-pil).

Layer counts: G-code `;LAYER_COUNT:` / `; total layers count` and SL1
`numSlow + numFast` must equal the layers with material (a layer extrudes, a
PNG has a lit pixel), for every engine and solid with shell_mm.  Stdlib only;
env INFILLD_BIN, INFILLD_SHARED as tests/cli/test_cli.py.
"""
import json
import os
import re
import subprocess
import sys
import tempfile
import unittest
import zipfile
import zlib
import struct

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")
CUBE = os.path.join(MESHES, "misc", "cube.bin.stl")
EXTRACTOR = os.path.join(SHARED, "thirdparty", "moonraker_metadata.py")
H = 0.2  # generic-fdm layer height

# (name, mesh, height mm, keys, whether the part's top is printed in full)
GCODE_CASES = [
    ("solid", CUBE, 10, ["--engine", "solid", "--set", "nozzle_temp_c=205",
                         "--set", "bed_temp_c=55"], True),
    ("solid_shell", CUBE, 10, ["--engine", "solid", "--set", "shell_mm=1.2"], True),
    # tips thinner than a bead at the top: layers the toolpath leaves empty
    ("solid_camel", os.path.join(MESHES, "camel.off"), 10, ["--engine", "solid"], False),
    # the lattice alone bulges past the part by its strut radius
    ("lattice", CUBE, 12, ["--engine", "lattice"], False),
    ("lattice_skin", CUBE, 12, ["--engine", "lattice", "--set", "shell_mm=1"], True),
    ("hollow", CUBE, 10, ["--engine", "hollow"], True),
]
SL1_CASES = [
    ("solid", CUBE, 10, ["--engine", "solid"]),
    ("solid_shell", CUBE, 10, ["--engine", "solid", "--set", "shell_mm=1"]),
    ("lattice", CUBE, 12, ["--engine", "lattice"]),
    ("hollow", CUBE, 10, ["--engine", "hollow"]),
]


def run(*args):
    p = subprocess.run([BIN, *args], capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        raise AssertionError("infilld %s failed (%d): %s" % (" ".join(args), p.returncode, p.stderr))


def pil_python():
    for py in (sys.executable, "/usr/bin/python3"):
        if py and os.path.exists(py) and subprocess.run(
                [py, "-c", "import PIL"], capture_output=True).returncode == 0:
            return py
    return None


def gcode_layers(path):
    """Declared counts, per-layer Z tags and the layers that extrude."""
    decl = {}
    cur, z, ext, zs, n = None, None, set(), {}, 0
    with open(path) as f:
        for line in f:
            if line.startswith(";LAYER_COUNT:"):
                decl["header"] = int(line[13:])
            elif line.startswith("; total layers count = "):
                decl["footer"] = int(line.split("=")[1])
            elif line.startswith(";LAYER:"):
                cur = int(line[7:])
                n += 1
                zs[cur] = z
            elif line.startswith(";Z:"):
                z = float(line[3:])
            elif cur is not None and line.startswith("G1 ") and re.search(r" E[0-9.]", line) \
                    and re.search(r" [XY]", line):
                ext.add(cur)
    return decl, n, zs, sorted(ext)


def footer_keys(path):
    keys = {}
    with open(path) as f:
        for line in f:
            m = re.match(r"^; ([a-z_ \[\]0-9()]+?) = (.*)$", line)
            if m:
                keys[m.group(1)] = m.group(2)
            m = re.match(r"^;TIME:(\d+)", line)
            if m:
                keys["TIME"] = m.group(1)
    return keys


def png_lit(data):
    """Whether an 8-bit gray PNG (filter 0 rows) has a nonzero pixel."""
    i, idat, w, h = 8, b"", 0, 0
    while i < len(data):
        n, = struct.unpack(">I", data[i:i + 4])
        t = data[i + 4:i + 8]
        if t == b"IHDR":
            w, h = struct.unpack(">II", data[i + 8:i + 16])
        elif t == b"IDAT":
            idat += data[i + 8:i + 8 + n]
        i += 12 + n
    raw = zlib.decompress(idat)
    return any(raw[r * (w + 1) + 1:(r + 1) * (w + 1)].strip(b"\0") for r in range(h))


class HostMetadataTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.gcode = {}
        for name, mesh, height, keys, _ in GCODE_CASES:
            g = os.path.join(cls.tmp.name, name + ".gcode")
            run("run", mesh, "-o", g, "--quiet", "--set", "height_mm=%g" % height, *keys)
            cls.gcode[name] = g

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_layer_count_is_layers_with_material(self):
        for name, _, height, _, _ in GCODE_CASES:
            with self.subTest(case=name):
                decl, n, _, ext = gcode_layers(self.gcode[name])
                self.assertTrue(ext, "nothing extrudes")
                self.assertEqual(ext[-1] + 1, n, "layers after the last that extrudes: %d of %d"
                                 % (n - 1 - ext[-1], n))
                self.assertEqual(ext, list(range(ext[0], n)), "empty layers between")
                self.assertEqual(decl.get("header"), n)
                self.assertEqual(decl.get("footer"), n)

    def test_moonraker_reads_every_field(self):
        py = pil_python()
        if py is None:
            self.skipTest("no python3 with Pillow for Moonraker's extractor")
        for name, _, height, keys, full_top in GCODE_CASES:
            with self.subTest(case=name):
                g = self.gcode[name]
                p = subprocess.run([py, EXTRACTOR, "-f", os.path.basename(g), "-p",
                                    os.path.dirname(g)], capture_output=True, text=True,
                                   timeout=120)
                self.assertEqual(p.returncode, 0, p.stderr)
                md = json.loads(p.stdout)["metadata"]
                decl, n, zs, ext = gcode_layers(g)
                foot = footer_keys(g)
                nozzle_c = 205.0 if "nozzle_temp_c=205" in keys else 215.0
                bed_c = 55.0 if "bed_temp_c=55" in keys else 60.0
                self.assertEqual(md["slicer"], "infilld")
                self.assertEqual(md["layer_count"], n)
                top = zs[ext[-1]]
                self.assertAlmostEqual(md["object_height"], top, places=6)
                if full_top:
                    self.assertLessEqual(abs(md["object_height"] - height), H + 1e-9,
                                         "object_height %s for a %g mm part"
                                         % (md["object_height"], height))
                self.assertAlmostEqual(md["layer_height"], H)
                self.assertAlmostEqual(md["first_layer_height"], H)
                self.assertAlmostEqual(md["nozzle_diameter"], 0.4)
                self.assertEqual(md["first_layer_extr_temp"], nozzle_c)
                self.assertEqual(md["first_layer_bed_temp"], bed_c)
                self.assertEqual(md["filament_temps"], [int(nozzle_c)])
                self.assertEqual(md["chamber_temp"], 0.0)
                self.assertEqual(md["filament_name"], "Generic PLA")
                self.assertEqual(md["filament_type"], "PLA")
                self.assertEqual(md["filament_colors"], ["#FF8040"])
                self.assertEqual(md["extruder_colors"], [])
                self.assertEqual(md["filament_change_count"], 0)
                self.assertEqual(md["mmu_print"], 0)
                self.assertEqual(md["printer_model"], "generic-fdm")
                self.assertEqual(md["printer_variant"], "0.4")
                self.assertAlmostEqual(md["estimated_time"], float(foot["TIME"]), delta=1)
                self.assertGreater(md["estimated_time"], 0)
                self.assertAlmostEqual(md["filament_total"],
                                       float(foot["filament used [mm]"]), places=2)
                self.assertGreater(md["filament_total"], 0)
                cm3 = md["filament_total"] * 3.14159265 * 1.75 ** 2 / 4 / 1000
                self.assertAlmostEqual(md["filament_weight_total"], cm3 * 1.24, delta=0.006)
                self.assertEqual(md["filament_weights"], [md["filament_weight_total"]])
                sizes = sorted((t["width"], t["height"]) for t in md["thumbnails"])
                self.assertEqual(sizes, [(32, 32), (300, 300)])
                for t in md["thumbnails"]:
                    self.assertGreater(os.path.getsize(os.path.join(os.path.dirname(g),
                                                                    t["relative_path"])), 100)
                size = os.path.getsize(g)
                self.assertTrue(0 < md["gcode_start_byte"] < md["gcode_end_byte"] <= size)


class Sl1LayerCountTest(unittest.TestCase):
    def test_declared_layers_carry_material(self):
        with tempfile.TemporaryDirectory() as d:
            for name, mesh, height, keys in SL1_CASES:
                with self.subTest(case=name):
                    out = os.path.join(d, name + ".sl1")
                    run("run", mesh, "-o", out, "--quiet", "--set", "height_mm=%g" % height,
                        *keys)
                    with zipfile.ZipFile(out) as z:
                        ini = dict(l.split(" = ", 1) for l in
                                   z.read("config.ini").decode().splitlines() if " = " in l)
                        job = ini["jobDir"]
                        names = sorted(n for n in z.namelist()
                                       if n.startswith(job) and n.endswith(".png"))
                        lit = [k for k, n in enumerate(names) if png_lit(z.read(n))]
                    declared = int(ini["numSlow"]) + int(ini["numFast"])
                    self.assertEqual(declared, len(names))
                    self.assertTrue(lit)
                    self.assertEqual(lit[-1] + 1, len(names),
                                     "%d empty layers at the top" % (len(names) - 1 - lit[-1]))
                    self.assertEqual(lit, list(range(lit[0], len(names))))


if __name__ == "__main__":
    unittest.main()
