"""Tenant isolation and authentication: tenant B sees 404 for every route
on tenant A's mesh and job (exactly like a missing id); missing or bad
keys get 401; admin routes refuse tenant keys (403) and work with the
admin key; a rotated key stops working at once."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import oas  # noqa: E402
from svc import FEMUR, Server, check, run  # noqa: E402

srv = Server(workers=1)
S = {}


def setup():
    S["a"] = srv.add_tenant("alpha")
    S["b"] = srv.add_tenant("beta")
    S["admin"] = srv.admin_key()
    check(S["admin"].startswith("ifa_"), "admin key on the last line")
    srv.start()
    S["mesh"] = srv.upload(FEMUR, S["a"]).json()["id"]
    S["job"] = srv.submit(S["a"], S["mesh"], params={"height_mm": 5}).json()["id"]
    srv.wait_job(S["a"], S["job"])


def test_cross_tenant_404():
    m, j = S["mesh"], S["job"]
    missing_m, missing_j = "m_" + "a" * 20, "j_" + "a" * 20
    for method, path, miss in [("GET", "/v1/meshes/" + m, "/v1/meshes/" + missing_m),
                               ("DELETE", "/v1/meshes/" + m, "/v1/meshes/" + missing_m),
                               ("GET", "/v1/jobs/" + j, "/v1/jobs/" + missing_j),
                               ("DELETE", "/v1/jobs/" + j, "/v1/jobs/" + missing_j),
                               ("GET", "/v1/jobs/%s/events" % j, "/v1/jobs/%s/events" % missing_j),
                               ("GET", "/v1/jobs/%s/output" % j, "/v1/jobs/%s/output" % missing_j)]:
        theirs = srv.request(method, path, key=S["b"])
        nothing = srv.request(method, miss, key=S["b"])
        pa, pn = theirs.problem(404, "not-found"), nothing.problem(404, "not-found")
        check(pa["title"] == pn["title"], "same answer as a missing id")
    # B's lists do not show A's objects; B cannot run a job on A's mesh.
    check(srv.json("GET", "/v1/meshes", key=S["b"])["meshes"] == [], "B lists no meshes")
    check(srv.json("GET", "/v1/jobs", key=S["b"])["jobs"] == [], "B lists no jobs")
    srv.request("POST", "/v1/jobs", {"mesh_id": m}, key=S["b"]).problem(422, "invalid-parameter")
    # A still has everything.
    check(srv.request("GET", "/v1/jobs/%s/output" % j, key=S["a"]).status == 200, "A downloads")


def test_401():
    for headers in ({}, {"Authorization": "Bearer nope"}, {"X-Api-Key": S["a"] + "x"},
                    {"Authorization": "Basic " + S["a"]}, {"Authorization": "Bearer " + S["a"][:-1] +
                                                          ("a" if S["a"][-1] != "a" else "b")}):
        r = srv.request("GET", "/v1/jobs", headers=headers)
        r.problem(401, "unauthorized")
        check(r.header("WWW-Authenticate", ) is not None, "WWW-Authenticate")
    check(srv.request("GET", "/v1/jobs", headers={"X-Api-Key": S["a"]}).status == 200, "X-Api-Key")


def test_admin_routes():
    for method, path in [("GET", "/v1/tenants"), ("POST", "/v1/tenants"),
                         ("GET", "/v1/tenants/alpha"), ("DELETE", "/v1/tenants/alpha"),
                         ("POST", "/v1/tenants/alpha/keys")]:
        srv.request(method, path, {"name": "x"} if method == "POST" else None,
                    key=S["a"]).problem(403, "forbidden")
        srv.request(method, path).problem(401, "unauthorized")
    r = srv.request("POST", "/v1/tenants", {"name": "gamma", "max_jobs": 3}, key=S["admin"])
    oas.check_response("POST", "/v1/tenants", r)
    gamma = r.json()["api_key"]
    check(srv.request("GET", "/v1/jobs", key=gamma).status == 200, "new tenant key works")
    srv.request("POST", "/v1/tenants", {"name": "gamma"}, key=S["admin"]).problem(409, "conflict")
    r = srv.request("GET", "/v1/tenants", key=S["admin"])
    oas.check_response("GET", "/v1/tenants", r)
    check({t["name"] for t in r.json()["tenants"]} == {"alpha", "beta", "gamma"}, "tenant list")
    r = srv.request("POST", "/v1/tenants/gamma/keys", key=S["admin"])
    oas.check_response("POST", "/v1/tenants/{name}/keys", r)
    srv.request("GET", "/v1/jobs", key=gamma).problem(401, "unauthorized")
    check(srv.request("GET", "/v1/jobs", key=r.json()["api_key"]).status == 200, "rotated key")
    d = srv.request("DELETE", "/v1/tenants/gamma", key=S["admin"])
    check(d.status == 204, "tenant removed")
    srv.request("GET", "/v1/jobs", key=r.json()["api_key"]).problem(401, "unauthorized")
    srv.request("GET", "/v1/tenants/gamma", key=S["admin"]).problem(404, "not-found")
    # The admin key is no tenant key.
    srv.request("GET", "/v1/jobs", key=S["admin"]).problem(401, "unauthorized")


def test_cli_rotate_remove():
    new = srv.cli("tenant", "key-rotate", "beta").strip().splitlines()[-1]
    srv.request("GET", "/v1/jobs", key=S["b"]).problem(401, "unauthorized")
    check(srv.request("GET", "/v1/jobs", key=new).status == 200, "CLI-rotated key works")
    listing = srv.cli("tenant", "list")
    check("alpha" in listing and "beta" in listing, "tenant list")
    srv.cli("tenant", "remove", "beta")
    srv.request("GET", "/v1/jobs", key=new).problem(401, "unauthorized")


def teardown():
    srv.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_cross_tenant_404, test_401, test_admin_routes, test_cli_rotate_remove, teardown])
    finally:
        srv.cleanup()
