#!/usr/bin/env bash
# Run the storage and API tests on a throw-away PostgreSQL server (the rest of the suite runs on
# SQLite in scripts/test.sh, which calls this script after it).
#
# Needs PostgreSQL's server programs (initdb, pg_ctl: on PATH or under /usr/lib/postgresql/*/bin);
# without them it says so and exits 0. The server listens on a Unix socket only, in a temporary
# folder that is removed at the end, with the server. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."

find_bin() {
  command -v "$1" 2>/dev/null && return 0
  local p
  for p in /usr/lib/postgresql/*/bin/"$1"; do
    [ -x "$p" ] && { echo "$p"; return 0; }
  done
  return 1
}

if ! INITDB=$(find_bin initdb) || ! PG_CTL=$(find_bin pg_ctl); then
  echo "test-postgres: skipped: no PostgreSQL server programs (initdb, pg_ctl) on this machine"
  exit 0
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
.venv/bin/python -m pip install --quiet -e '.[dev,postgres]'

DIR=$(mktemp -d /tmp/gaitwatch-pg.XXXXXX)
PORT=$((20000 + RANDOM % 20000))
# initdb refuses to run as root: run the server as an unprivileged user then.
RUN=()
if [ "$(id -u)" = 0 ]; then
  USER_=postgres
  id "$USER_" >/dev/null 2>&1 || USER_=nobody
  chown "$USER_" "$DIR"
  RUN=(runuser -u "$USER_" --)
fi

cleanup() {
  "${RUN[@]}" "$PG_CTL" -D "$DIR/data" -m immediate stop >/dev/null 2>&1 || true
  rm -rf "$DIR"
}
trap cleanup EXIT

"${RUN[@]}" "$INITDB" -D "$DIR/data" -U gaitwatch --auth=trust >"$DIR/initdb.log" 2>&1 \
  || { cat "$DIR/initdb.log"; echo "test-postgres: initdb failed"; exit 1; }
"${RUN[@]}" "$PG_CTL" -D "$DIR/data" -l "$DIR/server.log" -w \
  -o "-k $DIR -p $PORT -c listen_addresses=''" start >/dev/null \
  || { cat "$DIR/server.log"; echo "test-postgres: the server did not start"; exit 1; }

echo "test-postgres: $("${RUN[@]}" "$PG_CTL" --version) on $DIR, port $PORT"
GAITWATCH_TEST_POSTGRES_URL="postgresql+psycopg://gaitwatch@/postgres?host=$DIR&port=$PORT" \
  .venv/bin/python -m pytest -q -p no:cacheprovider \
  tests/test_db_ingest.py tests/test_db_erasure.py tests/test_migrations.py \
  tests/test_api_auth.py tests/test_api_gc.py tests/test_api_hostile.py \
  tests/test_api_resources.py "$@"
