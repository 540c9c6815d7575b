"""`infilld migrate-db`: a running single-machine installation (SQLite)
moves to PostgreSQL (started here, tests/support/pgserver.py) and to
another SQLite file; afterwards `serve` on the copy knows the same
tenants and keys, lists the same jobs with the same ids, serves their
outputs byte for byte, and runs new jobs.  A target that holds data is
refused and left as it was; a missing source is refused without creating
one; a password in a URL never reaches the output."""
import hashlib
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "support"))
from pgserver import PgServer  # noqa: E402
from svc import BIN, FEMUR, Server, check, run  # noqa: E402

S = {}
pg = None


def migrate(src, dst):
    return subprocess.run([BIN, "migrate-db", "--from", src, "--to", dst], capture_output=True,
                          text=True, timeout=300)


def setup():
    global pg
    srv = Server(workers=1)
    srv.start()
    key = srv.add_tenant("acme")
    mesh = srv.upload(FEMUR, key).json()["id"]
    ids = []
    for h in (4, 5, 6):
        ids.append(srv.submit(key, mesh, format="sl1", params={"height_mm": h},
                              headers={"Idempotency-Key": "k%d" % h}).json()["id"])
    outs = {}
    for i in ids:
        check(srv.wait_job(key, i)["state"] == "succeeded", "job %s" % i)
        outs[i] = hashlib.sha256(srv.request("GET", "/v1/jobs/%s/output" % i, key=key).body
                                 ).hexdigest()
    srv.stop()
    S.update(srv=srv, key=key, mesh=mesh, ids=ids, outs=outs,
             src="sqlite:" + os.path.join(srv.data, "infilld.db"))
    pg = PgServer()


def check_copy(url):
    """serve on the migrated database with the original store."""
    srv = S["srv"]
    new = Server(workers=1, data=tempfile.mkdtemp(prefix="infilld-mig-"),
                 extra=["--db", url, "--store", srv.data])
    new.start()
    try:
        key = S["key"]
        listed = new.json("GET", "/v1/jobs?limit=100", key=key)["jobs"]
        check(sorted(j["id"] for j in listed) == sorted(S["ids"]),
              "the same jobs after migration: %s" % [j["id"] for j in listed])
        for i in S["ids"]:
            r = new.request("GET", "/v1/jobs/%s/output" % i, key=key)
            check(r.status == 200 and hashlib.sha256(r.body).hexdigest() == S["outs"][i],
                  "output of %s byte for byte" % i)
        # The idempotency key still answers with the old job.
        r = new.submit(key, S["mesh"], format="sl1", params={"height_mm": 4},
                       headers={"Idempotency-Key": "k4"})
        check(r.json()["id"] == S["ids"][0] and r.header("Idempotent-Replayed") == "true",
              "idempotency key kept")
        # New work gets new ids past the copied ones and runs.
        j = new.submit(key, S["mesh"], format="sl1", params={"height_mm": 7}).json()
        check(j["id"] not in S["ids"], "a new id")
        check(new.wait_job(key, j["id"])["state"] == "succeeded", "a new job runs")
        new.request("GET", "/v1/jobs", key="ifk_" + "a" * 12 + "_" + "b" * 32).problem(
            401, "unauthorized")
    finally:
        new.cleanup()


def test_to_postgresql():
    url = pg.createdb("migrated")
    out = migrate(S["src"], url)
    check(out.returncode == 0, "migrate-db: %s" % out.stderr)
    check("(sqlite)" in out.stdout and "(postgresql)" in out.stdout, out.stdout)
    check_copy(url)


def test_to_sqlite():
    dst = "sqlite:" + os.path.join(tempfile.mkdtemp(prefix="infilld-mig-"), "copy.db")
    out = migrate(S["src"], dst)
    check(out.returncode == 0, "migrate-db: %s" % out.stderr)
    check_copy(dst)


def test_refusals():
    url = pg.createdb("busy")
    check(migrate(S["src"], url).returncode == 0, "first copy")
    again = migrate(S["src"], url)
    check(again.returncode == 1 and "holds data" in again.stderr,
          "a second copy into a non-empty target is refused: %s" % again.stderr)
    missing = os.path.join(tempfile.mkdtemp(prefix="infilld-mig-"), "none.db")
    out = migrate("sqlite:" + missing, url)
    check(out.returncode == 1 and "no database" in out.stderr and not os.path.exists(missing),
          "a missing source is refused, not created: %s" % out.stderr)
    out = migrate(S["src"], "postgresql://u:s3cret@127.0.0.1:1/nowhere")
    check(out.returncode == 1, "unreachable target fails")
    check("s3cret" not in out.stderr + out.stdout and "***" in out.stderr,
          "the password is redacted: %s" % out.stderr)
    out = migrate(S["src"], "mysql://x")
    check(out.returncode == 2, "an unknown scheme is a usage error")


def cleanup():
    if "srv" in S:
        S["srv"].cleanup()
    if pg:
        pg.stop()


if __name__ == "__main__":
    try:
        setup()
        run([test_to_postgresql, test_to_sqlite, test_refusals])
    finally:
        cleanup()
