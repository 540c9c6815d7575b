"""A store that goes away (an NFS share unmounted, a volume detached):
`serve --workers 0 --store S` and a separate `infilld worker --store S`
on the same database.  While S is gone /readyz answers 503 naming the
store, and the worker claims nothing (a job submitted meanwhile stays
queued, its attempts unspent); when S is back /readyz is 200 again and the job
runs.  Both processes carry on without a restart."""
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import BIN, FEMUR, Server, check, run  # noqa: E402

S = {}


def setup():
    base = tempfile.mkdtemp(prefix="infilld-outage-")
    store = os.path.join(base, "store")
    srv = Server(workers=0, extra=["--store", store])
    srv.start()
    url = srv.db_url or "sqlite:" + os.path.join(srv.data, "infilld.db")
    log = open(os.path.join(base, "worker.log"), "w")
    w = subprocess.Popen([BIN, "worker", "--db", url, "--store", store, "--data",
                          os.path.join(base, "w"), "--slots", "1"],
                         stdout=subprocess.PIPE, stderr=log, text=True)
    check("worker with 1 slot" in w.stdout.readline(), "worker started")
    S.update(base=base, store=store, srv=srv, worker=w, log=os.path.join(base, "worker.log"))
    S["key"] = srv.add_tenant("acme", "--store", store)
    S["mesh"] = srv.upload(FEMUR, S["key"]).json()["id"]
    j = srv.submit(S["key"], S["mesh"], params={"height_mm": 3}).json()
    check(srv.wait_job(S["key"], j["id"])["state"] == "succeeded", "a job runs on the worker")


def test_store_gone():
    srv = S["srv"]
    check(srv.request("GET", "/readyz").status == 200, "ready before")
    os.rename(S["store"], S["store"] + ".gone")
    r = srv.request("GET", "/readyz")
    r.problem(503, "unavailable")
    check("store" in r.json()["detail"], "the 503 names the store: %s" % r.json()["detail"])
    # Idle workers probe the store every 2 s (docs/operations.md).
    time.sleep(2.5)
    # Submissions are database-only: accepted and queued, never claimed.
    j = srv.submit(S["key"], S["mesh"], params={"height_mm": 3}).json()
    time.sleep(4)
    st = srv.json("GET", "/v1/jobs/" + j["id"], key=S["key"])
    check(st["state"] == "queued" and st["attempt"] == 0,
          "no claim while the store is gone: %s attempt %d" % (st["state"], st["attempt"]))
    with open(S["log"]) as f:
        check("not claiming jobs until it is back" in f.read(), "the worker says why")
    S["job"] = j["id"]


def test_store_back():
    srv = S["srv"]
    os.rename(S["store"] + ".gone", S["store"])
    check(srv.wait_job(S["key"], S["job"])["state"] == "succeeded", "the job runs once it is back")
    check(srv.request("GET", "/readyz").status == 200, "ready again")
    with open(S["log"]) as f:
        check("is back" in f.read(), "the worker says it is back")


def teardown():
    w = S["worker"]
    w.terminate()
    check(w.wait(60) == 0, "worker exit status")
    check(S["srv"].stop() == 0, "serve exit status")


def cleanup():
    if "worker" in S and S["worker"].poll() is None:
        S["worker"].kill()
    if "srv" in S:
        S["srv"].cleanup()
    if "base" in S:
        shutil.rmtree(S["base"], ignore_errors=True)


if __name__ == "__main__":
    try:
        setup()
        run([test_store_gone, test_store_back, teardown])
    finally:
        cleanup()
