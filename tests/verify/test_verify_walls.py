"""test_verify_walls.py - `infilld verify` reads the wall a job really has.

The `solid` engine's shell_mm is an exact 3D erosion (docs/solid.md): the
femur at 50 mm with shell_mm = S has walls of S everywhere.  The verifier
reads the written SL1 back and must report an in-layer and a vertical
minimum wall of S within two pixels / layers (docs/verify.md: one pixel
of rasterisation per boundary), for two values of S, so a measure stuck
at a constant or at a rasterisation artefact (the (sqrt 2 - 1) pixel
reading of a void meeting the outside at a pixel corner) fails.

Run by tests/run.sh; standalone: python3 tests/verify/test_verify_walls.py
"""
import configparser
import json
import os
import subprocess
import tempfile
import unittest
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
FEMUR = os.path.join(SHARED, "meshes", "femur.off")


def run(*args):
    p = subprocess.run([BIN, *args], capture_output=True, text=True, timeout=300)
    if p.returncode != 0:
        raise AssertionError(f"infilld {' '.join(args)} failed ({p.returncode}): {p.stderr}")
    return p.stdout


def pitch(sl1):
    """Pixel pitch (mm, the larger axis) and layer height of an SL1,
    read from its own ini files, not from the verifier."""
    with zipfile.ZipFile(sl1) as z:
        ini = configparser.ConfigParser()
        ini.read_string("[x]\n" + z.read("prusaslicer.ini").decode())
        cfg = configparser.ConfigParser()
        cfg.read_string("[x]\n" + z.read("config.ini").decode())
    x = ini["x"]
    px = max(float(x["display_width"]) / float(x["display_pixels_x"]),
             float(x["display_height"]) / float(x["display_pixels_y"]))
    return px, float(cfg["x"]["layerHeight"])


class FemurShellWalls(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def shell(self, shell_mm):
        out = os.path.join(self.tmp.name, f"femur_{shell_mm}.sl1")
        run("run", FEMUR, "-o", out, "--set", "height_mm=50", "--set", f"shell_mm={shell_mm}")
        rep = json.loads(run("verify", out))
        px, layer = pitch(out)
        print(f"femur shell {shell_mm} mm: in-layer {rep['min_wall_mm']:.4f} mm, vertical "
              f"{rep['min_wall_vertical_mm']:.4f} mm, specks {rep['specks']} "
              f"(pixel {px:.4f} mm, layer {layer} mm)")
        return rep, px, layer

    def check(self, shell_mm, floor_mm):
        rep, px, layer = self.shell(shell_mm)
        self.assertGreater(rep["enclosed_void_mm3"], 100)
        self.assertGreaterEqual(rep["min_wall_mm"], floor_mm)
        self.assertLessEqual(abs(rep["min_wall_mm"] - shell_mm), 2 * px, rep)
        self.assertLessEqual(abs(rep["min_wall_vertical_mm"] - shell_mm), 2 * layer + 1e-9, rep)

    def test_shell_1mm(self):
        self.check(1.0, 0.9)

    def test_shell_04mm(self):
        self.check(0.4, 0.3)


if __name__ == "__main__":
    unittest.main()
