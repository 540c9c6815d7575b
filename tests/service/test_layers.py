"""GET /v1/jobs/{id}/layers/{k}: resin outputs (sl1, zip) answer the
archive's own layer PNG byte for byte; G-code answers a drawing of layer
k whose bead pixels lie on that layer's moves (checked against a G-code
parse here, with the view the route documents); the layer count is the
archive's or the G-code's; k out of range, a mesh output and another
tenant's job are 404 problems; a job that has not finished is 409."""
import os
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "support"))
import oas  # noqa: E402
from sl1check import png_decode  # noqa: E402
from svc import FEMUR, Server, check, run  # noqa: E402

srv = Server(workers=1)
S = {}
ROLE_RGB = {"External perimeter": (0xff, 0x7d, 0x38), "Skirt/Brim": (0x00, 0x87, 0x6e)}
BACKGROUND = (0x20, 0x20, 0x24)


def setup():
    S["a"] = srv.add_tenant("alpha")
    S["b"] = srv.add_tenant("beta")
    srv.start()
    S["mesh"] = srv.upload(FEMUR, S["a"]).json()["id"]
    for fmt, h in (("sl1", 20), ("zip", 10), ("gcode", 20), ("stl", 10)):
        S[fmt] = srv.submit(S["a"], S["mesh"], format=fmt, params={"height_mm": h}).json()["id"]
    for fmt in ("sl1", "zip", "gcode", "stl"):
        j = srv.wait_job(S["a"], S[fmt], timeout=300)
        check(j["state"] == "succeeded", "%s job: %s" % (fmt, j))


def layer(job, k, key=None):
    return srv.request("GET", "/v1/jobs/%s/layers/%s" % (job, k), key=key or S["a"])


def artifact(job):
    r = srv.request("GET", "/v1/jobs/%s/output" % job, key=S["a"])
    check(r.status == 200, "download %s" % job)
    return r.body


