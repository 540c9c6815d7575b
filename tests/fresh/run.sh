#!/usr/bin/env bash
# tests/fresh/run.sh [--root DIR] [--keep] [--mirror URL] - the README's two
# commands on a fresh Debian 12.
#
# Builds a minbase Debian 12 (bookworm) root with debootstrap (nothing else
# installed: no compiler, no make, no curl, no node), installs make (the
# README's one prerequisite), clones this repository's HEAD
# into it as /root/infilld with ../shared beside it as /root/shared, then,
# chrooted:
#   1. `make run` in the background, and waits (up to FRESH_RUN_WAIT_S,
#      default 1800 s: the first `make run` installs the packages) for
#      http://127.0.0.1:8080/livez;
#   2. the README's curl session ("A complete session:" block), verbatim,
#      and checks that it downloaded a non-empty SL1 (zip) archive;
#   3. stops the server and runs `make test`.
# Not part of `make test` (it downloads ~400 MB of packages and takes
# 20-40 minutes).  Needs root, debootstrap (installed if missing), the Debian
# mirror, and port 8080 free on this machine (the chroot shares its network).
# Exit status 0 when all three steps pass.  Logs: DIR.log/ beside the root.
set -euo pipefail

HERE=$(cd "$(dirname "$0")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
ROOTFS=${FRESH_ROOT:-/var/tmp/infilld-fresh}
MIRROR=${FRESH_MIRROR:-http://deb.debian.org/debian}
KEEP=0
while [ $# -gt 0 ]; do
	case $1 in
	--root) ROOTFS=$2; shift 2 ;;
	--mirror) MIRROR=$2; shift 2 ;;
	--keep) KEEP=1; shift ;;
	*) echo "usage: $0 [--root DIR] [--keep] [--mirror URL]" >&2; exit 2 ;;
	esac
done
SHARED=${INFILLD_SHARED:-$REPO/../shared}
[ -d "$SHARED/meshes" ] || { echo "fresh: $SHARED/meshes not found (set INFILLD_SHARED)" >&2; exit 2; }
[ "$(id -u)" -eq 0 ] || { echo "fresh: must run as root (debootstrap, chroot)" >&2; exit 2; }
if (exec 3<>/dev/tcp/127.0.0.1/8080) 2>/dev/null; then
	echo "fresh: port 8080 is in use on this machine; the README's session needs it" >&2
	exit 2
fi
LOGS="$ROOTFS.log"
rm -rf "$LOGS" && mkdir -p "$LOGS"
say() { printf '[fresh %s] %s\n' "$(date +%H:%M:%S)" "$*" | tee -a "$LOGS/steps.txt"; }

mounted=()
# Every process whose root directory is the fresh root (the server started
# by `make run`, its workers), by /proc/PID/root.
kill_in_root() {
	local p r
	for p in /proc/[0-9]*; do
		r=$(readlink "$p/root" 2>/dev/null) || continue
		[ "$r" = "$ROOTFS" ] && kill -9 "${p#/proc/}" 2>/dev/null
	done
	return 0
}
cleanup() {
	set +e
	kill_in_root
	for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do umount -l "${mounted[$i]}" 2>/dev/null; done
	[ "$KEEP" = 1 ] || rm -rf --one-file-system "$ROOTFS"
}
trap cleanup EXIT

command -v debootstrap >/dev/null || {
	say "installing debootstrap on this machine"
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends debootstrap >/dev/null
}

# 1. the root
rm -rf --one-file-system "$ROOTFS"
say "debootstrap --variant=minbase bookworm $ROOTFS $MIRROR"
debootstrap --variant=minbase bookworm "$ROOTFS" "$MIRROR" >"$LOGS/debootstrap.txt" 2>&1 ||
	{ tail -n 20 "$LOGS/debootstrap.txt"; exit 1; }
cat >"$ROOTFS/etc/apt/sources.list" <<EOF
deb $MIRROR bookworm main
deb $MIRROR bookworm-updates main
deb ${MIRROR%/debian}/debian-security bookworm-security main
EOF
cp /etc/resolv.conf "$ROOTFS/etc/resolv.conf"
for m in proc sys dev dev/pts dev/shm; do
	mkdir -p "$ROOTFS/$m"
	case $m in
	proc) mount -t proc proc "$ROOTFS/proc" ;;
	sys) mount -t sysfs sys "$ROOTFS/sys" ;;
	dev/shm) mount -t tmpfs shm "$ROOTFS/dev/shm" ;;
	*) mount --bind "/$m" "$ROOTFS/$m" ;;
	esac
	mounted+=("$ROOTFS/$m")
done
say "root has $(chroot "$ROOTFS" dpkg-query -W -f='.\n' | wc -l) packages;" \
	"gcc: $(chroot "$ROOTFS" sh -c 'command -v gcc || echo none')," \
	"curl: $(chroot "$ROOTFS" sh -c 'command -v curl || echo none')," \
	"node: $(chroot "$ROOTFS" sh -c 'command -v node || echo none')"

