#!/usr/bin/env bash
# deps.sh - install the Debian packages infilld builds, tests and runs with.
# Idempotent and quick when everything is present (one dpkg-query call).
# Run as root (or with sudo available) on Debian 12.
set -euo pipefail

# Every -l the link line asks for (pkg-config --libs of the Makefile's PKGS,
# Ipopt's included: -llapack -lblas), every tool `make run`, `make test` and
# the README's session call.  Installed with --no-install-recommends, so a
# library that a -dev package only recommends must be listed here itself.
# yamllint and python3-yaml check deploy/'s compose and Kubernetes files
# (tests/service/test_deploy_lint.py).
PKGS=(
	gcc g++ make pkg-config clang libclang-rt-14-dev python3 python3-pil
	libmicrohttpd-dev libjansson-dev libpng-dev zlib1g-dev libsqlite3-dev
	libarchive-dev libpolyclipping-dev libtet1.5-dev coinor-libipopt-dev
	liblapack-dev libblas-dev nettle-dev libpq-dev postgresql
	curl ca-certificates wrk yamllint python3-yaml
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

# Node.js + npm run the OpenAPI linter, ESLint and the browser test; use
# the machine's if it has one (a newer node may come from elsewhere), else
# Debian's.  The portal's browser test (tests/web/test_portal.py) drives
# Debian's chromium through playwright-core (no browser download), with
# one font for legible screenshots (chromium only recommends fonts).  All
# of it is for the tests only: SKIP_NPM=1 (make run, container builds)
# skips it.
if [ "${SKIP_NPM-}" != 1 ]; then
	command -v npm >/dev/null 2>&1 || missing+=(nodejs npm)
	for p in chromium fonts-dejavu-core; do
		dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null | grep -qx installed ||
			missing+=("$p")
	done
fi

if [ ${#missing[@]} -gt 0 ]; then
	SUDO=
	[ "$(id -u)" -eq 0 ] || SUDO=sudo
	echo "deps: installing ${missing[*]}" >&2
	export DEBIAN_FRONTEND=noninteractive
	$SUDO apt-get update -qq
	$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# npm tools pinned by package-lock.json (OpenAPI linter, ESLint,
# playwright-core; three.js, whose build the portal vendors in web/vendor/),
# into node_modules/.
# SKIP_NPM=1 (container builds) skips it: only the tests need it.
ROOT=$(cd "$(dirname "$0")/.." && pwd)
if [ "${SKIP_NPM-}" != 1 ] && [ -f "$ROOT/package-lock.json" ] &&
	! cmp -s "$ROOT/package-lock.json" "$ROOT/node_modules/.package-lock-installed" 2>/dev/null; then
	echo "deps: npm ci (node $(node --version), npm $(npm --version))" >&2
	# --engine-strict: a package whose `engines` refuses this node or npm
	# stops the install with npm's own message instead of a hidden warning.
	(cd "$ROOT" && npm ci --engine-strict --no-audit --no-fund --loglevel=warn) ||
		{ echo "deps: npm ci failed (see above)" >&2; exit 1; }
	"$ROOT/node_modules/.bin/redocly" --version >/dev/null ||
		{ echo "deps: the OpenAPI linter does not start under node $(node --version)" >&2; exit 1; }
	cp "$ROOT/package-lock.json" "$ROOT/node_modules/.package-lock-installed"
fi
