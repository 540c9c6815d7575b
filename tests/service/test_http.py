"""HTTP hardening, with raw sockets against the real server: slow request
heads wait in the head gate and get 408 at the deadline while others are
served; a kept-alive connection whose next head trickles is closed at the
same deadline; slow bodies are cut off; a full server answers 503 with
Retry-After; conflicting message framing gets 400/501; problems carry
exactly one Content-Type."""
import os
import socket
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import Server, check, run  # noqa: E402

# A small connection limit keeps the attacks small.
srv = Server(workers=1, extra=["--max-connections", "16", "--per-ip-connections", "8",
                               "--head-timeout-s", "2", "--conn-timeout-s", "30",
                               "--min-body-rate-kbps", "80", "--body-grace-s", "1",
                               "--http-threads", "2"])
S = {}


def setup():
    S["key"] = srv.add_tenant("h")
    srv.start()


def connect(src="127.0.0.1", timeout=10):
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.settimeout(timeout)
    s.bind((src, 0))
    s.connect(("127.0.0.1", srv.port))
    return s


def read_all(s, limit=10.0):
    """Everything until the server closes (or limit seconds)."""
    s.settimeout(limit)
    out = b""
    end = time.time() + limit
    try:
        while time.time() < end:
            b = s.recv(65536)
            if not b:
                break
            out += b
    except (socket.timeout, ConnectionResetError):
        pass
    return out


def raw(data, limit=5.0):
    s = connect()
    s.sendall(data)
    got = read_all(s, limit)
    s.close()
    return got


def head_fields(resp):
    head = resp.split(b"\r\n\r\n", 1)[0].decode(errors="replace").split("\r\n")
    return head[0], [tuple(x.split(": ", 1)) for x in head[1:] if ": " in x]


def timed_livez():
    t0 = time.time()
    r = srv.request("GET", "/livez", timeout=10)
    return r.status, time.time() - t0


def test_slow_heads():
    """300 slow heads from 5 addresses (the limit is 16 connections): /livez
    stays fast, each slow head gets 408 at the 2 s deadline and is closed."""
    socks = []
    t0 = time.time()
    for i in range(300):
        s = connect("127.0.0.%d" % (2 + i % 5))
        s.sendall(b"GET /v1/jobs HTTP/1.1\r\nHost: x\r\n")
        socks.append(s)
    for s in socks[:100]:
        s.sendall(b"X-Slow: 1\r\n")  # a header line now and then
    worst = 0.0
    for _ in range(5):
        st, dt = timed_livez()
        check(st == 200, "livez during the attack: %d" % st)
        worst = max(worst, dt)
    check(worst < 2.0, "livez took %.2f s under the attack" % worst)
    print("     /livez under 300 slow heads: worst of 5 %.3f s" % worst)
    got408 = 0
    for s in socks:
        data = read_all(s, 8)
        got408 += data.startswith(b"HTTP/1.1 408")
        s.close()
    took = time.time() - t0
    check(got408 == len(socks), "408 for %d of %d slow heads" % (got408, len(socks)))
    check(took < 6, "slow heads closed after %.1f s (deadline 2 s)" % took)


def read_response(s, limit=5.0):
    """One whole response (head and Content-Length body) off a kept-alive
    socket."""
    s.settimeout(limit)
    data = b""
    while b"\r\n\r\n" not in data:
        b = s.recv(65536)
        if not b:
            raise AssertionError("closed before a response: %r" % data)
        data += b
    head, body = data.split(b"\r\n\r\n", 1)
    n = 0
    for line in head.split(b"\r\n")[1:]:
        k, _, v = line.partition(b":")
        if k.strip().lower() == b"content-length":
            n = int(v)
    while len(body) < n:
        body += s.recv(65536)
    return head.decode(errors="replace")


def metric(name):
    for line in srv.request("GET", "/metrics").body.decode().splitlines():
        if line.startswith(name + " "):
            return float(line.split()[1])
    raise AssertionError("no metric " + name)


