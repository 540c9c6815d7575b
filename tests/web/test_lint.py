"""The portal's own JavaScript (web/*.js; not the vendored three.js)
passes ESLint with the flat config eslint.config.mjs (recommended rules,
no innerHTML/outerHTML/insertAdjacentHTML, no eval); the vendored
three.js is the one package-lock.json pins."""
import glob
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "service"))
from svc import ROOT, check, run  # noqa: E402


def test_eslint():
    exe = os.path.join(ROOT, "node_modules", ".bin", "eslint")
    check(os.path.exists(exe), "eslint not installed: run make deps")
    files = sorted(glob.glob(os.path.join(ROOT, "web", "*.js")))
    check(len(files) >= 3, "web/*.js found: %s" % files)
    out = subprocess.run([exe, "--max-warnings", "0", *files], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    check(out.returncode == 0, "eslint failed:\n" + out.stdout[-4000:] + out.stderr[-2000:])


def test_lint_catches_inner_html():
    """The config really applies to web/: a file using innerHTML fails."""
    exe = os.path.join(ROOT, "node_modules", ".bin", "eslint")
    bad = "const n = document.body;\nn.innerHTML = 'x';\n"
    out = subprocess.run([exe, "--stdin", "--stdin-filename", "web/probe.js"], cwd=ROOT,
                         input=bad, capture_output=True, text=True, timeout=300)
    check(out.returncode == 1 and "innerHTML" in out.stdout, "innerHTML refused:\n" +
          out.stdout[-2000:] + out.stderr[-1000:])


def test_vendored_three_is_the_locked_one():
    """web/vendor/three.module.min.js is npm's three (package-lock.json),
    byte for byte, with its MIT licence header."""
    with open(os.path.join(ROOT, "web", "vendor", "three.module.min.js"), "rb") as f:
        vendored = f.read()
    with open(os.path.join(ROOT, "node_modules", "three", "build", "three.module.min.js"),
              "rb") as f:
        check(vendored == f.read(), "web/vendor/three.module.min.js differs from npm's three; "
              "copy node_modules/three/build/three.module.min.js again")
    check(b"SPDX-License-Identifier: MIT" in vendored[:200], "three.js licence header kept")


if __name__ == "__main__":
    run([test_eslint, test_lint_catches_inner_html, test_vendored_three_is_the_locked_one])
