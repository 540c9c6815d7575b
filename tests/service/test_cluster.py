"""Cluster: 2 API servers (`serve --workers 0`) and 3 workers (`infilld
worker`) on one PostgreSQL (started here, tests/support/pgserver.py) and
one shared store, each process with its own --data.  3 tenants submit 500
jobs through both API servers; one worker (its whole process group, as a
machine that dies) and one API server are SIGKILLed mid-run and started
again.  Checked apart from the code under test, in the database with psql
and in the store with sha256:

- every acknowledged job (202) finishes exactly once: state succeeded,
  exactly one "succeeded" state event, one recorded artifact;
- no job is lost (every 202's id is in the database; no job was made
  twice for one Idempotency-Key even when the client retried on the
  other API server after a kill);
- artifacts are byte-identical to a single-machine run: jobs of the
  cluster's database, copied to SQLite and run again by one `serve`, give
  the same bytes; and every one of the 500 matches a fresh single-machine
  job member by member, except the line an SL1 stamps by design
  (config.ini's fileCreationTimestamp, the job's own creation second);
- the per-tenant cap holds at every sample, and claims are fair: while
  all three tenants have queued work each gets a third of the claims."""
import hashlib
import http.client
import io
import json
import os
import signal
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "support"))
from pgserver import PgServer  # noqa: E402
from svc import BIN, FEMUR, Server, check, fail, run  # noqa: E402

JOBS = 500
TENANTS = ("acme", "bolt", "cogs")
# acme floods first; bolt and cogs come later: fairness must still give
# them their share as soon as they have work.
SHARE = {"acme": 250, "bolt": 125, "cogs": 125}
MAX_JOBS = 2           # per tenant; 3 workers x 1 slot < 3 x 2, so the cap alone cannot force fairness
PARAMS = {"height_mm": 8}

pg = None
tmp = None
url = None
store = None
apis = {}
workers = {}
keys = {}
mesh = {}
acked = {}             # job id -> (tenant, idempotency key)
samples = []           # per-tenant running counts seen while the run went on


def sql(query):
    """One psql query on the cluster's database; rows of '|'-separated text."""
    out = subprocess.run(["psql", url, "-X", "-A", "-t", "-F", "|", "-c", query],
                         capture_output=True, text=True, timeout=60)
    if out.returncode != 0:
        fail("psql: %s" % out.stderr)
    return [r.split("|") for r in out.stdout.splitlines() if r]


def start_api(name):
    data = os.path.join(tmp, name)
    log = open(os.path.join(tmp, name + ".log"), "a")
    p = subprocess.Popen([BIN, "serve", "--listen", "127.0.0.1:0", "--db", url, "--store", store,
                          "--data", data, "--workers", "0", "--lease-s", "3"],
                         stdout=subprocess.PIPE, stderr=log, text=True)
    line = p.stdout.readline()
    check("listening on http://127.0.0.1:" in line, "%s did not start: %r" % (name, line))
    port = int(line.split("127.0.0.1:")[1].split()[0])
    apis[name] = (p, port)
    return port


def start_worker(name):
    data = os.path.join(tmp, name)
    log = open(os.path.join(tmp, name + ".log"), "a")
    # Its own session: SIGKILL of the group is a machine that dies.
    p = subprocess.Popen([BIN, "worker", "--db", url, "--store", store, "--data", data,
                          "--slots", "1", "--lease-s", "3", "--job-threads", "1"],
                         stdout=subprocess.PIPE, stderr=log, text=True, start_new_session=True)
    line = p.stdout.readline()
    check("worker with 1 slot" in line, "%s did not start: %r" % (name, line))
    workers[name] = p


def call(port, method, path, body=None, key=None, headers=None, timeout=30):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    h = dict(headers or {})
    if key:
        h["Authorization"] = "Bearer " + key
    if isinstance(body, dict):
        body = json.dumps(body).encode()
        h["Content-Type"] = "application/json"
    c.request(method, path, body=body, headers=h)
    r = c.getresponse()
    data = r.read()
    c.close()
    return r.status, data