def test_slow_keepalive_heads():
    """10 kept-alive connections from 5 addresses (under 3/4 of the limit,
    so responses do not say Connection: close) each trickle their second
    request's head, a line every 0.4 s: each is closed at the 2 s head
    deadline (MHD's 30 s --conn-timeout-s alone never fires, the line
    keeps it busy), while /livez stays fast and a kept-alive client that
    sends its next request in time is served on the same connection."""
    before = metric("infilld_http_keepalive_closed_total")
    socks = []
    for i in range(10):
        s = connect("127.0.0.%d" % (20 + i % 5))
        s.sendall(b"GET /livez HTTP/1.1\r\nHost: x\r\n\r\n")
        head = read_response(s)
        check(head.startswith("HTTP/1.1 200") and "Connection: close" not in head,
              "first request kept alive: %r" % head[:80])
        s.sendall(b"GET /livez HTTP/1.1\r\n")
        socks.append(s)
    t0 = time.time()
    good = connect("127.0.0.30")
    good.sendall(b"GET /livez HTTP/1.1\r\nHost: x\r\n\r\n")
    read_response(good)
    time.sleep(1.0)  # idle, but inside the deadline
    good.sendall(b"GET /livez HTTP/1.1\r\nHost: x\r\n\r\n")
    check(read_response(good).startswith("HTTP/1.1 200"), "prompt second request served")
    good.close()
    open_ = list(socks)
    closed_at = {}
    worst = 0.0
    while open_ and time.time() - t0 < 12:
        for s in list(open_):
            try:
                s.sendall(b"X-Slow: 1\r\n")
                s.settimeout(0.01)
                if s.recv(4096) == b"":
                    raise ConnectionResetError
            except socket.timeout:
                continue
            except (BrokenPipeError, ConnectionResetError, OSError):
                closed_at[s] = time.time() - t0
                open_.remove(s)
        st, dt = timed_livez()
        check(st == 200, "livez during the attack: %d" % st)
        worst = max(worst, dt)
        time.sleep(0.4)
    for s in socks:
        s.close()
    check(not open_, "%d of 10 trickling keep-alive heads still open after 12 s" % len(open_))
    late = max(closed_at.values())
    check(late < 4.5, "trickling keep-alive heads closed after %.1f s (deadline 2 s)" % late)
    check(worst < 2.0, "livez took %.2f s under the attack" % worst)
    after = metric("infilld_http_keepalive_closed_total")
    check(after - before >= 10, "keepalive_closed counted %d" % (after - before))
    print("     10 trickling keep-alive heads closed after %.1f-%.1f s; /livez worst %.3f s"
          % (min(closed_at.values()), late, worst))


def test_slow_body():
    """A body trickling at 500 B/s (minimum 10 kB/s after 1 s) is cut off."""
    s = connect()
    s.sendall(("POST /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\n"
               "Content-Type: application/json\r\nContent-Length: 100000\r\n\r\n" %
               S["key"]).encode())
    t0 = time.time()
    closed = False
    try:
        while time.time() - t0 < 6:
            s.sendall(b" " * 100)
            time.sleep(0.2)
    except (BrokenPipeError, ConnectionResetError):
        closed = True
    if not closed:
        s.settimeout(0.5)
        try:
            closed = s.recv(100) == b""
        except (socket.timeout, ConnectionResetError):
            closed = False
    s.close()
    check(closed, "slow body not cut off after %.1f s" % (time.time() - t0))
    check(time.time() - t0 < 5, "slow body cut off after %.1f s" % (time.time() - t0))


