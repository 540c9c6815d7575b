"""deploy/: the systemd unit's ExecStart line and the container's
ENTRYPOINT start this very binary (paths mapped to a temp directory,
port 0), answer /livez and stop cleanly on SIGTERM; deploy/run-dev.sh
(`make run`) prints the URL and an admin hint and makes a working admin key."""
import http.client
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import BIN, ROOT, check, run  # noqa: E402


def start_and_probe(argv, env=None):
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                         env=env)
    try:
        lines = []
        while True:
            line = p.stdout.readline()
            check(line, "no 'listening' line; got %r" % lines)
            lines.append(line)
            m = re.search(r"listening on http://127\.0\.0\.1:(\d+)", line)
            if m:
                break
        c = http.client.HTTPConnection("127.0.0.1", int(m.group(1)), timeout=10)
        c.request("GET", "/livez")
        check(c.getresponse().status == 200, "livez")
        c.close()
        return lines
    finally:
        p.send_signal(signal.SIGTERM)
        rc = p.wait(60)
        p.stdout.close()
        check(rc == 0, "SIGTERM exit status %d" % rc)


def test_systemd_execstart():
    with open(os.path.join(ROOT, "deploy", "infilld.service")) as f:
        unit = f.read()
    line = re.search(r"^ExecStart=(.*)$", unit, re.M).group(1)
    d = tempfile.mkdtemp(prefix="infilld-unit-")
    argv = [a.replace("/usr/local/bin/infilld", BIN).replace("/var/lib/infilld", d)
            .replace("127.0.0.1:8080", "127.0.0.1:0") for a in shlex.split(line)]
    check(argv[0] == BIN and argv[1] == "serve", "ExecStart runs serve: %s" % line)
    try:
        start_and_probe(argv + ["--workers", "1"])
        check(os.path.exists(os.path.join(d, "infilld.db")), "state in StateDirectory")
    finally:
        shutil.rmtree(d, ignore_errors=True)
    for key in ("NoNewPrivileges=yes", "ProtectSystem=strict", "DynamicUser=yes",
                "StateDirectory=infilld"):
        check(key in unit, "unit has %s" % key)


def test_container_entrypoint():
    with open(os.path.join(ROOT, "deploy", "Dockerfile")) as f:
        df = f.read()
    ep = re.search(r'^ENTRYPOINT \[(.*)\]$', df, re.M).group(1)
    argv = [a.strip().strip('"') for a in ep.split(",")]
    d = tempfile.mkdtemp(prefix="infilld-ctr-")
    argv = [a.replace("/usr/local/bin/infilld", BIN).replace("/var/lib/infilld", d)
            .replace("0.0.0.0:8080", "127.0.0.1:0") for a in argv]
    try:
        start_and_probe(argv + ["--workers", "1"])
    finally:
        shutil.rmtree(d, ignore_errors=True)


# In debian:bookworm-slim before anything is installed (apt needs them).
BASE_PACKAGES = {"libc6", "libgcc-s1", "libstdc++6"}
# tests/run.sh sets INFILLD_SANITIZE=1 for `make SANITIZE=1 test`: BIN is then
# an ASan/UBSan build, linked without --as-needed and against the
# sanitizers' runtimes; the image builds without sanitizers.
SANITIZED = os.environ.get("INFILLD_SANITIZE") == "1"


def runtime_packages(dockerfile_text):
    """The packages the Dockerfile's last stage installs."""
    last = dockerfile_text.split("\nFROM ")[-1]
    m = re.search(r"--no-install-recommends(.*?)&&", last, re.S)
    check(m, "no apt-get install in the runtime stage")
    return set(w for w in m.group(1).replace("\\", " ").split() if not w.startswith("-"))


def missing_runtime_libs(binary, packages):
    """NEEDED libraries of binary whose Debian package is neither installed
    by packages, nor a dependency of one of them (apt installs the whole
    closure of Depends and Pre-Depends), nor in the base image."""
    have = set(BASE_PACKAGES)
    todo = list(packages)
    while todo:
        pkg = todo.pop()
        if pkg in have:
            continue
        have.add(pkg)
        deps = subprocess.run(["dpkg-query", "-W", "-f", "${Depends},${Pre-Depends}", pkg],
                              capture_output=True, text=True).stdout
        todo += [d.split()[0].split(":")[0] for d in deps.replace("|", ",").split(",")
                 if d.strip()]
    needed = re.findall(r"\(NEEDED\).*\[(.+)\]",
                        subprocess.run(["readelf", "-d", binary], capture_output=True,
                                       text=True).stdout)
    cache = subprocess.run(["ldconfig", "-p"], capture_output=True, text=True).stdout
    missing = []
    for lib in needed:
        if SANITIZED and re.match(r"lib(asan|ubsan)\.so", lib):
            continue  # the sanitizers' runtime: the image's build is never sanitized
        m = re.search(r"^\s+%s \(libc6,x86-64\) => (\S+)" % re.escape(lib), cache, re.M)
        check(m, "%s not in the linker cache" % lib)
        path = os.path.realpath(m.group(1))
        owner = None
        for cand in (path, path.replace("/usr/lib/", "/lib/", 1), m.group(1),
                     m.group(1).replace("/lib/", "/usr/lib/", 1)):
            out = subprocess.run(["dpkg", "-S", cand], capture_output=True, text=True)
            if out.returncode == 0:
                owner = out.stdout.split(":")[0]
                break
        check(owner, "no package owns %s" % path)
        if owner not in have:
            missing.append("%s (%s)" % (lib, owner))
    return missing


def test_container_libraries():
    # Every library the binary links must be in the runtime image, or the
    # container dies at start ("error while loading shared libraries").
    with open(os.path.join(ROOT, "deploy", "Dockerfile")) as f:
        text = f.read()
    pkgs = runtime_packages(text)
    missing = missing_runtime_libs(BIN, pkgs)
    check(not missing, "deploy/Dockerfile's runtime stage lacks %s" % missing)
    # The check itself: without libpq5 it must complain.
    check(any("libpq" in x for x in missing_runtime_libs(BIN, pkgs - {"libpq5"})),
          "the library check misses a package taken away")


def test_run_dev():
    d = tempfile.mkdtemp(prefix="infilld-dev-")
    env = dict(os.environ, INFILLD_DATA=d, INFILLD_LISTEN="127.0.0.1:0")
    try:
        lines = start_and_probe([os.path.join(ROOT, "deploy", "run-dev.sh"), BIN], env)
        text = "".join(lines)
        check("admin key" in text and "http://127.0.0.1:0" in text, "hint printed: %s" % text)
        with open(os.path.join(d, "admin.key")) as f:
            key = f.read().strip()
        check(re.fullmatch(r"ifa_[a-z2-7]{12}_[a-z2-7]{32}", key), "admin key saved: %r" % key)
        check(oct(os.stat(os.path.join(d, "admin.key")).st_mode & 0o777) == "0o600", "mode 600")
    finally:
        shutil.rmtree(d, ignore_errors=True)


if __name__ == "__main__":
    run([test_systemd_execstart, test_container_entrypoint, test_container_libraries,
         test_run_dev])
