"""End to end through the real service: tenant via CLI, upload femur.off
(raw and multipart with checksum), a solid SL1 job and a G-code job
followed over SSE, downloads (chunked, Range, ETag, digest) verified
independently, listing with pagination, idempotency, and cancelling a
running job.  Every JSON response is checked against openapi.yaml."""
import base64
import hashlib
import io
import json
import os
import sys
import time
import uuid
import zipfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import oas  # noqa: E402
from svc import FEMUR, Server, check, fail, run  # noqa: E402

srv = Server(workers=2)
S = {}


def setup():
    srv.key = srv.add_tenant("acme", "--max-jobs", "2")
    check(srv.key.startswith("ifk_"), "key on the last line: %r" % srv.key)
    srv.start()
    r = srv.request("GET", "/livez")
    oas.check_response("GET", "/livez", r)
    r = srv.request("GET", "/readyz")
    oas.check_response("GET", "/readyz", r)
    r = srv.request("GET", "/v1/engines", key=srv.key)
    oas.check_response("GET", "/v1/engines", r)
    check("solid" in [e["name"] for e in r.json()["engines"]], "solid engine listed")


def test_upload_raw():
    r = srv.upload(FEMUR, srv.key)
    oas.check_response("POST", "/v1/meshes", r)
    m = r.json()
    check(r.header("Location") == "/v1/meshes/" + m["id"], "Location")
    with open(FEMUR, "rb") as f:
        data = f.read()
    check(m["sha256"] == hashlib.sha256(data).hexdigest(), "sha256 of the stored body")
    check(m["size_bytes"] == len(data), "size")
    check(m["analysis"]["mesh"]["triangles"] > 1000, "analysis triangles")
    check(m["analysis"]["mesh"]["watertight"] is True, "femur is watertight")
    g = srv.request("GET", "/v1/meshes/" + m["id"], key=srv.key)
    oas.check_response("GET", "/v1/meshes/{id}", g)
    check(g.json()["sha256"] == m["sha256"], "get returns the mesh")
    S["mesh"] = m["id"]


def test_upload_multipart_checksum():
    with open(FEMUR, "rb") as f:
        data = f.read()
    b = "----infilld" + uuid.uuid4().hex
    digest = hashlib.sha256(data).hexdigest()
    body = (("--%s\r\nContent-Disposition: form-data; name=\"sha256\"\r\n\r\n%s\r\n" % (b, digest))
            .encode() +
            ("--%s\r\nContent-Disposition: form-data; name=\"file\"; filename=\"femur.off\"\r\n"
             "Content-Type: application/octet-stream\r\n\r\n" % b).encode() + data +
            ("\r\n--%s--\r\n" % b).encode())
    r = srv.request("POST", "/v1/meshes", body,
                    {"Content-Type": "multipart/form-data; boundary=" + b}, srv.key)
    check(r.status == 201, "multipart upload: %d %s" % (r.status, r.body[:300]))
    oas.check_response("POST", "/v1/meshes", r)
    check(r.json()["name"] == "femur.off" and r.json()["format"] == "off", "name/format from part")
    check(r.json()["sha256"] == digest, "digest")
    # RFC 9530 Content-Digest on a raw upload
    cd = "sha-256=:%s:" % base64.b64encode(hashlib.sha256(data).digest()).decode()
    r = srv.request("POST", "/v1/meshes?format=off", data,
                    {"Content-Type": "application/octet-stream", "Content-Digest": cd}, srv.key)
    check(r.status == 201, "Content-Digest upload: %d" % r.status)


def follow(job_id):
    """SSE to the end; checks ids increase and progress never goes back."""
    ev = srv.events(srv.key, job_id)
    check(ev, "events arrived")
    ids = [e[0] for e in ev]
    check(ids == sorted(ids) and len(set(ids)) == len(ids), "event ids increase: %s" % ids)
    prog = [e[2]["progress"] for e in ev]
    check(all(b >= a for a, b in zip(prog, prog[1:])), "progress monotonic: %s" % prog)
    for _, _, data in ev:
        errs = oas.errors(data, oas.schema("JobEvent"))
        check(not errs, "event data matches JobEvent: %s" % errs)
    check(ev[0][2]["state"] == "queued", "first event is queued")
    check(ev[-1][1] == "state", "last event is a state change")
    return ev


