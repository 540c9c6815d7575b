"""Damaged artifacts are never served as 200: a file whose size differs
from the database's answers 500, an altered one of the right size ends its
chunked stream with an error, and a Range of it answers 500 rather than 206
(even after an earlier Range of the intact file was served); `infilld fsck` reports both (and a missing
one), exits 1, and with --quarantine moves the damaged ones aside so their
downloads answer 410."""
import glob
import hashlib
import http.client
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import BIN, SHARED, Server, check, run  # noqa: E402

P = os.path.join(SHARED, "meshes", "P.off")
srv = Server(workers=1)
S = {}


def setup():
    S["key"] = srv.add_tenant("a")
    srv.start()
    mesh = srv.upload(P, S["key"]).json()["id"]
    S["jobs"] = []
    for _ in range(4):
        jid = srv.submit(S["key"], mesh, format="gcode", params={"height_mm": 5}).json()["id"]
        S["jobs"].append(jid)
    for jid in S["jobs"]:
        check(srv.wait_job(S["key"], jid)["state"] == "succeeded", "job ran")


def artifact(jid):
    (path,) = glob.glob(os.path.join(srv.data, "tenants", "*", "artifacts", jid + "-a*"))
    return path


def download(jid):
    """(status, body or None when the stream broke off)."""
    c = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=20)
    c.request("GET", "/v1/jobs/%s/output" % jid, headers={"Authorization": "Bearer " + S["key"]})
    r = c.getresponse()
    try:
        body = r.read()
    except (http.client.IncompleteRead, ConnectionError):
        body = None
    c.close()
    return r.status, body


def ranged(jid, spec):
    """(status, body, headers) of a Range request."""
    c = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=20)
    c.request("GET", "/v1/jobs/%s/output" % jid,
              headers={"Authorization": "Bearer " + S["key"], "Range": spec})
    r = c.getresponse()
    body = r.read()
    c.close()
    return r.status, body, dict(r.getheaders())


def fsck(*extra):
    out = subprocess.run([BIN, "fsck", "--data", srv.data, *extra], capture_output=True,
                         text=True, timeout=60)
    return out.returncode, out.stdout


def test_damage_detected():
    truncated, altered, intact, gone = S["jobs"]
    st, body = download(intact)
    check(st == 200 and body is not None, "intact download")
    whole = {}
    for jid in (intact, altered):
        with open(artifact(jid), "rb") as f:
            whole[jid] = f.read()
    # Ranges of intact files: the first checks the whole file's digest on
    # the server, the next is served from what it saw; both are the bytes
    for jid in (altered, altered, intact):
        st, part, h = ranged(jid, "bytes=50-149")
        check(st == 206 and part == whole[jid][50:150], "range of an intact file: %d" % st)
        check(h.get("Content-Range") == "bytes 50-149/%d" % len(whole[jid]), h)
    with open(artifact(truncated), "r+b") as f:
        f.truncate(os.path.getsize(artifact(truncated)) // 2)
    with open(artifact(altered), "r+b") as f:
        f.seek(100)
        b = f.read(1)
        f.seek(100)
        f.write(bytes([b[0] ^ 0xFF]))
    os.unlink(artifact(gone))
    st, body = download(truncated)
    check(st == 500, "truncated artifact: %d" % st)
    st, body = download(altered)
    check(body is None or st != 200, "altered artifact served whole as %d" % st)
    # the altered file was served in part before: its new ctime makes the
    # server check it again, so neither a range over the change nor one
    # away from it is served
    for spec in ("bytes=50-149", "bytes=0-9", "bytes=-10"):
        st, part, _ = ranged(altered, spec)
        check(st == 500 and b"damaged" in part, "range %s of the altered file: %d %r" %
              (spec, st, part[:80]))
    st, part, _ = ranged(truncated, "bytes=0-9")
    check(st == 500, "range of the truncated file: %d" % st)
    st, body = download(gone)
    check(st == 410, "missing artifact: %d" % st)
    st, body = download(intact)
    check(st == 200 and body is not None, "the intact one still downloads")
    rc, out = fsck()
    print("     " + out.replace("\n", "\n     ").rstrip())
    check(rc == 1, "fsck exits 1 on damage: %d" % rc)
    check("damaged %s" % truncated in out and "damaged %s" % altered in out, "both damaged")
    check("missing %s" % gone in out, "missing reported")
    check(intact not in out, "intact not reported")


def test_quarantine():
    truncated, altered, intact, gone = S["jobs"]
    rc, out = fsck("--quarantine")
    check(rc == 1 and "quarantined %s" % truncated in out and "quarantined %s" % altered in out,
          "quarantined: %s" % out)
    check(os.path.exists(os.path.join(srv.data, "quarantine")), "moved aside")
    for jid in (truncated, altered):
        st, body = download(jid)
        check(st == 410, "quarantined download: %d" % st)
        check(b"damaged" in body, "the 410 says why: %r" % body)
    rc, out = fsck()
    check("damaged" not in out.split("checked")[0], "nothing damaged left: %s" % out)
    st, body = download(intact)
    check(st == 200 and hashlib.sha256(body).hexdigest() ==
          srv.json("GET", "/v1/jobs/" + intact, key=S["key"])["output"]["sha256"], "intact")


def teardown():
    srv.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_damage_detected, test_quarantine, teardown])
    finally:
        srv.cleanup()
