"""test_fea_api.py - params.loads of POST /v1/jobs on a real `infilld serve`
(loopback, temp data directory, real SQLite): a malformed load-case object
is 422 with `field` the JSON path of the offending value, whatever the
engine; a valid one for the solid engine (which has no `loads` parameter)
is the ordinary unknown-parameter 422; a text form instead of the object is
refused too.  No job is queued by any of them.  A rhombic job (the engine
takes `loads`) with a valid object runs and reports the case it used, in
the engine's text form.""" 
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "service"))
import oas  # noqa: E402
from svc import FEMUR, Server, check, run  # noqa: E402

srv = Server(workers=1)
S = {}
VALID = {"material": {"E_mpa": 2500, "nu": 0.4},
         "fixed": ["plate", {"box_mm": [0, 0, 0, 5, 5, 1], "axes": "z"}],
         "forces": [{"preset": "top", "force_n": [0, 0, -1000]}]}


def setup():
    S["key"] = srv.add_tenant("fea")
    srv.start()
    S["mesh"] = srv.upload(FEMUR, S["key"]).json()["id"]


def submit(params, engine=None):
    body = {"mesh_id": S["mesh"], "params": params}
    if engine:
        body["engine"] = engine
    r = srv.request("POST", "/v1/jobs", body, key=S["key"])
    oas.check_response("POST", "/v1/jobs", r)
    return r


def test_malformed_loads_name_the_path():
    cases = [
        ({"forces": [{"preset": "top", "force_n": [0, 0, -1]},
                     {"preset": "top", "force_n": [1, 2]}]},
         "loads.forces[1].force_n", "expected 3 numbers"),
        ({"fixed": [{"box_mm": [0, 0, 0, 1, 1]}]}, "loads.fixed[0].box_mm", "expected 6 numbers"),
        ({"material": {"E_mpa": 2500}}, "loads.material.nu", "Poisson"),
        ({"fixed": ["plate"], "torque": 1}, "loads.torque", "unknown key"),
        ({"fixed": [{"preset": "plate", "axes": "xyw"}]}, "loads.fixed[0].axes", "x, y, z"),
    ]
    for loads, field, needle in cases:
        for engine in (None, "lattice"):
            r = submit({"height_mm": 50, "loads": loads}, engine)
            p = r.problem(422, "invalid-parameter")
            check(p.get("field") == field, "field %s: %s" % (field, p))
            check(needle in p["detail"], "detail names the problem: %s" % p["detail"])


def test_valid_loads_unknown_to_solid():
    r = submit({"height_mm": 50, "loads": VALID})
    p = r.problem(422, "invalid-parameter")
    check(p.get("field") == "loads", "field loads: %s" % p)
    check("unknown parameter 'loads'" in p["detail"] and "solid" in p["detail"], p["detail"])
    # the text form is not the API's: the same unknown-parameter answer for solid
    r = submit({"loads": "fixed plate axes=xyz; force top n=0,0,-1000"})
    p = r.problem(422, "invalid-parameter")
    check(p.get("field") == "loads", "field loads: %s" % p)


def test_nothing_queued():
    jobs = srv.json("GET", "/v1/jobs", key=S["key"])
    check(not jobs.get("items", jobs.get("jobs", [])), "no job was queued: %s" % jobs)


def test_rhombic_job_uses_the_loads():
    loads = dict(VALID, fixed=["plate", {"box_mm": [0, 0, 0, 20, 17, 1], "axes": "z"}])
    r = submit({"height_mm": 50, "loads": loads, "refine": "uniform", "volume_fraction": 0.3,
                "wall_mm": 1, "skin_mm": 1}, "rhombic")
    check(r.status == 202, "rhombic job accepted: %s %s" % (r.status, r.body[:300]))
    j = srv.wait_job(S["key"], r.json()["id"], timeout=300)
    check(j["state"] == "succeeded", "rhombic job ran: %s" % j)
    rh = j["metrics"]["rhombic"]
    check(rh["loads"] == "material E_mpa=2500 nu=0.4; fixed plate axes=xyz; "
          "fixed box=0,0,0,20,17,1 axes=z; force top n=0,0,-1000", rh["loads"])
    check(rh["compliance_nmm"] > 0 and rh["compliance_normalized"] >= 1, rh)
    # the text form is refused for an engine that takes loads too: one format
    r = submit({"height_mm": 50, "loads": "fixed plate; force top n=0,0,-1"}, "rhombic")
    p = r.problem(422, "invalid-parameter")
    check(p.get("field") == "loads", "field loads: %s" % p)


def test_hybrid_job():
    """The hybrid engine through the API: its components come back as a
    JSON list of objects, its compliance under the given loads; a local
    template path is the CLI's only."""
    loads = dict(VALID, fixed=["plate", {"box_mm": [0, 0, 0, 20, 17, 1], "axes": "z"}])
    r = submit({"height_mm": 50, "layer_mm": 0.2, "loads": loads}, "hybrid")
    check(r.status == 202, "hybrid job accepted: %s %s" % (r.status, r.body[:300]))
    j = srv.wait_job(S["key"], r.json()["id"], timeout=400)
    check(j["state"] == "succeeded", "hybrid job ran: %s" % j)
    hy = j["metrics"]["hybrid"]
    check(isinstance(hy["components"], list) and hy["components"], hy)
    for c in hy["components"]:
        check(c["class"] in ("VCol", "NCol") and c["facets"] > 0 and c["area_mm2"] > 0, c)
    check(hy["loads"].startswith("material E_mpa=2500 nu=0.4; fixed plate axes=xyz"), hy)
    check(0 < hy["weight_fraction"] < 1 and hy["compliance_nmm"] >= hy["compliance_solid_nmm"],
          hy)
    r = submit({"height_mm": 50, "mfs_template": "/etc/passwd"}, "hybrid")
    p = r.problem(422, "invalid-parameter")
    check(p.get("field") == "mfs_template", "field mfs_template: %s" % p)


if __name__ == "__main__":
    try:
        setup()
        run([test_malformed_loads_name_the_path, test_valid_loads_unknown_to_solid,
             test_nothing_queued, test_rhombic_job_uses_the_loads, test_hybrid_job])
    finally:
        srv.cleanup()
