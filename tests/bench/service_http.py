"""service_http.py BIN TMP - HTTP benchmarks of `infilld serve` on loopback:
sustained job submissions/s and status reads/s with wrk (keep-alive,
2 threads, 64 connections, 5 s each), and the download of a 1 GB
artifact with the server's RSS sampled before, during and after."""
import hashlib
import http.client
import json
import os
import re
import sqlite3
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "service"))
from svc import FEMUR, Server  # noqa: E402


def rss_kb(pid):
    with open("/proc/%d/status" % pid) as f:
        return int(re.search(r"VmRSS:\s+(\d+)", f.read()).group(1))


def wrk(url, key, script=None, seconds=5):
    args = ["wrk", "-t2", "-c64", "-d%ds" % seconds, "--latency", "-H", "Authorization: Bearer " + key]
    if script:
        args += ["-s", script]
    out = subprocess.run(args + [url], capture_output=True, text=True, timeout=seconds + 60).stdout
    rps = float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1))
    p99 = re.search(r"99%\s+(\S+)", out)
    non2xx = re.search(r"Non-2xx or 3xx responses: (\d+)", out)
    return rps, p99.group(1) if p99 else "?", int(non2xx.group(1)) if non2xx else 0


def main():
    bin_path, tmp = sys.argv[1], sys.argv[2]
    os.environ["INFILLD_BIN"] = bin_path
    srv = Server(workers=0, data=os.path.join(tmp, "data"),
                 extra=["--http-threads", "4", "--per-ip-connections", "1024"])
    os.makedirs(srv.data, exist_ok=True)
    key = srv.add_tenant("bench", "--max-upload-mb", "100")
    srv.start()
    try:
        mesh = srv.upload(FEMUR, key).json()["id"]
        lua = os.path.join(tmp, "submit.lua")
        with open(lua, "w") as f:
            f.write('wrk.method = "POST"\nwrk.headers["Content-Type"] = "application/json"\n'
                    'wrk.body = \'{"mesh_id": "%s", "params": {"height_mm": 20}}\'\n' % mesh)
        base = "http://127.0.0.1:%d" % srv.port
        rps, p99, bad = wrk(base + "/v1/jobs", key, lua)
        print("submissions: %.0f/s (p99 %s, non-2xx %d; each one fsynced, synchronous=FULL)"
              % (rps, p99, bad))
        jid = srv.json("GET", "/v1/jobs?limit=1", key=key)["jobs"][0]["id"]
        rps, p99, bad = wrk(base + "/v1/jobs/" + jid, key)
        print("status reads: %.0f/s (p99 %s, non-2xx %d)" % (rps, p99, bad))

        # A 1 GB artifact, registered as a finished job's output.
        name = jid + "-a1.sl1"
        tenant_dir = os.path.join(srv.data, "tenants", "1", "artifacts")
        os.makedirs(tenant_dir, exist_ok=True)
        path = os.path.join(tenant_dir, name)
        h = hashlib.sha256()
        block = os.urandom(1 << 20)
        with open(path, "wb") as f:
            for _ in range(1024):
                f.write(block)
                h.update(block)
        db = sqlite3.connect(os.path.join(srv.data, "infilld.db"))
        db.execute("UPDATE jobs SET state='succeeded', artifact=?, artifact_bytes=?, "
                   "artifact_sha256=?, finished_at=1 WHERE id=?",
                   (name, 1 << 30, h.hexdigest(), jid))
        db.commit()
        db.close()
        pid = srv.proc.pid
        before = rss_kb(pid)
        peak = [before]
        done = threading.Event()

        def sample():
            while not done.is_set():
                peak[0] = max(peak[0], rss_kb(pid))
                time.sleep(0.05)
        t = threading.Thread(target=sample)
        t.start()
        c = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=120)
        t0 = time.time()
        c.request("GET", "/v1/jobs/%s/output" % jid, headers={"Authorization": "Bearer " + key})
        r = c.getresponse()
        got = 0
        while True:
            b = r.read(1 << 20)
            if not b:
                break
            got += len(b)
        dt = time.time() - t0
        done.set()
        t.join()
        c.close()
        print("1 GB download: %.0f MB/s (%d bytes in %.2f s, chunked); server RSS %.1f MB before, "
              "peak %.1f MB, growth %.1f MB" % (got / dt / 1e6, got, dt, before / 1024,
                                                 peak[0] / 1024, (peak[0] - before) / 1024))
    finally:
        srv.stop()


if __name__ == "__main__":
    main()