def run_job(fmt, params, expect_ext, content_type, **fields):
    r = srv.submit(srv.key, S["mesh"], engine="solid", format=fmt, params=params, **fields)
    oas.check_response("POST", "/v1/jobs", r)
    job = r.json()
    check(r.header("Location") == "/v1/jobs/" + job["id"], "Location")
    check(r.header("Retry-After") is not None, "Retry-After")
    ev = follow(job["id"])
    j = srv.request("GET", "/v1/jobs/" + job["id"], key=srv.key)
    oas.check_response("GET", "/v1/jobs/{id}", j)
    j = j.json()
    check(ev[-1][2]["state"] == "succeeded", "job succeeded: %s" % j["error"])
    check(j["state"] == "succeeded" and j["progress"] == 1.0, "final state")
    check(any(e[1] == "progress" for e in ev), "progress events were sent")
    check(j["metrics"]["layers"] == j["layers_total"] > 0, "metrics layers %r %r" % (j["metrics"].get("layers"), j["layers_total"]))
    out = srv.request("GET", "/v1/jobs/%s/output" % job["id"], key=srv.key)
    check(out.status == 200, "download: %d %s" % (out.status, out.body[:200]))
    check(out.header("Transfer-Encoding") == "chunked", "chunked stream")
    check(out.header("Content-Type") == content_type, "content type %s" % out.header("Content-Type"))
    check(expect_ext in out.header("Content-Disposition"), "disposition")
    sha = hashlib.sha256(out.body).hexdigest()
    check(out.header("ETag") == '"%s"' % sha, "ETag is the SHA-256")
    check(out.header("Repr-Digest") ==
          "sha-256=:%s:" % base64.b64encode(hashlib.sha256(out.body).digest()).decode(), "digest")
    check(j["output"]["sha256"] == sha and j["output"]["bytes"] == len(out.body), "output record")
    # Range and conditional requests
    part = srv.request("GET", "/v1/jobs/%s/output" % job["id"], key=srv.key,
                       headers={"Range": "bytes=100-1099"})
    check(part.status == 206 and part.body == out.body[100:1100], "range 100-1099")
    check(part.header("Content-Range") == "bytes 100-1099/%d" % len(out.body), "Content-Range")
    tail = srv.request("GET", "/v1/jobs/%s/output" % job["id"], key=srv.key,
                       headers={"Range": "bytes=-10"})
    check(tail.status == 206 and tail.body == out.body[-10:], "suffix range")
    bad = srv.request("GET", "/v1/jobs/%s/output" % job["id"], key=srv.key,
                      headers={"Range": "bytes=%d-" % (len(out.body) + 5)})
    bad.problem(416, "range-not-satisfiable")
    nm = srv.request("GET", "/v1/jobs/%s/output" % job["id"], key=srv.key,
                     headers={"If-None-Match": out.header("ETag")})
    check(nm.status == 304 and nm.body == b"", "304 on If-None-Match")
    return j, out.body


def test_sl1_job():
    j, data = run_job("sl1", {"height_mm": 40}, ".sl1", "application/vnd.prusa.sl1")
    path = os.path.join(srv.data, "check.sl1")
    with open(path, "wb") as f:
        f.write(data)
    try:
        import sl1check  # tests/support, the output module's independent checker
    except ImportError:
        sl1check = None
    if sl1check:
        rep = sl1check.check_archive(path, expect_layers=j["layers_total"])
        check(rep is not None, "sl1check report")
    zf = zipfile.ZipFile(io.BytesIO(data))
    names = zf.namelist()
    check("config.ini" in names and "prusaslicer.ini" in names, "SL1 manifests")
    pngs = [n for n in names if n.endswith(".png") and not n.startswith("thumbnail/")]
    check(len(pngs) == j["layers_total"] == 800, "one PNG per layer: %d" % len(pngs))
    check(zf.testzip() is None, "zip CRCs")
    S["sl1_job"] = j["id"]


def test_generic_resin_zip_job():
    """The job's printer field picks generic-resin; its display keys set the PNG size."""
    import struct
    params = {"height_mm": 10, "layer_mm": 0.2, "display_px_x": 1920, "display_px_y": 1080,
              "display_mm_x": 76.8, "display_mm_y": 43.2, "mirror_x": True}
    j, data = run_job("zip", params, ".zip", "application/zip", printer="generic-resin")
    check(j["printer"] == "generic-resin", "printer recorded: %r" % j["printer"])
    zf = zipfile.ZipFile(io.BytesIO(data))
    pngs = [n for n in zf.namelist() if n.endswith(".png")]
    check(len(pngs) == j["layers_total"] > 0, "one PNG per layer: %d" % len(pngs))
    for n in pngs[:3] + pngs[-1:]:
        head = zf.read(n)[:24]
        check(head[12:16] == b"IHDR" and struct.unpack(">II", head[16:24]) == (1920, 1080),
              "%s is 1920 x 1080: %r" % (n, head[16:24]))
    man = json.loads(zf.read("manifest.json"))
    check(abs(man["pixel_um"][0] - 40) < 1e-6 and abs(man["pixel_um"][1] - 40) < 1e-6,
          "40 um pixels: %r" % man["pixel_um"])


def test_gcode_job():
    j, data = run_job("gcode", {"height_mm": 30}, ".gcode", "text/x.gcode")
    text = data.decode()
    try:
        import gcodecheck  # tests/support, the G-code module's independent parser
    except ImportError:
        gcodecheck = None
    if gcodecheck and hasattr(gcodecheck, "check_file"):
        path = os.path.join(srv.data, "check.gcode")
        with open(path, "w") as f:
            f.write(text)
        gcodecheck.check_file(path)
    check(text.startswith("; generated by infilld"), "banner first")
    zs = [float(line.split(":")[1]) for line in text.splitlines() if line.startswith(";Z:")]
    check(len(zs) == j["layers_total"] and zs == sorted(zs), "one ;Z: per layer, increasing")


