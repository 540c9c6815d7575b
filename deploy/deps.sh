#!/usr/bin/env bash
# deps.sh - install the Debian packages infilld builds, tests and runs with.
# Idempotent and quick when everything is present (one dpkg-query call).
# Run as root (or with sudo available) on Debian 12.
set -euo pipefail

PKGS=(
	gcc g++ make pkg-config clang libclang-rt-14-dev python3
	libmicrohttpd-dev libjansson-dev libpng-dev zlib1g-dev libsqlite3-dev
	libarchive-dev libpolyclipping-dev libtet1.5-dev coinor-libipopt-dev
	nettle-dev wrk
)

missing=()
while read -r name status; do
	[ "$status" = "installed" ] || missing+=("$name")
done < <(dpkg-query -W -f='${Package} ${db:Status-Status}\n' "${PKGS[@]}" 2>/dev/null || true)
# Packages dpkg has never heard of do not appear in the output at all.
for p in "${PKGS[@]}"; do
	dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null | grep -qx installed || {
		case " ${missing[*]-} " in *" $p "*) ;; *) missing+=("$p") ;; esac
	}
done

[ ${#missing[@]} -eq 0 ] && exit 0

SUDO=
[ "$(id -u)" -eq 0 ] || SUDO=sudo
echo "deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
