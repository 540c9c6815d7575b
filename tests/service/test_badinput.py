"""Bad input gets a clear RFC 9457 answer, never a crash or a hang:
malformed JSON, wrong types, unknown engine/parameters, oversize uploads
(413 before the body is read), wrong checksums, broken meshes from
../shared/meshes/broken/, path characters in ids, unknown routes and
methods, slowloris connections (408 at the head deadline), 1,000 concurrent
status reads; refused and abandoned uploads leave no temp file."""
import glob
import hashlib
import os
import socket
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import oas  # noqa: E402
from svc import FEMUR, SHARED, Server, check, run  # noqa: E402

srv = Server(workers=1, extra=["--conn-timeout-s", "2", "--head-timeout-s", "2",
                               "--per-ip-connections", "2000",
                               "--max-connections", "4000", "--http-threads", "4"])
S = {}


def setup():
    S["key"] = srv.add_tenant("bad", "--max-upload-mb", "1")
    srv.start()
    S["mesh"] = srv.upload(FEMUR, S["key"]).json()["id"]


def raw_post(path, ctype, body):
    """POST with Content-Length; read the answer even if the server stops
    reading the body early (then the send fails with a broken pipe)."""
    s = socket.create_connection(("127.0.0.1", srv.port), timeout=10)
    s.sendall(("POST %s HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\n"
               "Content-Type: %s\r\nContent-Length: %d\r\n\r\n" %
               (path, S["key"], ctype, len(body))).encode())
    try:
        s.sendall(body)
    except (BrokenPipeError, ConnectionResetError):
        pass
    try:
        data = s.recv(65536)
    except ConnectionResetError:
        data = b""
    s.close()
    return data


def post_raw(body, ctype="application/json", key=True):
    return srv.request("POST", "/v1/jobs", body, {"Content-Type": ctype},
                       S["key"] if key else None)


def test_json_errors():
    post_raw(b"{not json").problem(400, "malformed-json")
    post_raw(b"").problem(400, "malformed-json")
    post_raw(b"[1,2]").problem(422, "invalid-parameter")
    post_raw(b'{"mesh_id": 5}').problem(422, "invalid-parameter")
    post_raw(b'{"mesh_id":"x","mesh_id":"y"}').problem(400, "malformed-json")
    p = post_raw(b'{"mesh_id": "%s", "colour": "red"}' % S["mesh"].encode())
    check(p.problem(422, "invalid-parameter")["field"] == "colour", "unknown field named")
    post_raw(b"{}", ctype="text/plain").problem(415, "unsupported-media-type")
    cases = [({"engine": "nosuch"}, "engine"), ({"format": "pdf"}, "format"),
             ({"params": {"height_mm": "tall"}}, "height_mm"),
             ({"params": {"height_mm": -3}}, "height_mm"), ({"params": {"bogus": 1}}, "bogus"),
             ({"params": {"up": 7}}, "up"), ({"params": []}, "params"),
             ({"printer": "nosuch"}, "printer"), ({"fault": "segv"}, "fault"),
             # generic-resin display keys (docs/printers.md): impossible values, and the
             # SL1's firmware-fixed display
             ({"printer": "generic-resin", "format": "zip", "params": {"display_px_x": 0}},
              "display_px_x"),
             ({"printer": "generic-resin", "format": "zip", "params": {"display_mm_y": 1}},
              "display_mm_y"),
             ({"params": {"display_px_x": 3840}}, "display_px_x"),
             # a G-code layer the nozzle cannot print: refused when posted,
             # not when the writer opens after the engine's work
             ({"format": "gcode", "printer": "generic-fdm", "params": {"layer_mm": 0.4}},
              "layer_mm"),
             ({"format": "gcode", "printer": "generic-fdm", "params": {"nozzle_mm": 0.2}},
              "layer_mm")]
    for extra, field in cases:
        body = {"mesh_id": S["mesh"]}
        body.update(extra)
        r = srv.request("POST", "/v1/jobs", body, key=S["key"])
        p = r.problem(422)
        oas.check_response("POST", "/v1/jobs", r)
        check(field in p.get("field", "") or field in p["detail"], "%s named in %s" % (field, p))
    srv.request("POST", "/v1/jobs", {"mesh_id": "m_" + "b" * 20}, key=S["key"]).problem(422)
    big = b'{"mesh_id": "' + b"x" * (2 << 20) + b'"}'
    check(raw_post("/v1/jobs", "application/json", big).startswith(b"HTTP/1.1 413"),
          "2 MB JSON body refused early")
    # Without a length: read, discarded past the limit, refused at the end.
    s = socket.create_connection(("127.0.0.1", srv.port), timeout=10)
    s.sendall(("POST /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\n"
               "Content-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n" %
               S["key"]).encode() + b"%x\r\n%s\r\n0\r\n\r\n" % (len(big), big))
    got = s.recv(65536)
    s.close()
    check(got.startswith(b"HTTP/1.1 413") and b"/problems/payload-too-large" in got,
          "chunked JSON refused: %r" % got[:200])


