"""cluster_http.py BIN TMP BENCH_QUEUE - the PostgreSQL figures of
`make bench` (service.sh): bench_queue at 100k queued jobs on a
PostgreSQL started here (tests/support/pgserver.py), then status reads/s
through 2 API servers (`serve --workers 0`) on one database, wrk on both
at once (keep-alive, 2 threads and 64 connections each, 5 s)."""
import http.client
import json
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "support"))
sys.path.insert(0, os.path.join(HERE, "..", "service"))
from pgserver import PgServer  # noqa: E402
from svc import FEMUR, check  # noqa: E402


def start_api(bin_path, url, store, data):
    p = subprocess.Popen([bin_path, "serve", "--listen", "127.0.0.1:0", "--db", url, "--store",
                          store, "--data", data, "--workers", "0", "--http-threads", "4",
                          "--per-ip-connections", "1024"],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    line = p.stdout.readline()
    m = re.search(r"127\.0\.0\.1:(\d+)", line)
    check(m, "API server did not start: %r" % line)
    return p, int(m.group(1))


def main():
    bin_path, tmp, bench_queue = sys.argv[1:4]
    pg = PgServer()
    procs = []
    try:
        subprocess.run([bench_queue, pg.createdb("bench_queue"), "100000"], check=True)
        url = pg.createdb("bench_http")
        store = os.path.join(tmp, "pg-store")
        key = subprocess.run([bin_path, "tenant", "add", "bench", "--db", url, "--store", store,
                              "--data", os.path.join(tmp, "pg-admin")], capture_output=True,
                             text=True, check=True).stdout.strip().splitlines()[-1]
        for k in (1, 2):
            procs.append(start_api(bin_path, url, store, os.path.join(tmp, "pg-api%d" % k)))
        c = http.client.HTTPConnection("127.0.0.1", procs[0][1], timeout=30)
        with open(FEMUR, "rb") as f:
            c.request("POST", "/v1/meshes?format=off&name=femur.off", f.read(),
                      {"Authorization": "Bearer " + key,
                       "Content-Type": "application/octet-stream"})
        mesh = json.loads(c.getresponse().read())["id"]
        c.request("POST", "/v1/jobs", json.dumps({"mesh_id": mesh}),
                  {"Authorization": "Bearer " + key, "Content-Type": "application/json"})
        job = json.loads(c.getresponse().read())["id"]
        c.close()
        runs = [subprocess.Popen(["wrk", "-t2", "-c64", "-d5s", "-H", "Authorization: Bearer " + key,
                                  "http://127.0.0.1:%d/v1/jobs/%s" % (port, job)],
                                 stdout=subprocess.PIPE, text=True) for _, port in procs]
        rps = []
        for r in runs:
            out = r.communicate(timeout=60)[0]
            rps.append(float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1)))
            bad = re.search(r"Non-2xx or 3xx responses: (\d+)", out)
            check(not bad, "non-2xx answers: %s" % (bad.group(1) if bad else ""))
        print("status reads/s through 2 API servers on one PostgreSQL: %.0f (%.0f + %.0f)"
              % (sum(rps), rps[0], rps[1]))
    finally:
        for p, _ in procs:
            p.terminate()
            p.wait(30)
        pg.stop()


if __name__ == "__main__":
    main()
