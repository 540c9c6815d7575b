#!/usr/bin/env bash
# run-dev.sh BIN - `make run`: start the service on 127.0.0.1:8080 with the
# embedded default data directory (var/infilld, gitignored), creating an
# admin key on first use (kept in var/infilld/admin.key, mode 0600: a
# development convenience; production keeps keys only as hashes).
set -euo pipefail
BIN=${1:?usage: run-dev.sh BIN}
DATA=${INFILLD_DATA:-var/infilld}
LISTEN=${INFILLD_LISTEN:-127.0.0.1:8080}
mkdir -p "$DATA"
if [ ! -s "$DATA/admin.key" ]; then
	umask 077
	"$BIN" admin-key --data "$DATA" | tail -n 1 >"$DATA/admin.key"
fi
cat <<MSG
infilld: starting on http://$LISTEN (data: $DATA)
  admin key:   \$(cat $DATA/admin.key)
  new tenant:  curl -s -H "Authorization: Bearer \$(cat $DATA/admin.key)" \\
                 -H 'Content-Type: application/json' -d '{"name":"me"}' http://$LISTEN/v1/tenants
  or:          $BIN tenant add me --data $DATA     (key on the last line)
  web portal:  http://$LISTEN/   (sign in with a tenant key, or the admin key; docs/portal.md)
  walkthrough: docs/service.md
MSG
exec "$BIN" serve --listen "$LISTEN" --data "$DATA"
