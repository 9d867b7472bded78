#!/bin/sh
# Health check: exit 0 when something in this container LISTENs on every given TCP port.
#
# Why read /proc/net/tcp instead of connecting: a probe on the agent port would be a new agent
# (in sync mode the server then waits for it to speak), and a probe on the monitor port gets a
# full scene pushed at it; a check that runs every few seconds beside live episodes must not
# touch either.
#
# Usage: listening.sh PORT [PORT ...]
set -eu
[ "$#" -gt 0 ] || { echo "usage: listening.sh PORT [PORT ...]" >&2; exit 2; }

for port in "$@"; do
    hex=$(printf '%04X' "$port")
    # /proc/net/tcp{,6} rows: `sl local_address rem_address st ...`, local as ADDR:PORT in hex,
    # st 0A = LISTEN. cat skips a missing tcp6 (no IPv6) without failing.
    cat /proc/net/tcp /proc/net/tcp6 2>/dev/null \
        | awk -v want=":$hex" 'substr($2, length($2) - 4) == want && $4 == "0A" { found = 1 }
                               END { exit !found }' \
        || { echo "nothing listens on TCP port $port" >&2; exit 1; }
done
