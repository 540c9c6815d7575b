"""test_style.py - `make test` runs tests/check-style.sh (the mechanical part
of ../shared/STYLE.md: one-way layers, module prefixes of extern symbols,
file sizes) on the objects of the build under test, and checks that the
checker itself can fail: a scratch copy of the tree with an engine file that
includes an SQL header must be refused."""
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD = os.path.relpath(os.environ.get("INFILLD_BUILD", os.path.join(ROOT, "build")), ROOT)


class StyleTest(unittest.TestCase):
    def test_tree_passes(self):
        p = subprocess.run(["bash", "tests/check-style.sh", BUILD], cwd=ROOT,
                           capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)

    def test_checker_fails_on_a_layering_breach(self):
        with tempfile.TemporaryDirectory() as d:
            for sub in ("tests", "engine", "api", "db", "service"):
                shutil.copytree(os.path.join(ROOT, sub), os.path.join(d, sub),
                                ignore=shutil.ignore_patterns("*.o", "*.d"))
            with open(os.path.join(d, "engine", "core", "err.c"), "a") as f:
                f.write('\n#include "sqlite3.h"\n')
            p = subprocess.run(["bash", "tests/check-style.sh", "no-build"], cwd=d,
                               capture_output=True, text=True, timeout=300)
            self.assertNotEqual(p.returncode, 0)
            self.assertIn("engine/ must not include", p.stdout)


if __name__ == "__main__":
    sys.exit(unittest.main())
