"""test_docs.py - documentation that must stay true to the code."""
import os
import subprocess
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


class DocsTest(unittest.TestCase):
    def test_parameters_md_is_generated_from_the_binary(self):
        p = subprocess.run([sys.executable, os.path.join(HERE, "gen_params.py"), "--check"],
                           capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)

    def test_readme_commands(self):
        readme = open(os.path.join(ROOT, "README.md")).read()
        self.assertIn("make run", readme)
        self.assertIn("make test", readme)
        ci = open(os.path.join(ROOT, ".ci", "run")).read()
        self.assertIn("make test", ci)


if __name__ == "__main__":
    unittest.main(verbosity=2)
