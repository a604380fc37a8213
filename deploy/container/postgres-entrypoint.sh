#!/bin/bash
# First start on an empty volume: a cluster whose only remote login is
# POSTGRES_USER with POSTGRES_PASSWORD, owning database POSTGRES_DB. Later
# starts reuse the cluster as it is. Then runs postgres in the foreground
# (as PID 1, so the container's stop signal reaches it).
set -euo pipefail

: "${PGDATA:=/var/lib/postgresql/data}"
user=${POSTGRES_USER:-oaipp}
db=${POSTGRES_DB:-oaipp}

if [ ! -s "$PGDATA/PG_VERSION" ]; then
  if [ -z "${POSTGRES_PASSWORD:-}" ]; then
    echo "postgres-entrypoint: POSTGRES_PASSWORD is empty; refusing to make a cluster without one" >&2
    exit 2
  fi
  case "$user$db" in
    *[!a-z0-9_]*) echo "postgres-entrypoint: POSTGRES_USER and POSTGRES_DB: [a-z0-9_] only" >&2; exit 2 ;;
  esac
  initdb --pgdata="$PGDATA" --username=postgres --auth-local=peer --auth-host=scram-sha-256 \
    --encoding=UTF8 --locale=C.UTF-8 >/dev/null
  # Single-user mode: no listening server exists before the role does.
  # With -j a statement ends at a semicolon followed by an empty line.
  password=${POSTGRES_PASSWORD//\'/\'\'}
  postgres --single -D "$PGDATA" -j postgres >/dev/null <<SQL
CREATE ROLE $user LOGIN PASSWORD '$password';

CREATE DATABASE $db OWNER $user;

SQL
  # Remote clients: only this role, to its own database, with a password.
  cat >"$PGDATA/pg_hba.conf" <<HBA
local all postgres peer
host $db $user 0.0.0.0/0 scram-sha-256
host $db $user ::/0 scram-sha-256
HBA
  echo "postgres-entrypoint: made a cluster in $PGDATA (database $db, role $user)"
fi

exec postgres -D "$PGDATA" -c listen_addresses='*' "$@"
