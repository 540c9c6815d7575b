"""openapi.yaml passes a real linter (Redocly CLI, installed by `make deps`
with npm ci) with the rules of redocly.yaml, and every route the server
answers is documented."""
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import oas  # noqa: E402
from svc import ROOT, check, run  # noqa: E402


def test_lint():
    exe = os.path.join(ROOT, "node_modules", ".bin", "redocly")
    check(os.path.exists(exe), "redocly not installed: run make deps")
    out = subprocess.run([exe, "lint", "openapi.yaml"], cwd=ROOT, capture_output=True,
                         text=True, timeout=300, env=dict(os.environ, REDOCLY_TELEMETRY="off",
                                                          REDOCLY_SUPPRESS_UPDATE_NOTICE="true"))
    check(out.returncode == 0, "redocly lint failed:\n" + out.stdout[-3000:] + out.stderr[-2000:])


def test_routes_documented():
    with open(os.path.join(ROOT, "api", "server.c")) as f:
        src = f.read()
    routes = re.findall(r'\{"(GET|POST|DELETE)",\s*"([^"]+)",\s*AUTH_\w+,\s*BODY_\w+,\s*\w+,\s*"([^"]+)"\}',
                        src)
    check(len(routes) >= 15, "routes parsed from server.c: %d" % len(routes))
    paths = oas.spec()["paths"]
    for method, _, documented in routes:
        check(documented in paths and method.lower() in paths[documented],
              "%s %s missing from openapi.yaml" % (method, documented))


if __name__ == "__main__":
    run([test_lint, test_routes_documented])