# 2. the checkout (committed HEAD only, as a clone would see it) and shared/
git clone -q "$REPO" "$ROOTFS/root/infilld"
git -C "$ROOTFS/root/infilld" log -1 --format='%h %s' | cut -c1-100 | sed 's/^/[fresh] HEAD /'
cp -r "$SHARED" "$ROOTFS/root/shared"
# A site whose egress re-signs TLS (a proxy CA in this machine's trust
# store) needs that trust in the root too, or npm cannot reach its
# registry: the host's bundle goes in as /root/host-ca.crt and node reads
# it (NODE_EXTRA_CA_CERTS), as node does on this machine.  Nothing else of
# the host's set-up is carried over.
CA_ENV=()
if [ -n "${NODE_EXTRA_CA_CERTS-}" ] && [ -f "$NODE_EXTRA_CA_CERTS" ]; then
	cp "$NODE_EXTRA_CA_CERTS" "$ROOTFS/root/host-ca.crt"
	CA_ENV=(NODE_EXTRA_CA_CERTS=/root/host-ca.crt)
fi
in_root() { chroot "$ROOTFS" /usr/bin/env -i HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
	LANG=C.UTF-8 TERM=dumb "${CA_ENV[@]}" bash -c "cd /root/infilld && $1"; }

# make itself is the one prerequisite the README names (make deps installs
# the rest); git is not needed in the root: the clone was made from outside.
say "apt-get install make (the README's prerequisite)"
in_root "apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends make" \
	>"$LOGS/prereq.txt" 2>&1 || { tail -n 20 "$LOGS/prereq.txt"; exit 1; }

# 3. make run, then wait for /livez (polled from this machine: same network)
say "make run (background; log $LOGS/make-run.txt)"
in_root "make run" >"$LOGS/make-run.txt" 2>&1 &
RUN_PID=$!
WAIT=${FRESH_RUN_WAIT_S:-1800}
t0=$(date +%s)
until python3 -c 'import urllib.request,sys; sys.exit(urllib.request.urlopen("http://127.0.0.1:8080/livez", timeout=2).status != 200)' 2>/dev/null; do
	if ! kill -0 "$RUN_PID" 2>/dev/null; then
		say "FAIL: make run exited before /livez answered"; tail -n 30 "$LOGS/make-run.txt"; exit 1
	fi
	[ $(($(date +%s) - t0)) -lt "$WAIT" ] || { say "FAIL: no /livez after $WAIT s"; tail -n 30 "$LOGS/make-run.txt"; exit 1; }
	sleep 3
done
say "PASS: make run serves /livez after $(($(date +%s) - t0)) s"

# 4. the README's session, verbatim: the fenced block after "A complete session:"
awk '/A complete session:/ { f = 1; next } f && /^```sh/ { g = 1; next } g && /^```/ { exit } g' \
	"$ROOTFS/root/infilld/README.md" >"$ROOTFS/root/readme-session.sh"
[ -s "$ROOTFS/root/readme-session.sh" ] || { say "FAIL: README has no session block"; exit 1; }
say "README session ($(wc -l <"$ROOTFS/root/readme-session.sh") lines)"
if ! in_root "set -eo pipefail; . /root/readme-session.sh" >"$LOGS/session.txt" 2>&1; then
	say "FAIL: the README session failed"; tail -n 30 "$LOGS/session.txt"; exit 1
fi
out="$ROOTFS/root/infilld/femur.sl1"
if ! python3 - "$out" <<'EOF'; then
import sys, zipfile
z = zipfile.ZipFile(sys.argv[1])
pngs = [n for n in z.namelist() if n.endswith(".png") and "thumbnail" not in n.lower()]
assert "config.ini" in z.namelist() and len(pngs) > 100, (len(pngs), z.namelist()[:5])
print("[fresh] femur.sl1: %d bytes, %d layers" % (sum(i.file_size for i in z.infolist()), len(pngs)))
EOF
	say "FAIL: the session's download is not a layer archive"; exit 1
fi
say "PASS: README session ($(grep -c '^data:' "$LOGS/session.txt" || true) progress events)"
kill_in_root
wait "$RUN_PID" 2>/dev/null || true

# 5. make test
say "make test (log $LOGS/make-test.txt)"
if in_root "make test" >"$LOGS/make-test.txt" 2>&1; then rc=0; else rc=$?; fi
grep -E '^(== |FAIL)' "$LOGS/make-test.txt" | tee -a "$LOGS/steps.txt" || true
[ "$rc" -eq 0 ] || { say "FAIL: make test exited $rc"; tail -n 40 "$LOGS/make-test.txt"; exit 1; }
say "PASS: make test"