def test_resin_layers_are_the_archive_pngs():
    for fmt in ("sl1", "zip"):
        path = os.path.join(srv.data, "%s.%s" % (fmt, fmt))
        with open(path, "wb") as f:
            f.write(artifact(S[fmt]))
        with zipfile.ZipFile(path) as z:
            names = [n for n in z.namelist() if n.endswith(".png") and "/" not in n]
            if fmt == "sl1":
                by_k = {int(n[-9:-4]): n for n in names}
            else:
                by_k = {int(n[:-4]) - 1: n for n in names}
            n = len(names)
            check(sorted(by_k) == list(range(n)), "%s layer names 0..%d" % (fmt, n - 1))
            for k in (0, n // 2, n - 1):
                r = layer(S[fmt], k)
                check(r.status == 200, "%s layer %d: %d %s" % (fmt, k, r.status, r.body[:200]))
                check(r.header("Content-Type") == "image/png", "image/png")
                check(r.header("X-Layer-Count") == str(n), "X-Layer-Count %s, archive %d" %
                      (r.header("X-Layer-Count"), n))
                check(r.body == z.read(by_k[k]), "%s layer %d is the archive's PNG" % (fmt, k))
                oas.check_response("get", "/v1/jobs/{id}/layers/{k}", r)
        for k in (n, n + 1000, 99999999):
            p = layer(S[fmt], k).problem(404, "not-found")
            check(str(n) in p["detail"] or k > 10000000, "the detail names the count: %s" % p)


def gcode_layers(text):
    """Per layer (";LAYER_CHANGE" blocks): extrusion segments (x0, y0, x1,
    y1, role, width) in mm, G90 + M83 as the writer emits them."""
    layers, x, y, role, width = [], 0.0, 0.0, None, 0.45
    for line in text.splitlines():
        if line == ";LAYER_CHANGE":
            layers.append([])
        elif line.startswith(";TYPE:"):
            role = line[6:]
        elif line.startswith(";WIDTH:"):
            width = float(line[7:])
        elif line.startswith(("G0 ", "G1 ")):
            words = {w[0]: float(w[1:]) for w in line.split(";")[0].split()[1:]}
            nx, ny = words.get("X", x), words.get("Y", y)
            if layers and words.get("E", 0) > 0 and (nx, ny) != (x, y):
                layers[-1].append((x, y, nx, ny, role, width))
            x, y = nx, ny
    return layers


def test_gcode_layer_drawing():
    text = artifact(S["gcode"]).decode()
    layers = gcode_layers(text)
    n = len(layers)
    check(n > 10, "G-code layers: %d" % n)
    pts = [c for segs in layers for s in segs for c in ((s[0], s[1]), (s[2], s[3]))]
    lo_x, hi_x = min(p[0] for p in pts), max(p[0] for p in pts)
    lo_y, hi_y = min(p[1] for p in pts), max(p[1] for p in pts)
    scale = (1024 - 16) / max(hi_x - lo_x, hi_y - lo_y)
    sizes = set()
    walls = [k for k in range(n) if any(s[4] == "External perimeter" for s in layers[k])]
    check(len(walls) > 5, "layers with external perimeters: %d" % len(walls))
    cases = [(0, "Skirt/Brim"), (walls[0], "External perimeter"),
             (walls[len(walls) // 2], "External perimeter"), (walls[-1], "External perimeter")]
    for k, role in cases:
        r = layer(S["gcode"], k)
        check(r.status == 200 and r.header("Content-Type") == "image/png", "gcode layer %d" % k)
        check(r.header("X-Layer-Count") == str(n), "count %s vs %d" % (r.header("X-Layer-Count"), n))
        img = png_decode(r.body)
        check(img.channels == 4 and max(img.width, img.height) <= 1024, "RGBA, at most 1024 px")
        sizes.add((img.width, img.height))

        def px(x, y):
            u = int(8 + (x - lo_x) * scale)
            v = int(8 + (hi_y - y) * scale)
            row = img.rows[min(max(v, 0), img.height - 1)]
            u = min(max(u, 0), img.width - 1)
            return tuple(row[u * 4:u * 4 + 3])
        segs = [s for s in layers[k] if s[4] == role]
        check(segs, "layer %d has %s moves" % (k, role))
        hits = sum(px((s[0] + s[2]) / 2, (s[1] + s[3]) / 2) == ROLE_RGB[role] for s in segs)
        check(hits >= 0.8 * len(segs), "layer %d: %d of %d %s midpoints drawn in its colour" %
              (k, hits, len(segs), role))
        # A corner of the view far from the part is background.
        check(px(lo_x - 0.5 / scale * 8, hi_y + 0.5 / scale * 8) == BACKGROUND, "margin is background")
    check(len(sizes) == 1, "every layer at the same scale: %s" % sizes)
    layer(S["gcode"], n).problem(404, "not-found")


def test_mesh_output_and_bad_k():
    layer(S["stl"], 0).problem(404, "not-found")
    for k in ("-1", "abc", "1e3", "0x10", "%20"):
        layer(S["sl1"], k).problem(404, "not-found")


def test_tenant_isolation():
    missing = "j_" + "a" * 20
    for fmt in ("sl1", "gcode"):
        theirs = layer(S[fmt], 0, key=S["b"]).problem(404, "not-found")
        nothing = layer(missing, 0, key=S["b"]).problem(404, "not-found")
        check(theirs["title"] == nothing["title"], "B's answer is a missing job's")
    srv.request("GET", "/v1/jobs/%s/layers/0" % S["sl1"]).problem(401, "unauthorized")


def test_not_finished_is_409():
    idle = Server(workers=0)
    try:
        key = idle.add_tenant("gamma")
        idle.start()
        mesh = idle.upload(FEMUR, key).json()["id"]
        job = idle.submit(key, mesh, params={"height_mm": 10}).json()["id"]
        r = idle.request("GET", "/v1/jobs/%s/layers/0" % job, key=key)
        r.problem(409, "not-ready")
        check(r.header("Retry-After") is not None, "Retry-After while queued")
        idle.json("DELETE", "/v1/jobs/" + job, key=key)
        idle.request("GET", "/v1/jobs/%s/layers/0" % job, key=key).problem(409, "not-ready")
    finally:
        idle.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_resin_layers_are_the_archive_pngs, test_gcode_layer_drawing,
             test_mesh_output_and_bad_k, test_tenant_isolation, test_not_finished_is_409])
    finally:
        srv.cleanup()
