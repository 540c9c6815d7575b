"""Concurrent uploads of one tenant cannot pass its storage quota together:
8 threads upload a ~1 MB mesh at once (raw and multipart) against a quota
of three meshes, over several rounds; the accepted uploads fit the quota,
the others get 403 quota-exceeded, and the mesh list, the tenant's
used_bytes and the files on disk agree (nothing of a refused upload stays)."""
import os
import struct
import sys
import threading
import time
import uuid

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import Server, check, run  # noqa: E402

N_THREADS = 8
ROUNDS = 4
FITS = 3  # meshes the quota holds

srv = Server(workers=1)
S = {}


def cube_stl(n=40, side_mm=20.0):
    """Binary STL of a closed cube, each face an n x n grid (12 n^2 facets,
    outward normals): 84 + 50 * 12 n^2 bytes, 960,084 for n = 40."""
    h = side_mm / n
    tris = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (0.0, side_mm):
            for i in range(n):
                for j in range(n):
                    def p(a, b):
                        q = [0.0, 0.0, 0.0]
                        q[axis], q[u], q[v] = side, a * h, b * h
                        return q
                    a, b, c, d = p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)
                    # (u, v, axis) is right-handed: CCW in (u, v) points +axis.
                    quad = [(a, b, c), (a, c, d)] if side > 0 else [(a, c, b), (a, d, c)]
                    nrm = [0.0, 0.0, 0.0]
                    nrm[axis] = 1.0 if side > 0 else -1.0
                    tris += [(nrm, t) for t in quad]
    out = [b"infilld quota race cube".ljust(80, b" "), struct.pack("<I", len(tris))]
    for nrm, t in tris:
        out.append(struct.pack("<12fH", *nrm, *t[0], *t[1], *t[2], 0))
    return b"".join(out)


def setup():
    srv.start()
    S["admin"] = srv.admin_key()
    S["mesh"] = cube_stl()
    S["size"] = len(S["mesh"])
    S["quota"] = FITS * S["size"]
    t = srv.json("POST", "/v1/tenants", {"name": "race", "quota_bytes": S["quota"]},
                 key=S["admin"], expect=201)
    S["key"] = t["api_key"]
    S["id"] = t.get("id")


def upload(i, barrier, results):
    data = S["mesh"]
    if i % 2:
        b = "----infilld" + uuid.uuid4().hex
        body = (("--%s\r\nContent-Disposition: form-data; name=\"file\"; "
                 "filename=\"cube%d.stl\"\r\nContent-Type: application/octet-stream\r\n\r\n"
                 % (b, i)).encode() + data + ("\r\n--%s--\r\n" % b).encode())
        ct = "multipart/form-data; boundary=" + b
        path = "/v1/meshes"
    else:
        body, ct = data, "model/stl"
        path = "/v1/meshes?name=cube%d.stl" % i
    barrier.wait()
    results[i] = srv.request("POST", path, body, {"Content-Type": ct}, S["key"], timeout=120)


def used():
    return srv.json("GET", "/v1/tenants/race", key=S["admin"])["used_bytes"]


def listed():
    return srv.json("GET", "/v1/meshes?limit=1000", key=S["key"])["meshes"]


def mesh_files():
    """{mesh id: size} of the mesh files under DATA/tenants/*/meshes."""
    files = {}
    for root, _, names in os.walk(os.path.join(srv.data, "tenants")):
        if os.path.basename(root) == "meshes":
            for f in names:
                files[os.path.splitext(f)[0]] = os.path.getsize(os.path.join(root, f))
    return files


def tmp_uploads():
    d = os.path.join(srv.data, "tmp")
    return [f for f in os.listdir(d) if f.startswith("up-")] if os.path.isdir(d) else []


def test_concurrent_uploads_within_quota():
    size, quota = S["size"], S["quota"]
    for rnd in range(ROUNDS):
        barrier = threading.Barrier(N_THREADS)
        results = [None] * N_THREADS
        threads = [threading.Thread(target=upload, args=(i, barrier, results))
                   for i in range(N_THREADS)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        ok = [r for r in results if r.status == 201]
        refused = [r for r in results if r.status != 201]
        for r in refused:
            p = r.problem(403, "quota-exceeded")
            check(p.get("quota_bytes") == quota, "refusal names the quota: %s" % p)
            check(p.get("used_bytes", 0) + size > quota,
                  "refusal's used_bytes leave no room for the upload: %s" % p)
        u = used()
        print("round %d: %d accepted, %d refused, used_bytes %d (quota %d)"
              % (rnd, len(ok), len(refused), u, quota), flush=True)
        check(len(ok) * size <= quota,
              "round %d: %d uploads of %d bytes accepted, quota %d" % (rnd, len(ok), size, quota))
        check(u <= quota, "round %d: used_bytes %d past the quota %d" % (rnd, u, quota))
        check(len(ok) == FITS, "round %d: all %d that fit are accepted, got %d"
              % (rnd, FITS, len(ok)))
        for r in ok:
            check(r.json()["size_bytes"] == size, "size_bytes is the mesh's: %s" % r.json())
        meshes = listed()
        files = mesh_files()
        check(sorted(m["id"] for m in meshes) == sorted(r.json()["id"] for r in ok),
              "round %d: the list holds exactly the accepted meshes" % rnd)
        check(files == {m["id"]: m["size_bytes"] for m in meshes},
              "round %d: files on disk %s match the list %s"
              % (rnd, files, {m["id"]: m["size_bytes"] for m in meshes}))
        check(u == sum(files.values()), "round %d: used_bytes %d, files %d"
              % (rnd, u, sum(files.values())))
        deadline = time.time() + 5
        while tmp_uploads() and time.time() < deadline:
            time.sleep(0.05)
        check(not tmp_uploads(), "round %d: temp files left: %s" % (rnd, tmp_uploads()))
        # Empty the tenant for the next round (credits the usage back).
        for m in meshes:
            srv.request("DELETE", "/v1/meshes/" + m["id"], key=S["key"])
        check(used() == 0 and not mesh_files(), "round %d: deletes credit everything" % rnd)


def teardown():
    srv.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_concurrent_uploads_within_quota, teardown])
    finally:
        srv.cleanup()
