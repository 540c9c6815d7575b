"""The PostgreSQL backend (db/pg/) on a real server started here
(tests/support/pgserver.py): the unit program tests/unit/db/test_db runs
its backend-independent cases on it (INFILLD_TEST_DB_URL), test_db_pg its
PostgreSQL-only ones (concurrent claims from many connections, races on an
idempotency key, a quota and the migrations, LISTEN/NOTIFY, a killed
connection), and a restart test: connections opened before the server
restarts (fast shutdown) work after it, the listener included."""
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "support"))
from pgserver import PgServer  # noqa: E402

BUILD = os.environ.get("INFILLD_BUILD", os.path.join(HERE, "..", "..", "build"))
UNIT = os.path.join(BUILD, "tests", "unit", "db")


def fail(msg, pg):
    print("FAIL: " + msg)
    if pg and pg.dir and os.path.exists(pg.log):
        with open(pg.log, errors="replace") as f:
            print("server log (tail):\n" + f.read()[-3000:])
    sys.exit(1)


def run_unit(pg, name, url):
    env = dict(os.environ, INFILLD_TEST_DB_URL=url, HARNESS_VERBOSE="1")
    r = subprocess.run([os.path.join(UNIT, name)], env=env, timeout=600)
    if r.returncode != 0:
        fail("%s on PostgreSQL exited %d" % (name, r.returncode), pg)
    print("ok %s on PostgreSQL" % name)


def restart_test(pg, url):
    env = dict(os.environ, INFILLD_TEST_DB_URL=url)
    p = subprocess.Popen([os.path.join(UNIT, "test_db_pg"), "restart"], env=env,
                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        line = p.stdout.readline()
        if line.strip() != "ready":
            fail("restart phase did not get ready: %r" % line, pg)
        pg.restart()
        p.stdin.write("go\n")
        p.stdin.flush()
        rc = p.wait(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    if rc != 0:
        fail("connections did not recover from a server restart (exit %d)" % rc, pg)
    print("ok connections recover from a server restart")


def main():
    pg = PgServer()
    try:
        run_unit(pg, "test_db", pg.createdb("unit_db"))
        run_unit(pg, "test_db_pg", pg.createdb("unit_db_pg"))
        restart_test(pg, pg.createdb("restart"))
    finally:
        pg.stop()
    print("PASS")


if __name__ == "__main__":
    main()
