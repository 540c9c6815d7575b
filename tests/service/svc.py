"""svc.py - helpers for the service tests: start the real `infilld serve`
on loopback (ephemeral port, temp data directory, a real SQLite file, or
with INFILLD_TEST_BACKEND=postgresql a database of its own in a real
PostgreSQL started for the test process by tests/support/pgserver.py),
make tenants with the real CLI, talk HTTP with http.client, read SSE, and
check responses against openapi.yaml's schemas (oas.py).  Stdlib only."""
import atexit
import http.client
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
SHARED = os.environ.get("INFILLD_SHARED", os.path.join(ROOT, "..", "shared"))
FEMUR = os.path.join(SHARED, "meshes", "femur.off")


BACKEND = os.environ.get("INFILLD_TEST_BACKEND", "sqlite")
_pg = None
_dbs = {}


def db_url_for(data):
    """The --db of a data directory: None (serve's SQLite default) or, on
    the PostgreSQL backend, a fresh database per data directory (kept for
    a Server restarted on the same directory)."""
    global _pg
    if BACKEND != "postgresql":
        return None
    if _pg is None:
        sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                                        "support"))
        from pgserver import PgServer
        _pg = PgServer()
        atexit.register(_pg.stop)
    if data not in _dbs:
        _dbs[data] = _pg.createdb("t%d" % (len(_dbs) + 1))
    return _dbs[data]


def fail(msg):
    raise AssertionError(msg)


def check(cond, msg):
    if not cond:
        fail(msg)


