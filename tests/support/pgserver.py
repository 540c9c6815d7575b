"""pgserver.py - a throwaway PostgreSQL server for the tests.

PgServer() runs Debian's PostgreSQL (initdb + pg_ctl, version 15 preferred)
in a fresh temporary directory, listening only on a Unix socket in that
directory (no TCP port, so parallel tests never collide), fsync on.  initdb
refuses to run as root: as root the directory is given to user `nobody`
and the server runs as it (runuser); otherwise as the current user.  The
superuser is "infilld" with trust authentication (only this machine's
processes that can reach the socket directory can connect).

    pg = PgServer()
    url = pg.createdb("test")   # postgresql:///test?host=DIR&user=infilld
    pg.restart()                # fast shutdown + start: clients' connections break
    pg.stop()                   # also at exit, and on SIGTERM

stop() removes the directory; it runs at interpreter exit (atexit) and on
SIGTERM (tests/run.sh's timeout), so a failing test leaves no server behind.
"""
import atexit
import glob
import os
import pwd
import shutil
import signal
import subprocess
import sys
import tempfile

SUPERUSER = "infilld"


def _bindir():
    env = os.environ.get("INFILLD_PG_BINDIR")
    if env:
        return env
    dirs = sorted(glob.glob("/usr/lib/postgresql/*/bin"),
                  key=lambda d: int(d.split("/")[-2]) if d.split("/")[-2].isdigit() else 0)
    for d in ["/usr/lib/postgresql/15/bin"] + dirs[::-1]:
        if os.path.exists(os.path.join(d, "initdb")):
            return d
    initdb = shutil.which("initdb")
    if initdb:
        return os.path.dirname(initdb)
    raise RuntimeError("PostgreSQL server binaries not found (apt-get install postgresql)")


class PgServer:
    def __init__(self, log_to=None):
        self.bindir = _bindir()
        self.dir = tempfile.mkdtemp(prefix="infilld-pg-")
        self.data = os.path.join(self.dir, "data")
        self.log = os.path.join(self.dir, "server.log")
        self.running = False
        self.user = None
        if os.geteuid() == 0:
            self.user = "nobody"
            pw = pwd.getpwnam(self.user)
            os.chown(self.dir, pw.pw_uid, pw.pw_gid)
        os.chmod(self.dir, 0o700)
        atexit.register(self.stop)
        if signal.getsignal(signal.SIGTERM) in (signal.SIG_DFL, None):
            signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
        try:
            self._run("initdb", "-D", self.data, "-U", SUPERUSER, "--auth=trust", "-E", "UTF8",
                      "--locale=C.UTF-8", "--no-sync")
            self.start()
        except BaseException:
            self.stop()
            raise

    def _run(self, tool, *args, check=True):
        cmd = [os.path.join(self.bindir, tool)] + list(args)
        if self.user:
            cmd = ["runuser", "-u", self.user, "--"] + cmd
        r = subprocess.run(cmd, cwd=self.dir, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True)
        if check and r.returncode != 0:
            tail = ""
            if os.path.exists(self.log):
                with open(self.log, errors="replace") as f:
                    tail = f.read()[-2000:]
            raise RuntimeError("%s failed (%d): %s\n%s" % (tool, r.returncode, r.stdout, tail))
        return r

    def start(self):
        opts = "-c listen_addresses='' -c unix_socket_directories='%s' -c fsync=on" % self.dir
        self._run("pg_ctl", "-D", self.data, "-l", self.log, "-w", "-t", "60", "-o", opts,
                  "start")
        self.running = True

    def restart(self):
        """Fast shutdown (clients' connections break) and start again."""
        self._run("pg_ctl", "-D", self.data, "-m", "fast", "-w", "stop")
        self.running = False
        self.start()

    def url(self, db):
        return "postgresql:///%s?host=%s&user=%s" % (db, self.dir, SUPERUSER)

    def createdb(self, name):
        """Create database name (fresh) and return its URL."""
        self._run("createdb", "-h", self.dir, "-U", SUPERUSER, name)
        return self.url(name)

    def psql(self, db, sql):
        """Run sql in database db; its output."""
        return self._run("psql", "-X", "-q", "-A", "-t", "-v", "ON_ERROR_STOP=1", "-h", self.dir,
                         "-U", SUPERUSER, "-d", db, "-c", sql).stdout

    def stop(self):
        if self.running:
            self._run("pg_ctl", "-D", self.data, "-m", "fast", "-w", "stop", check=False)
            self.running = False
        if self.dir and os.path.isdir(self.dir):
            shutil.rmtree(self.dir, ignore_errors=True)
        self.dir = None