def setup():
    global pg, tmp, url, store
    tmp = tempfile.mkdtemp(prefix="infilld-cluster-")
    pg = PgServer()
    url = pg.createdb("cluster")
    store = os.path.join(tmp, "store")
    for t in TENANTS:
        out = subprocess.run([BIN, "tenant", "add", t, "--max-jobs", str(MAX_JOBS), "--db", url,
                              "--store", store, "--data", os.path.join(tmp, "admin")],
                             capture_output=True, text=True, timeout=60)
        check(out.returncode == 0, "tenant add: %s" % out.stderr)
        keys[t] = out.stdout.strip().splitlines()[-1]
    for a in ("api1", "api2"):
        start_api(a)
    with open(FEMUR, "rb") as f:
        body = f.read()
    for i, t in enumerate(TENANTS):
        port = apis["api1" if i % 2 == 0 else "api2"][1]
        st, data = call(port, "POST", "/v1/meshes?format=off&name=femur.off", body, keys[t],
                        {"Content-Type": "application/octet-stream"})
        check(st == 201, "upload: %d %s" % (st, data[:300]))
        mesh[t] = json.loads(data)["id"]


def submit_one(tenant, n, prefer):
    """Submit job n of tenant through API prefer, the other one on a
    connection failure, with the same Idempotency-Key; returns the id."""
    idem = "%s-%d" % (tenant, n)
    body = {"mesh_id": mesh[tenant], "engine": "solid", "format": "sl1", "params": PARAMS}
    order = [prefer, "api2" if prefer == "api1" else "api1"]
    for attempt in range(40):
        name = order[attempt % 2]
        if name not in apis:
            time.sleep(0.05)
            continue
        try:
            st, data = call(apis[name][1], "POST", "/v1/jobs", body, keys[tenant],
                            {"Idempotency-Key": idem})
        except OSError:
            continue  # killed meanwhile: the other server answers the same key
        if st in (200, 202):
            return json.loads(data)["id"], idem
        if st == 503:
            time.sleep(0.1)
            continue
        fail("submit %s: %d %s" % (idem, st, data[:300]))
    fail("submit %s: no API server answered" % idem)


def sampler(stop):
    while not stop.is_set():
        try:
            rows = sql("SELECT t.name, count(*) FROM jobs j JOIN tenants t ON t.id = j.tenant_id"
                       " WHERE j.state = 'running' GROUP BY t.name")
            samples.append({r[0]: int(r[1]) for r in rows})
        except AssertionError:
            pass
        time.sleep(0.2)


def test_cluster_run():
    for w in ("w1", "w2", "w3"):
        start_worker(w)
    stop = threading.Event()
    th = threading.Thread(target=sampler, args=(stop,), daemon=True)
    th.start()
    plan = [("acme", i) for i in range(SHARE["acme"])]
    rest = [(t, i) for i in range(SHARE["bolt"]) for t in ("bolt", "cogs")]
    plan += rest
    killed_api = killed_worker = False
    for k, (t, i) in enumerate(plan):
        jid, idem = submit_one(t, i, "api1" if k % 2 == 0 else "api2")
        check(jid not in acked, "job %s acknowledged twice" % jid)
        acked[jid] = (t, idem)
        if k == 150 and not killed_worker:
            # A machine dies: the worker, its job processes, all at once,
            # while it holds a job (its worker process is HOST-w0-PID).
            pid = workers["w1"].pid
            deadline = time.time() + 60
            while time.time() < deadline and not sql(
                    "SELECT 1 FROM jobs WHERE state = 'running' AND worker LIKE '%%-%d'" % pid):
                time.sleep(0.01)
            os.killpg(pid, signal.SIGKILL)
            workers.pop("w1").wait()
            killed_worker = True
        if k == 250 and not killed_api:
            p, _ = apis.pop("api2")
            p.kill()
            p.wait()
            killed_api = True
        if k == 330:
            start_api("api2")
            start_worker("w1")
    check(len(acked) == JOBS, "acknowledged %d of %d" % (len(acked), JOBS))
    deadline = time.time() + 600
    while time.time() < deadline:
        rows = sql("SELECT state, count(*) FROM jobs GROUP BY state")
        counts = {r[0]: int(r[1]) for r in rows}
        if counts.get("succeeded", 0) + counts.get("failed", 0) + counts.get("cancelled", 0) \
                >= JOBS:
            break
        time.sleep(1)
    stop.set()
    th.join()
    rows = sql("SELECT id, state, attempt, artifact, artifact_sha256 FROM jobs")
    check(len(rows) == JOBS, "the database holds %d jobs, %d were acknowledged"
          % (len(rows), JOBS))
    by_id = {r[0]: r for r in rows}
    missing = [j for j in acked if j not in by_id]
    check(not missing, "acknowledged jobs lost: %s" % missing[:5])
    bad = [r for r in rows if r[1] != "succeeded"]
    check(not bad, "%d job(s) did not succeed, e.g. %s" % (len(bad), bad[:3]))
    # Exactly once: one "succeeded" state event per job.
    ev = sql("SELECT j.id, count(*) FROM job_events e JOIN jobs j ON j.seq = e.job_seq"
             " WHERE e.type = 'state' AND e.data::json->>'state' = 'succeeded' GROUP BY j.id")
    once = {r[0]: int(r[1]) for r in ev}
    twice = [j for j, n in once.items() if n != 1]
    check(not twice and len(once) == JOBS, "succeeded events: %d jobs, %d not exactly once"
          % (len(once), len(twice)))
    retried = sum(1 for r in rows if int(r[2]) > 1)
    print("  %d jobs, %d ran more than one attempt (killed worker's)" % (JOBS, retried))
    check(retried >= 1, "the killed worker held no job: the kill tested nothing")
    test_cluster_run.rows = rows