class Server:
    """One `infilld serve` with its own data directory."""

    def __init__(self, workers=1, extra=(), env=None, data=None):
        self.own_data = data is None
        self.data = data or tempfile.mkdtemp(prefix="infilld-svc-")
        self.workers = workers
        self.extra = list(extra)
        self.env = dict(os.environ)
        self.env.update(env or {})
        self.proc = None
        self.port = None
        self.log_path = os.path.join(self.data, "serve.log")
        self.db_url = db_url_for(self.data)
        self.db_args = ["--db", self.db_url] if self.db_url else []

    def cli(self, *args):
        """Run an infilld sub-command on this data directory; stdout."""
        out = subprocess.run([BIN, *args, "--data", self.data, *self.db_args],
                             capture_output=True, text=True, timeout=60)
        if out.returncode != 0:
            fail("infilld %s failed (%d): %s" % (" ".join(args), out.returncode, out.stderr))
        return out.stdout

    def add_tenant(self, name, *opts):
        """Create a tenant; its key is alone on the last line of stdout."""
        return self.cli("tenant", "add", name, *opts).strip().splitlines()[-1]

    def admin_key(self):
        return self.cli("admin-key").strip().splitlines()[-1]

    def start(self, port=0):
        log = open(self.log_path, "a")
        self.proc = subprocess.Popen(
            [BIN, "serve", "--listen", "127.0.0.1:%d" % port, "--data", self.data,
             *self.db_args, "--workers", str(self.workers), *self.extra],
            stdout=subprocess.PIPE, stderr=log, text=True, env=self.env)
        line = self.proc.stdout.readline()
        m = re.search(r"listening on http://127\.0\.0\.1:(\d+)", line)
        if not m:
            self.proc.kill()
            fail("serve did not start: %r\n%s" % (line, self.log()))
        self.port = int(m.group(1))
        return self

    def log(self):
        try:
            with open(self.log_path, errors="replace") as f:
                return f.read()[-4000:]
        except OSError:
            return ""

    def stop(self, sig=signal.SIGTERM, timeout=60):
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc and self.proc.stdout:
            self.proc.stdout.close()
        rc = self.proc.returncode if self.proc else 0
        self.proc = None
        return rc

    def cleanup(self):
        self.stop()
        if self.own_data:
            shutil.rmtree(self.data, ignore_errors=True)

    def worker_pids(self):
        """pids of this server's worker processes (children running `worker`)."""
        pids = []
        for pid in os.listdir("/proc"):
            if not pid.isdigit():
                continue
            try:
                with open("/proc/%s/stat" % pid) as f:
                    ppid = int(f.read().rsplit(")", 1)[1].split()[1])
                with open("/proc/%s/cmdline" % pid, "rb") as f:
                    cmd = f.read().split(b"\0")
            except (OSError, IndexError, ValueError):
                continue
            if ppid == self.proc.pid and len(cmd) > 1 and cmd[1] == b"worker":
                pids.append((int(pid), cmd))
        return pids

    # ---- HTTP ----
    def request(self, method, path, body=None, headers=None, key=None, timeout=60):
        c = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)
        h = dict(headers or {})
        if key:
            h["Authorization"] = "Bearer " + key
        if isinstance(body, (dict, list)):
            body = json.dumps(body).encode()
            h.setdefault("Content-Type", "application/json")
        c.request(method, path, body=body, headers=h)
        r = c.getresponse()
        data = r.read()
        c.close()
        return Resp(r.status, r.getheaders(), data)

    def json(self, method, path, body=None, key=None, expect=200, headers=None):
        r = self.request(method, path, body, headers, key)
        if r.status != expect:
            fail("%s %s: expected %d, got %d: %s" % (method, path, expect, r.status,
                                                     r.body[:600]))
        return r.json() if r.body else None

    def upload(self, path, key, fmt=None, expect=201, **query):
        with open(path, "rb") as f:
            data = f.read()
        q = dict(query)
        q.setdefault("format", fmt or os.path.splitext(path)[1][1:])
        q.setdefault("name", os.path.basename(path))
        qs = "&".join("%s=%s" % kv for kv in q.items())
        r = self.request("POST", "/v1/meshes?" + qs, data,
                         {"Content-Type": "application/octet-stream"}, key)
        if r.status != expect:
            fail("upload %s: expected %d, got %d: %s" % (path, expect, r.status, r.body[:600]))
        return r

    def submit(self, key, mesh_id, expect=202, headers=None, **fields):
        body = {"mesh_id": mesh_id}
        body.update(fields)
        r = self.request("POST", "/v1/jobs", body, headers, key)
        if r.status != expect:
            fail("submit: expected %d, got %d: %s" % (expect, r.status, r.body[:600]))
        return r

    def wait_job(self, key, job_id, states=("succeeded", "failed", "cancelled"), timeout=120):
        deadline = time.time() + timeout
        while time.time() < deadline:
            j = self.json("GET", "/v1/jobs/" + job_id, key=key)
            if j["state"] in states:
                return j
            time.sleep(0.1)
        fail("job %s did not reach %s in %ds (last %s)\n%s" % (job_id, states, timeout, j,
                                                              self.log()))

    def events(self, key, job_id, last_event_id=None, timeout=120):
        """Read the SSE stream to its end: list of (id, event, data)."""
        c = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)
        h = {"Authorization": "Bearer " + key, "Accept": "text/event-stream"}
        if last_event_id is not None:
            h["Last-Event-ID"] = str(last_event_id)
        c.request("GET", "/v1/jobs/%s/events" % job_id, headers=h)
        r = c.getresponse()
        check(r.status == 200, "events: status %d" % r.status)
        check(r.getheader("Content-Type") == "text/event-stream", "events content type")
        out, cur = [], {}
        for raw in r:
            line = raw.decode().rstrip("\n")
            if line == "":
                if "data" in cur:
                    out.append((int(cur.get("id", 0)), cur.get("event", "message"),
                                json.loads(cur["data"])))
                cur = {}
            elif line.startswith(":"):
                continue
            else:
                k, _, v = line.partition(": ")
                cur[k] = v
        c.close()
        return out


class Resp:
    def __init__(self, status, headers, body):
        self.status = status
        self.headers = {k.lower(): v for k, v in headers}
        self.body = body

    def header(self, name):
        return self.headers.get(name.lower())

    def json(self):
        return json.loads(self.body)

    def problem(self, status, type_slug=None):
        """Assert an RFC 9457 problem response; return it."""
        check(self.status == status, "expected %d, got %d: %s" % (status, self.status,
                                                                self.body[:400]))
        check(self.header("Content-Type") == "application/problem+json",
              "problem content type: %s" % self.header("Content-Type"))
        p = self.json()
        for k in ("type", "title", "status", "detail"):
            check(k in p, "problem lacks %s: %s" % (k, p))
        check(p["status"] == status, "problem status field")
        if type_slug:
            check(p["type"] == "/problems/" + type_slug, "problem type %s, want %s" %
                  (p["type"], type_slug))
        return p


def run(tests):
    """Run test functions in order; exit non-zero when one fails."""
    failed = 0
    for t in tests:
        start = time.time()
        try:
            t()
            print("ok   %-40s %.1fs" % (t.__name__, time.time() - start), flush=True)
        except Exception as e:  # report and continue with the next test
            failed += 1
            print("FAIL %-40s %s: %s" % (t.__name__, type(e).__name__, e), flush=True)
            import traceback
            traceback.print_exc()
    print("%d passed, %d failed" % (len(tests) - failed, failed))
    sys.exit(1 if failed else 0)
