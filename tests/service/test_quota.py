"""Storage quotas cover artifacts: outputs are charged to the tenant, a job
whose output would pass the quota fails with error.type "quota" (nothing
stored or charged), and uploads and submissions past the quota get 403
problems with used_bytes and quota_bytes."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import SHARED, Server, check, run  # noqa: E402

P = os.path.join(SHARED, "meshes", "P.off")  # 500 bytes; 10 mm of G-code is ~200 kB
srv = Server(workers=1)
S = {}


def setup():
    srv.start()
    S["admin"] = srv.admin_key()


def tenant(name, quota):
    t = srv.json("POST", "/v1/tenants", {"name": name, "quota_bytes": quota}, key=S["admin"],
                 expect=201)
    return t["api_key"]


def used(name):
    return srv.json("GET", "/v1/tenants/" + name, key=S["admin"])["used_bytes"]


def artifacts(key):
    """Bytes of the tenant's artifact files on disk."""
    total = 0
    for root, _, files in os.walk(os.path.join(srv.data, "tenants")):
        if root.endswith("artifacts"):
            total += sum(os.path.getsize(os.path.join(root, f)) for f in files)
    return total


def job(key, mesh):
    jid = srv.submit(key, mesh, format="gcode", params={"height_mm": 10}).json()["id"]
    return srv.wait_job(key, jid)


def test_outputs_charged_and_limited():
    key = tenant("q1", 300000)
    mesh = srv.upload(P, key).json()["id"]
    size = os.path.getsize(P)
    j1 = job(key, mesh)
    check(j1["state"] == "succeeded", "first job fits: %s" % j1)
    out = j1["output"]["bytes"]
    after1 = used("q1")
    check(after1 > size + 100000, "the artifact is charged: used %d" % after1)
    check(after1 == size + out, "used = mesh + artifact: %d vs %d" % (after1, size + out))
    # Three more jobs: each would pass the quota, so each fails and stores nothing.
    jobs = [srv.submit(key, mesh, format="gcode", params={"height_mm": 10}).json()["id"]
            for _ in range(3)]
    for jid in jobs:
        j = srv.wait_job(key, jid)
        check(j["state"] == "failed" and j["error"]["type"] == "quota",
              "over-quota job fails with type quota: %s" % j)
        check("quota" in j["error"]["detail"], "detail names the quota")
    check(used("q1") == after1, "failed jobs are not charged: %d" % used("q1"))
    check(used("q1") <= 300000, "never past the quota")
    check(artifacts(key) == after1 - size, "only the first artifact is on disk")


def test_refused_past_quota():
    size = os.path.getsize(P)
    key = tenant("q2", size)
    mesh = srv.upload(P, key).json()["id"]  # exactly the quota
    r = srv.request("POST", "/v1/meshes?format=off&name=P2.off", open(P, "rb").read(),
                    {"Content-Type": "application/octet-stream"}, key)
    p = r.problem(403, "quota-exceeded")
    check(p.get("used_bytes") == size and p.get("quota_bytes") == size,
          "upload refusal carries used and allowed bytes: %s" % p)
    r = srv.request("POST", "/v1/jobs", {"mesh_id": mesh, "format": "gcode"}, key=key)
    p = r.problem(403, "quota-exceeded")
    check(p.get("used_bytes") == size and p.get("quota_bytes") == size,
          "job refusal carries used and allowed bytes: %s" % p)
    # Chunked: no length to refuse up front; stopped once past the quota.
    import http.client
    c = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=20)
    c.putrequest("POST", "/v1/meshes?format=off")
    c.putheader("Authorization", "Bearer " + key)
    c.putheader("Content-Type", "application/octet-stream")
    c.putheader("Transfer-Encoding", "chunked")
    c.endheaders()
    data = open(P, "rb").read()
    c.send(b"%x\r\n%s\r\n0\r\n\r\n" % (len(data), data))
    resp = c.getresponse()
    check(resp.status == 403, "chunked upload past the quota: %d" % resp.status)
    c.close()
    check(used("q2") == size, "nothing more charged")


def teardown():
    srv.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_outputs_charged_and_limited, test_refused_past_quota, teardown])
    finally:
        srv.cleanup()