def members(data):
    """zip members name -> bytes, config.ini's fileCreationTimestamp line
    apart (returned separately)."""
    z = zipfile.ZipFile(io.BytesIO(data))
    out, stamp = {}, None
    for n in z.namelist():
        b = z.read(n)
        if n == "config.ini":
            lines = b.decode().splitlines(True)
            stamp = [x for x in lines if x.startswith("fileCreationTimestamp")]
            b = "".join(x for x in lines if not x.startswith("fileCreationTimestamp")).encode()
        out[n] = b
    return out, stamp


def test_artifacts_identical():
    # The same job on one machine (SQLite serve), for the reference bytes.
    ref = Server(workers=1)
    try:
        ref.start()
        key = ref.add_tenant("ref")
        m = ref.upload(FEMUR, key).json()["id"]
        j = ref.submit(key, m, engine="solid", format="sl1", params=PARAMS).json()
        ref.wait_job(key, j["id"])
        r = ref.request("GET", "/v1/jobs/%s/output" % j["id"], key=key)
        check(r.status == 200, "reference output: %d" % r.status)
        want, _ = members(r.body)
    finally:
        ref.cleanup()
    rows = sql("SELECT j.id, j.tenant_id, j.artifact, j.artifact_sha256, j.created_at FROM jobs j")
    differ = []
    digests = {}
    for jid, tid, name, recorded, created in rows:
        path = os.path.join(store, "tenants", tid, "artifacts", name)
        with open(path, "rb") as f:
            data = f.read()
        got, stamp = members(data)
        when = time.strftime("%Y-%m-%d at %H:%M:%S UTC", time.gmtime(int(created) // 1000))
        if got != want or stamp != ["fileCreationTimestamp = %s\n" % when] or \
                hashlib.sha256(data).hexdigest() != recorded:
            differ.append((jid, sorted(n for n in got if got[n] != want.get(n)), stamp))
        digests[created[:-3]] = digests.get(created[:-3], set()) | {recorded}
    check(not differ, "%d artifact(s) differ from the single-machine run, e.g. %s"
          % (len(differ), differ[:3]))
    # Jobs created in the same second have the same bytes, whichever worker
    # and attempt made them.
    check(all(len(v) == 1 for v in digests.values()), "same second, same bytes")
    # And one of them through each API server (the store is shared).
    t = TENANTS[0]
    jid = next(j for j, (tn, _) in acked.items() if tn == t)
    recorded = sql("SELECT artifact_sha256 FROM jobs WHERE id = '%s'" % jid)[0][0]
    for a in ("api1", "api2"):
        st, body = call(apis[a][1], "GET", "/v1/jobs/%s/output" % jid, key=keys[t])
        check(st == 200 and hashlib.sha256(body).hexdigest() == recorded,
              "download through %s: %d" % (a, st))


def test_rerun_on_one_machine():
    """Byte for byte: the cluster's database copied to SQLite (migrate-db),
    three of its jobs (one re-run after the worker's kill, if any) queued
    again there and run by a single-machine `serve` on the same store: the
    new artifacts are the cluster's, byte for byte (same job, same bytes,
    whichever machine and attempt)."""
    rows = sql("SELECT id, tenant_id, artifact, attempt FROM jobs ORDER BY attempt DESC, seq"
               " LIMIT 3")
    data = tempfile.mkdtemp(prefix="infilld-rerun-", dir=tmp)
    dbfile = os.path.join(data, "infilld.db")
    out = subprocess.run([BIN, "migrate-db", "--from", url, "--to", "sqlite:" + dbfile],
                         capture_output=True, text=True, timeout=300)
    check(out.returncode == 0, "migrate-db: %s" % out.stderr)
    want = {}
    for jid, tid, name, _ in rows:
        with open(os.path.join(store, "tenants", tid, "artifacts", name), "rb") as f:
            want[jid] = f.read()
    con = sqlite3.connect(dbfile)
    with con:
        con.executemany("UPDATE jobs SET state = 'queued', stage = 'queued', artifact = NULL,"
                        " artifact_bytes = NULL, artifact_sha256 = NULL, finished_at = NULL,"
                        " lease_expires = NULL, worker = NULL, run_after = 0 WHERE id = ?",
                        [(r[0],) for r in rows])
    con.close()
    one = Server(workers=1, data=data, extra=["--db", "sqlite:" + dbfile, "--store", store])
    try:
        one.start()
        t = {r[0]: r[1] for r in sql("SELECT id::text, name FROM tenants")}
        for jid, tid, _, attempt in rows:
            key = keys[t[tid]]
            j = one.wait_job(key, jid)
            check(j["state"] == "succeeded", "re-run of %s: %s" % (jid, j["state"]))
            r = one.request("GET", "/v1/jobs/%s/output" % jid, key=key)
            check(r.status == 200 and r.body == want[jid],
                  "job %s (attempt %s in the cluster): the single machine's bytes differ"
                  % (jid, attempt))
    finally:
        one.stop()
    print("  %d jobs re-run on one machine: byte-identical" % len(rows))


def test_cap_and_fairness():
    over = [s for s in samples if any(n > MAX_JOBS for n in s.values())]
    check(samples, "no samples taken")
    check(not over, "a tenant ran more than %d jobs at once: %s" % (MAX_JOBS, over[:3]))
    rows = sql("SELECT t.name, j.created_at, j.started_at FROM jobs j"
               " JOIN tenants t ON t.id = j.tenant_id")
    created = {t: [int(r[1]) for r in rows if r[0] == t] for t in TENANTS}
    started = {t: sorted(int(r[2]) for r in rows if r[0] == t) for t in TENANTS}
    # While every tenant had queued work: from when the last one got its
    # first job in, to when the first one ran its last.
    lo = max(min(c) for c in created.values())
    hi = min(s[-1] for s in started.values())
    claims = {t: sum(1 for x in started[t] if lo <= x <= hi) for t in TENANTS}
    total = sum(claims.values())
    print("  claims while all three had work: %s" % claims)
    check(total >= 60, "window too short to judge fairness: %d claims" % total)
    for t, n in claims.items():
        check(0.25 <= n / total <= 0.42, "tenant %s got %d of %d claims" % (t, n, total))


def test_sse_across_servers():
    """A job submitted through api1, run by some worker, streamed from
    api2: its events reach the stream (LISTEN/NOTIFY) in order to the end."""
    t = "cogs"
    st, data = call(apis["api1"][1], "POST", "/v1/jobs",
                    {"mesh_id": mesh[t], "engine": "solid", "format": "sl1",
                     "params": {"height_mm": 40}}, keys[t])
    check(st == 202, "submit: %d" % st)
    jid = json.loads(data)["id"]
    c = http.client.HTTPConnection("127.0.0.1", apis["api2"][1], timeout=120)
    c.request("GET", "/v1/jobs/%s/events" % jid, headers={"Authorization": "Bearer " + keys[t]})
    r = c.getresponse()
    check(r.status == 200, "events: %d" % r.status)
    ids, states, progress = [], [], 0
    for raw in r:
        line = raw.decode().rstrip("\n")
        if line.startswith("id: "):
            ids.append(int(line[4:]))
        elif line.startswith("data: "):
            d = json.loads(line[6:])
            states.append(d["state"])
            progress = max(progress, d["progress"])
    c.close()
    check(ids == sorted(ids) and len(set(ids)) == len(ids), "event ids in order: %s" % ids)
    check(states[-1] == "succeeded" and "running" in states and progress == 1.0,
          "the stream saw the job run and end: %s" % states)
    print("  %d events streamed from api2 for a job submitted through api1" % len(ids))


def teardown():
    for name, p in list(workers.items()):
        p.send_signal(signal.SIGTERM)
    for name, p in list(workers.items()):
        check(p.wait(60) == 0, "worker %s exit status" % name)
    for name, (p, _) in list(apis.items()):
        p.send_signal(signal.SIGTERM)
        check(p.wait(60) == 0, "API server %s exit status" % name)
    workers.clear()
    apis.clear()


def cleanup():
    for p in workers.values():
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except OSError:
            pass
    for p, _ in apis.values():
        p.kill()
    if pg:
        pg.stop()
    if tmp:
        subprocess.run(["rm", "-rf", tmp])


if __name__ == "__main__":
    try:
        setup()
        run([test_cluster_run, test_artifacts_identical, test_rerun_on_one_machine,
             test_cap_and_fairness,
             test_sse_across_servers, teardown])
    finally:
        cleanup()
