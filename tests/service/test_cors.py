"""serve --cors-origin ORIGIN: responses to ORIGIN's requests carry
Access-Control-Allow-Origin and expose the headers clients read; an
OPTIONS preflight answers 204 with the route's methods and the request
headers the API takes; another origin gets no CORS header; without the
option OPTIONS is 405 and nothing CORS is sent; a malformed origin is a
usage error."""
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import BIN, Server, check, run  # noqa: E402

ORIGIN = "http://portal.example:8443"
srv = Server(workers=0, extra=["--cors-origin", ORIGIN])
S = {}


def setup():
    S["key"] = srv.add_tenant("alpha")
    srv.start()


def test_preflight():
    r = srv.request("OPTIONS", "/v1/jobs", headers={
        "Origin": ORIGIN, "Access-Control-Request-Method": "POST",
        "Access-Control-Request-Headers": "authorization, content-type"})
    check(r.status == 204, "preflight 204, got %d: %s" % (r.status, r.body[:200]))
    check(r.header("Access-Control-Allow-Origin") == ORIGIN, "allow origin")
    methods = r.header("Access-Control-Allow-Methods") or ""
    check("POST" in methods and "GET" in methods, "methods %s" % methods)
    allowed = (r.header("Access-Control-Allow-Headers") or "").lower()
    for h in ("authorization", "content-type", "idempotency-key", "last-event-id"):
        check(h in allowed, "%s allowed: %s" % (h, allowed))
    r = srv.request("OPTIONS", "/v1/jobs/j_aaaaaaaaaaaaaaaaaaaa/layers/3", headers={"Origin": ORIGIN})
    check(r.status == 204 and "GET" in r.header("Access-Control-Allow-Methods"), "layer preflight")
    r = srv.request("OPTIONS", "/v1/jobs", headers={"Origin": "http://evil.example"})
    check(r.header("Access-Control-Allow-Origin") is None, "no CORS for another origin")
    srv.request("OPTIONS", "/nowhere", headers={"Origin": ORIGIN}).problem(404, "not-found")


def test_simple_requests():
    r = srv.request("GET", "/v1/jobs", key=S["key"], headers={"Origin": ORIGIN})
    check(r.status == 200 and r.header("Access-Control-Allow-Origin") == ORIGIN, "ACAO on 200")
    check("X-Layer-Count" in (r.header("Access-Control-Expose-Headers") or ""), "exposed headers")
    check("Origin" in (r.header("Vary") or ""), "Vary: Origin")
    r = srv.request("GET", "/v1/jobs", headers={"Origin": ORIGIN})
    check(r.status == 401 and r.header("Access-Control-Allow-Origin") == ORIGIN,
          "a problem is readable by the portal too")
    r = srv.request("GET", "/v1/jobs", key=S["key"], headers={"Origin": "http://evil.example"})
    check(r.header("Access-Control-Allow-Origin") is None, "no ACAO for another origin")


def test_off_by_default():
    plain = Server(workers=0)
    try:
        plain.start()
        r = plain.request("OPTIONS", "/v1/jobs", headers={"Origin": ORIGIN})
        r.problem(405, "method-not-allowed")
        check(r.header("Access-Control-Allow-Origin") is None, "no CORS header")
        r = plain.request("GET", "/livez", headers={"Origin": ORIGIN})
        check(r.header("Access-Control-Allow-Origin") is None and r.header("Vary") is None,
              "no CORS on plain responses")
    finally:
        plain.cleanup()


def test_bad_origin():
    for bad in ("portal.example", "http://portal.example/path", "ftp://x", "http://"):
        out = subprocess.run([BIN, "serve", "--cors-origin", bad, "--data", srv.data],
                             capture_output=True, text=True, timeout=30)
        check(out.returncode == 2 and "--cors-origin" in out.stderr, "%s refused: %s" %
              (bad, out.stderr))


if __name__ == "__main__":
    try:
        setup()
        run([test_preflight, test_simple_requests, test_off_by_default, test_bad_origin])
    finally:
        srv.cleanup()
