"""The web portal in a real browser: Debian's headless chromium driven by
playwright-core (portal_flow.mjs) against a real `infilld serve` on
loopback.  Tenant A signs in, uploads femur.off, sees a server 422 at its
field, runs a solid SL1 job at height_mm=50 and watches it reach 100 %,
moves the layer slider to layer 500 (the PNG received and the pixels
shown must equal the archive's layer 500), downloads the archive (its
SHA-256 must be the job's); tenant B signs in with the keyboard alone
and sees none of A's jobs; the admin key
sees the tenants and the queue.  A G-code job of the same part shows its
layers as drawings with the role legend.  The page's responses carry the strict
CSP and the browser reports no CSP violation or script error.
Screenshots: BUILD/test-artifacts/portal/ (or $INFILLD_ARTIFACTS)."""
import hashlib
import json
import os
import shutil
import subprocess
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "service"))
sys.path.insert(0, os.path.join(HERE, "..", "support"))
from sl1check import png_decode  # noqa: E402
from svc import FEMUR, ROOT, Server, check, run  # noqa: E402

CHROMIUM = "/usr/bin/chromium"
ARTIFACTS = os.environ.get("INFILLD_ARTIFACTS") or os.path.join(
    os.environ.get("INFILLD_BUILD", os.path.join(ROOT, "build")), "test-artifacts", "portal")
srv = Server(workers=1)
S = {}


def setup():
    check(os.path.exists(CHROMIUM), "no %s: run make deps (Debian's chromium)" % CHROMIUM)
    check(os.path.isdir(os.path.join(ROOT, "node_modules", "playwright-core")),
          "playwright-core not installed: run make deps")
    shutil.rmtree(ARTIFACTS, ignore_errors=True)
    os.makedirs(ARTIFACTS)
    S["a"] = srv.add_tenant("alpha")
    S["b"] = srv.add_tenant("beta")
    S["admin"] = srv.admin_key()
    srv.start()
    S["url"] = "http://127.0.0.1:%d" % srv.port


def test_page_headers():
    r = srv.request("GET", "/")
    check(r.status == 200 and r.header("Content-Type").startswith("text/html"), "GET / is the page")
    csp = r.header("Content-Security-Policy") or ""
    for part in ("default-src 'self'", "script-src 'self'", "style-src 'self'", "object-src 'none'"):
        check(part in csp, "CSP has %s: %s" % (part, csp))
    check("unsafe-inline" not in csp and "unsafe-eval" not in csp, "no unsafe CSP sources")
    body = r.body.decode()
    check("<script>" not in body and "style=" not in body, "no inline script or style")
    for f in ("app.js", "style.css", "three.module.min.js"):
        a = srv.request("GET", "/web/" + f)
        check(a.status == 200 and a.header("Content-Security-Policy") == csp, "/web/" + f)
    with open(os.path.join(ROOT, "web", "vendor", "three.module.min.js"), "rb") as f:
        check(srv.request("GET", "/web/three.module.min.js").body == f.read(),
              "the vendored three.js is served as committed")
    srv.request("GET", "/web/nope.js").problem(404, "not-found")