def test_oversize_upload_early():
    """413 from Content-Length alone: the server answers without reading."""
    s = socket.create_connection(("127.0.0.1", srv.port), timeout=10)
    s.sendall(("POST /v1/meshes?format=stl HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\n"
               "Content-Type: model/stl\r\nContent-Length: %d\r\n\r\n" %
               (S["key"], 5 << 30)).encode())
    s.sendall(b"solid x\n" * 1000)  # a little of the 5 GB, then wait for the answer
    data = s.recv(65536).decode(errors="replace")
    s.close()
    check(data.startswith("HTTP/1.1 413"), "early 413: %r" % data[:200])
    check("application/problem+json" in data, "problem+json")
    # Chunked body with no length: stopped once it passes the limit.
    s = socket.create_connection(("127.0.0.1", srv.port), timeout=10)
    s.sendall(("POST /v1/meshes?format=stl HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\n"
               "Content-Type: model/stl\r\nTransfer-Encoding: chunked\r\n\r\n" % S["key"]).encode())
    chunk = b"x" * 65536
    got = b""
    try:
        for _ in range(64):  # 4 MB > 1 MB limit: stored up to 1 MB, the rest discarded
            s.sendall(b"%x\r\n%s\r\n" % (len(chunk), chunk))
        s.sendall(b"0\r\n\r\n")
    except (BrokenPipeError, ConnectionResetError):
        pass
    try:
        got = s.recv(65536)
    except ConnectionResetError:
        pass
    s.close()
    check(got.startswith(b"HTTP/1.1 413"), "chunked 413: %r" % got[:100])


def upload_temps():
    """The upload temp files in the store's tmp/ (api/meshes.c: tmp/up-*)."""
    return sorted(glob.glob(os.path.join(srv.data, "tmp", "up-*")))


def wait_no_upload_temps(what):
    deadline = time.time() + 10
    while upload_temps() and time.time() < deadline:
        time.sleep(0.1)
    check(not upload_temps(), "%s left upload temp files: %s" % (what, upload_temps()))


