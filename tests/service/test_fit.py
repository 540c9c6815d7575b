"""A job whose part cannot fit the printer is refused at submission (422,
field height_mm or scale, saying by how much) when the mesh's stored
analysis already shows it, not later in a worker: the femur (1 mm tall in
file units) asked at height_mm 500 on the SL1 (150 mm of height), and at
scale 1000; height_mm 50 is accepted."""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import oas  # noqa: E402
from svc import FEMUR, Server, check, run  # noqa: E402

srv = Server(workers=1)
S = {}


def setup():
    S["key"] = srv.add_tenant("fit")
    srv.start()
    S["mesh"] = srv.upload(FEMUR, S["key"]).json()["id"]


def test_too_tall_refused():
    r = srv.request("POST", "/v1/jobs", {"mesh_id": S["mesh"], "params": {"height_mm": 500}},
                    key=S["key"])
    p = r.problem(422, "invalid-parameter")
    oas.check_response("POST", "/v1/jobs", r)
    check(p.get("field") == "height_mm", "field height_mm: %s" % p)
    m = re.search(r"([0-9.]+) mm too large in Z", p["detail"])
    check(m is not None, "says by how much: %s" % p["detail"])
    check(abs(float(m.group(1)) - 350) < 1, "500 mm on a 150 mm printer: %s" % p["detail"])
    jobs = srv.json("GET", "/v1/jobs", key=S["key"])
    check(not jobs.get("items", jobs.get("jobs", [])), "no job was queued: %s" % jobs)


def test_too_large_scale_refused():
    r = srv.request("POST", "/v1/jobs", {"mesh_id": S["mesh"], "params": {"scale": 1000}},
                    key=S["key"])
    p = r.problem(422, "invalid-parameter")
    check(p.get("field") == "scale", "field scale: %s" % p)
    check("does not fit" in p["detail"], p["detail"])


def test_fitting_accepted():
    j = srv.submit(S["key"], S["mesh"], params={"height_mm": 50, "layer_mm": 0.5}).json()
    done = srv.wait_job(S["key"], j["id"])
    check(done["state"] == "succeeded", "job ran: %s" % done)


if __name__ == "__main__":
    try:
        setup()
        run([test_too_tall_refused, test_too_large_scale_refused, test_fitting_accepted])
    finally:
        srv.cleanup()