def test_framing():
    """Request smuggling: conflicting framing gets an error and a close, and
    what follows the head never runs as a second request."""
    smuggled = b"GET /v1/nothing HTTP/1.1\r\nHost: x\r\n\r\n"
    cases = [
        (b"Content-Length: 5\r\nContent-Length: 40\r\n", b"400"),
        (b"Content-Length: 5, 40\r\n", b"400"),
        (b"Content-Length: 5x\r\n", b"400"),
        (b"Content-Length : 5\r\n", b"400"),
        (b"Transfer-Encoding: chunked\r\nContent-Length: 5\r\n", b"400"),
        (b"Transfer-Encoding: chunked, chunked\r\n", b"400"),
        (b"Transfer-Encoding: chunked\r\nTransfer-Encoding: chunked\r\n", b"400"),
        (b"Transfer-Encoding: gzip\r\n", b"501"),
        (b"Transfer-Encoding: gzip, chunked\r\n", b"501"),
    ]
    for fields, code in cases:
        t0 = time.time()
        got = raw(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " +
                  S["key"].encode() + b"\r\nContent-Type: application/json\r\n" + fields +
                  b"\r\n{}\r\n" + smuggled, limit=5)
        check(got.startswith(b"HTTP/1.1 " + code), "%r: %r" % (fields, got[:120]))
        check(got.count(b"HTTP/1.1 ") == 1, "%r: one answer only: %r" % (fields, got))
        check(time.time() - t0 < 3, "%r: answered and closed at once" % fields)
        line, hdrs = head_fields(got)
        check(("Connection", "close") in hdrs, "%r: Connection: close" % fields)
        check(("Content-Type", "application/problem+json") in hdrs, "problem body")
    # A head past 32 KiB: 431, without waiting for its end.
    got = raw(b"GET /livez HTTP/1.1\r\nHost: x\r\n" + b"X-Big: " + b"a" * 40000, limit=5)
    check(got.startswith(b"HTTP/1.1 431"), "oversize head: %r" % got[:80])
    # Identical repeated values are one value (RFC 9110 section 8.6).
    got = raw(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " +
              S["key"].encode() + b"\r\nContent-Type: application/json\r\n"
              b"Content-Length: 2\r\nContent-Length: 2\r\nConnection: close\r\n\r\n{}", 5)
    check(got.startswith(b"HTTP/1.1 422"), "repeated equal Content-Length: %r" % got[:80])


def test_one_content_type():
    """Every problem carries exactly one Content-Type, application/problem+json."""
    for path, key in (("/v1/nothing", S["key"]), ("/v1/jobs", None), ("/v1/jobs/j_x", S["key"])):
        got = raw(("GET %s HTTP/1.1\r\nHost: x\r\n%sConnection: close\r\n\r\n" %
                   (path, "Authorization: Bearer %s\r\n" % key if key else "")).encode())
        line, hdrs = head_fields(got)
        types = [v for k, v in hdrs if k.lower() == "content-type"]
        check(types == ["application/problem+json"], "%s: %s %s" % (path, line, types))


def hold(src, n):
    """n connections from src that each hold a libmicrohttpd slot (a whole
    head, then a body that does not come)."""
    socks = []
    for _ in range(n):
        s = connect(src)
        s.sendall(("POST /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\n"
                   "Content-Type: application/json\r\nContent-Length: 100\r\n\r\n" %
                   S["key"]).encode())
        socks.append(s)
    time.sleep(0.3)
    return socks


def get_from(src, path):
    s = connect(src)
    s.sendall(("GET %s HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n" % path).encode())
    got = read_all(s, 5)
    s.close()
    return got


def test_limits_answer_503():
    """At the per-address and total limits, new clients get 503 with
    Retry-After (not a silent close); probes still answer."""
    held = hold("127.0.0.9", 8)  # --per-ip-connections 8
    got = get_from("127.0.0.9", "/v1/engines")
    line, hdrs = head_fields(got)
    check(line.startswith("HTTP/1.1 503"), "per-address limit: %r" % got[:100])
    check(any(k == "Retry-After" for k, _ in hdrs), "Retry-After at the per-address limit")
    check(b"/problems/unavailable" in got, "problem body")
    held += hold("127.0.0.10", 8)  # 16 = --max-connections
    got = get_from("127.0.0.11", "/v1/engines")
    line, hdrs = head_fields(got)
    check(line.startswith("HTTP/1.1 503"), "connection limit: %r" % got[:100])
    check(("Retry-After", "2") in hdrs, "Retry-After at the limit")
    check(get_from("127.0.0.11", "/livez").startswith(b"HTTP/1.1 200"), "probes use the reserve")
    for s in held:
        s.close()
    time.sleep(0.5)
    check(get_from("127.0.0.9", "/livez").startswith(b"HTTP/1.1 200"), "slots released")
    got = get_from("127.0.0.11", "/v1/engines")
    check(got.startswith(b"HTTP/1.1 401"), "served again after the limit: %r" % got[:60])


def teardown():
    srv.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_slow_heads, test_slow_keepalive_heads, test_slow_body, test_framing, test_one_content_type,
             test_limits_answer_503, teardown])
    finally:
        srv.cleanup()