def test_list_paginate():
    ids = []
    for _ in range(5):
        ids.append(srv.submit(srv.key, S["mesh"], format="sl1", params={"height_mm": 5})
                   .json()["id"])
    seen, cursor, pages = [], None, 0
    while True:
        q = "/v1/jobs?limit=3" + ("&cursor=" + cursor if cursor else "")
        r = srv.request("GET", q, key=srv.key)
        oas.check_response("GET", "/v1/jobs", r)
        page = r.json()
        seen += [j["id"] for j in page["jobs"]]
        pages += 1
        cursor = page["next_cursor"]
        if not cursor:
            break
    check(len(seen) == len(set(seen)), "no duplicates across pages")
    check(seen[:5] == ids[::-1], "newest first")
    check(pages >= 2, "paginated")
    for jid in ids:
        srv.wait_job(srv.key, jid)
    r = srv.request("GET", "/v1/jobs?state=succeeded&limit=1000", key=srv.key)
    check(all(j["state"] == "succeeded" for j in r.json()["jobs"]), "state filter")
    m = srv.request("GET", "/v1/meshes?limit=1", key=srv.key)
    oas.check_response("GET", "/v1/meshes", m)
    check(m.json()["next_cursor"], "mesh pagination cursor")
    m2 = srv.request("GET", "/v1/meshes?limit=1&cursor=" + m.json()["next_cursor"], key=srv.key)
    check(m2.json()["meshes"][0]["id"] != m.json()["meshes"][0]["id"], "mesh page 2")


def test_idempotency():
    h = {"Idempotency-Key": "order-" + uuid.uuid4().hex}
    a = srv.submit(srv.key, S["mesh"], headers=h, params={"height_mm": 5}).json()
    b = srv.submit(srv.key, S["mesh"], headers=h, params={"height_mm": 5})
    check(b.json()["id"] == a["id"] and b.header("Idempotent-Replayed") == "true", "replay")
    c = srv.request("POST", "/v1/jobs", {"mesh_id": S["mesh"], "params": {"height_mm": 6}},
                    h, srv.key)
    c.problem(422, "idempotency-key-reused")
    srv.wait_job(srv.key, a["id"])


def test_cancel_running():
    # About 14,000 layers: seconds of real work for the solid engine.
    long_job = srv.submit(srv.key, S["mesh"], format="sl1",
                          params={"height_mm": 140, "layer_mm": 0.01}).json()["id"]
    deadline = time.time() + 60
    while time.time() < deadline:
        j = srv.json("GET", "/v1/jobs/" + long_job, key=srv.key)
        if j["state"] == "running" and j["layers_done"] > 0:
            break
        time.sleep(0.05)
    check(j["state"] == "running", "long job running: %s" % j)
    t0 = time.time()
    r = srv.request("DELETE", "/v1/jobs/" + long_job, key=srv.key)
    oas.check_response("DELETE", "/v1/jobs/{id}", r)
    check(r.json()["state"] == "cancelled", "cancelled at once")
    # The job process stops within seconds: its tmp output disappears and
    # the worker logs it.
    while time.time() - t0 < 10:
        if "job %s attempt 1 stopped" % long_job in srv.log():
            break
        time.sleep(0.1)
    check("job %s attempt 1 stopped" % long_job in srv.log(), "worker stopped the job:\n" +
          srv.log())
    later = srv.json("GET", "/v1/jobs/" + long_job, key=srv.key)
    check(later["state"] == "cancelled" and later["output"] is None, "stays cancelled")
    srv.request("DELETE", "/v1/jobs/" + S["sl1_job"], key=srv.key).problem(409, "conflict")
    out = srv.request("GET", "/v1/jobs/%s/output" % long_job, key=srv.key)
    out.problem(409, "not-ready")


def test_metrics_and_delete():
    r = srv.request("GET", "/metrics")
    check(r.status == 200 and r.header("Content-Type").startswith("text/plain"), "metrics")
    t = r.body.decode()
    for needle in ('infilld_jobs{state="succeeded"}', "infilld_queue_depth",
                   'infilld_job_duration_seconds_bucket{state="succeeded",le="+Inf"}',
                   'infilld_http_requests_total{route="/v1/jobs",code="202"}'):
        check(needle in t, "metrics has %s" % needle)
    # A mesh no job uses can go; then it is gone.
    up = srv.upload(FEMUR, srv.key).json()
    d = srv.request("DELETE", "/v1/meshes/" + up["id"], key=srv.key)
    check(d.status == 204, "delete mesh")
    srv.request("GET", "/v1/meshes/" + up["id"], key=srv.key).problem(404, "not-found")


def teardown():
    rc = srv.stop()
    check(rc == 0, "serve exits 0 on SIGTERM, got %s\n%s" % (rc, srv.log()))
    srv.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_upload_raw, test_upload_multipart_checksum, test_sl1_job,
             test_generic_resin_zip_job, test_gcode_job,
             test_list_paginate, test_idempotency, test_cancel_running,
             test_metrics_and_delete, teardown])
    finally:
        srv.cleanup()