def test_refused_uploads_leave_no_temp():
    """Every refused or abandoned upload removes its temp file: the body
    stored up to the limit and then refused (chunked 413), a checksum
    mismatch, a broken mesh, a client gone half-way through its body."""
    check(os.path.isdir(os.path.join(srv.data, "tmp")), "the store's tmp/ exists")
    # the check itself sees a temp file (it would fail on a leak)
    leak = os.path.join(srv.data, "tmp", "up-testleak")
    open(leak, "wb").close()
    check(upload_temps() == [leak], "a planted temp file is seen: %s" % upload_temps())
    os.unlink(leak)
    # chunked, past the 1 MB limit: written to tmp/ up to it, then refused
    s = socket.create_connection(("127.0.0.1", srv.port), timeout=10)
    s.sendall(("POST /v1/meshes?format=stl HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\n"
               "Content-Type: model/stl\r\nTransfer-Encoding: chunked\r\n\r\n" % S["key"]).encode())
    got = b""
    try:
        for _ in range(32):
            s.sendall(b"%x\r\n%s\r\n" % (65536, b"y" * 65536))
        s.sendall(b"0\r\n\r\n")
        got = s.recv(65536)
    except (BrokenPipeError, ConnectionResetError):
        pass
    s.close()
    check(got.startswith(b"HTTP/1.1 413") or got == b"", "chunked 413: %r" % got[:100])
    wait_no_upload_temps("a chunked upload over the limit")
    with open(FEMUR, "rb") as f:
        data = f.read()
    srv.request("POST", "/v1/meshes?format=off&sha256=" + "0" * 64, data,
                {"Content-Type": "application/octet-stream"}, S["key"]).problem(422)
    wait_no_upload_temps("a checksum mismatch")
    srv.request("POST", "/v1/meshes?format=stl", b"solid x\nfacet normal 0 0 1\nendsolid x\n",
                {"Content-Type": "model/stl"}, S["key"]).problem(422, "invalid-mesh")
    wait_no_upload_temps("a broken mesh")
    # a client that goes away after a tenth of its declared body
    s = socket.create_connection(("127.0.0.1", srv.port), timeout=10)
    s.sendall(("POST /v1/meshes?format=off HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\n"
               "Content-Type: application/octet-stream\r\nContent-Length: %d\r\n\r\n" %
               (S["key"], len(data))).encode())
    s.sendall(data[:len(data) // 10])
    deadline = time.time() + 10
    while not upload_temps() and time.time() < deadline:
        time.sleep(0.05)
    check(upload_temps() != [], "the half-sent upload is being written to tmp/")
    s.close()
    wait_no_upload_temps("a client gone half-way")
    check(srv.request("GET", "/livez").status == 200, "alive after the refused uploads")


def test_checksum_and_types():
    with open(FEMUR, "rb") as f:
        data = f.read()
    r = srv.request("POST", "/v1/meshes?format=off&sha256=" + "0" * 64, data,
                    {"Content-Type": "application/octet-stream"}, S["key"])
    p = r.problem(422, "checksum-mismatch")
    check(hashlib.sha256(data).hexdigest() in p["detail"], "detail gives the real digest")
    srv.request("POST", "/v1/meshes?format=off&sha256=xyz", data,
                {"Content-Type": "application/octet-stream"}, S["key"]).problem(400)
    srv.request("POST", "/v1/meshes", data, {"Content-Type": "image/png"},
                S["key"]).problem(415, "unsupported-media-type")
    srv.request("POST", "/v1/meshes", data, {"Content-Type": "application/octet-stream"},
                S["key"]).problem(422, "invalid-parameter")
    srv.request("POST", "/v1/meshes?format=exe", data,
                {"Content-Type": "application/octet-stream"}, S["key"]).problem(422)
    srv.request("POST", "/v1/meshes", b"--x\r\nbroken", {
        "Content-Type": "multipart/form-data; boundary=x"}, S["key"]).problem(400, "bad-request")


def test_broken_meshes():
    files = sorted(glob.glob(os.path.join(SHARED, "meshes", "broken", "*")))
    check(len(files) >= 10, "broken meshes found")
    for path in files:
        with open(path, "rb") as f:
            data = f.read()
        r = srv.request("POST", "/v1/meshes?format=stl&name=" + os.path.basename(path), data,
                        {"Content-Type": "model/stl"}, S["key"])
        check(r.status in (201, 422), "%s: %d %s" % (path, r.status, r.body[:200]))
        oas.check_response("POST", "/v1/meshes", r)
        if r.status == 422:
            p = r.problem(422, "invalid-mesh")
            check(len(p["detail"]) > 10 and "stopped without" not in p["detail"],
                  "%s: clear message: %s" % (path, p["detail"]))
    check(srv.request("GET", "/livez").status == 200, "alive after the broken meshes")


def test_ids_and_routes():
    for bad in ["..%2F..%2Fetc%2Fpasswd", "j_../../x", "%00", "j_" + "a" * 200, "'; DROP TABLE jobs"]:
        r = srv.request("GET", "/v1/jobs/" + bad.replace(" ", "%20"), key=S["key"])
        check(r.status in (404, 400), "%r: %d" % (bad, r.status))
        if r.status == 404:
            r.problem(404)
    srv.request("GET", "/v1/nothing", key=S["key"]).problem(404, "not-found")
    r = srv.request("PUT", "/v1/jobs", key=S["key"])
    r.problem(405, "method-not-allowed")
    check("GET" in r.header("Allow") and "POST" in r.header("Allow"), "Allow header")
    srv.request("POST", "/livez").problem(405)
    d = srv.request("GET", "/problems/not-found")
    check(d.status == 200 and b"404" in d.body, "problem types are documented")


def test_slowloris():
    socks = []
    for _ in range(20):
        s = socket.create_connection(("127.0.0.1", srv.port), timeout=10)
        s.sendall(b"GET /v1/jobs HTTP/1.1\r\nHost: x\r\nX-Slow: ")  # never finished
        socks.append(s)
    t0 = time.time()
    # The server still answers others meanwhile.
    check(srv.request("GET", "/livez").status == 200, "serving during the attack")
    closed = 0
    for s in socks:
        try:
            s.settimeout(10)
            got = s.recv(4096)
            closed += got == b"" or got.startswith(b"HTTP/1.1 408")
        except (ConnectionResetError, socket.timeout):
            closed += 1
        s.close()
    check(closed == len(socks), "slow heads answered 408: %d of %d" % (closed, len(socks)))
    check(time.time() - t0 < 8, "closed by the 2 s head deadline")


def test_concurrent_status():
    jid = srv.submit(S["key"], S["mesh"], params={"height_mm": 5}).json()["id"]
    results, lock = [], threading.Lock()
    start = threading.Barrier(1000)

    def one():
        start.wait()
        try:
            r = srv.request("GET", "/v1/jobs/" + jid, key=S["key"], timeout=60)
            st = r.status
        except Exception as e:  # counted as a failure below
            st = repr(e)
        with lock:
            results.append(st)

    ts = [threading.Thread(target=one) for _ in range(1000)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    bad = [x for x in results if x != 200]
    check(len(results) == 1000 and not bad, "1000 concurrent reads: %d failures %s" %
          (len(bad), bad[:5]))


def teardown():
    srv.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_json_errors, test_oversize_upload_early, test_refused_uploads_leave_no_temp,
             test_checksum_and_types,
             test_broken_meshes, test_ids_and_routes, test_slowloris, test_concurrent_status,
             teardown])
    finally:
        srv.cleanup()