def test_browser_flow():
    env = dict(os.environ, URL=S["url"], KEY_A=S["a"], KEY_B=S["b"], ADMIN_KEY=S["admin"],
               MESH=FEMUR, OUT=ARTIFACTS)
    out = subprocess.run(["node", os.path.join(HERE, "portal_flow.mjs")], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=600)
    print(out.stdout[-3000:], out.stderr[-3000:])
    with open(os.path.join(ARTIFACTS, "result.json")) as f:
        res = json.load(f)
    check(out.returncode == 0 and "error" not in res, "browser flow failed: %s\n%s" %
          (res.get("error"), srv.log()))
    check(res["problems"] == [], "browser console errors or CSP violations: %s" % res["problems"])
    # The only failed requests are the ones the flow provokes: the 422, the
    # admin key tried as a tenant key at sign-in, B's look at A's job.
    job_layer = "/v1/jobs/%s/layers/500" % res["job_id"]
    check(sorted(res["http_errors"]) == sorted(["A 422 /v1/jobs", "admin 401 /v1/engines",
                                                "B 404 " + job_layer]),
          "failed requests: %s" % res["http_errors"])
    # Sign-in: the key in sessionStorage, never in the URL.
    check(res["key_in_storage"], "key kept in sessionStorage")
    check(S["a"] not in res["url_after_signin"], "key not in the URL")
    check(res["upload_bar"] == 100, "upload bar at 100: %s" % res["upload_bar"])
    check("7798" in res["analysis"] and "yes" in res["analysis"], "analysis shown: %s" %
          res["analysis"])
    # The 422 came from the server and is shown at height_mm.
    check("does not fit" in res["field_error"], "server 422 at height_mm: %r" % res["field_error"])
    check(res["field_invalid"] == "true", "height_mm marked aria-invalid")
    # Progress reached 100 % through the event stream.
    check(res["final_state"] == "succeeded", "job state %s" % res["final_state"])
    check(res["progress"][-1] == 100, "progress reached 100: %s" % res["progress"])
    job = srv.json("GET", "/v1/jobs/" + res["job_id"], key=S["a"])
    check(job["engine"] == "solid" and job["format"] == "sl1" and
          job["params"] == {"height_mm": 50}, "the job the form built: %s" % job["params"])
    # Layer 500: bytes received and pixels shown are the archive's.
    dl = os.path.join(ARTIFACTS, "download.sl1")
    with open(dl, "rb") as f:
        data = f.read()
    check(hashlib.sha256(data).hexdigest() == job["output"]["sha256"],
          "downloaded file's SHA-256 is the job's")
    check(res["download_name"].endswith(".sl1"), "download name %s" % res["download_name"])
    with zipfile.ZipFile(dl) as z:
        names = sorted(n for n in z.namelist() if n.endswith("00500.png") and "/" not in n)
        check(len(names) == 1, "archive's layer 500: %s" % names)
        want = z.read(names[0])
        layers = [n for n in z.namelist() if n.endswith(".png") and "/" not in n]
    check(res["layer_count"] == str(len(layers)), "slider counts %s layers, archive %d" %
          (res["layer_count"], len(layers)))
    with open(os.path.join(ARTIFACTS, "layer500.png"), "rb") as f:
        check(f.read() == want, "the preview PNG is the archive's layer 500, byte for byte")
    img = png_decode(want)
    check(res["layer500_size"] == [img.width, img.height], "shown size %s" % res["layer500_size"])
    with open(os.path.join(ARTIFACTS, "layer500.gray"), "rb") as f:
        shown = f.read()
    check(shown == b"".join(img.rows), "the pixels shown are the archive's layer 500")
    check(sum(shown) > 0, "layer 500 is not empty")
    # Tenant B: no jobs listed, A's job answers 404.
    check(res["b_focus"]["id"] == "apikey" and res["b_focus"]["outline"] != "none",
          "keyboard reaches the key field with a visible focus ring: %s" % res["b_focus"])
    check(res["jobs_listed_b"] == 0, "B lists none of A's jobs")
    check(res["b_status_on_a_job"] == 404, "B gets 404 on A's job")
    # Admin: both tenants and the queue.
    check(sorted(res["admin_tenants"]) == ["alpha", "beta"], "admin tenants %s" %
          res["admin_tenants"])
    check("succeeded" in res["admin_queue"], "admin queue table: %s" % res["admin_queue"])
    # The G-code job: a drawing per layer, the role legend.
    check(res["gcode_printer"] == "generic-fdm", "gcode picks an FDM printer")
    check(res["gcode_state"] == "succeeded", "gcode job %s" % res["gcode_state"])
    check(int(res["gcode_layers"]) > 100 and max(res["gcode_layer"]) == 1024,
          "gcode layer drawn: %s of %s" % (res["gcode_layer"], res["gcode_layers"]))
    check(res["gcode_legend"], "role legend shown for G-code")
    check(res["jobs_listed_a"] == 2, "A lists its two jobs: %d" % res["jobs_listed_a"])
    check(res["jobs_queued_a"] == 0 and res["jobs_succeeded_a"] == 2, "state filter: %d queued, "
          "%d succeeded" % (res["jobs_queued_a"], res["jobs_succeeded_a"]))
    # Cancel ends a running hollow job; the button goes away.
    check(res["cancel_state"] == "cancelled", "cancelled job shows %s" % res["cancel_state"])
    check(res["cancel_button_hidden"], "no Cancel button on a cancelled job")
    for n in ("01-signed-in", "02-uploaded", "03-field-error", "04-finished", "05-layer-500",
              "06-tenant-b", "07-admin", "08-gcode-layer-100", "09-cancelled"):
        check(os.path.getsize(os.path.join(ARTIFACTS, n + ".png")) > 1000, "screenshot " + n)


if __name__ == "__main__":
    try:
        setup()
        run([test_page_headers, test_browser_flow])
    finally:
        srv.cleanup()
