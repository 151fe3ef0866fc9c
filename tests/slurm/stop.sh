#!/usr/bin/env bash
# stop.sh STATE_DIR -- stop the daemons tests/slurm/start.sh started from STATE_DIR.
#
# Only the processes named by STATE_DIR/pid/{slurmd,slurmctld,munged}.pid are signalled,
# and only if the pid still belongs to a process of that name: TERM first, KILL after
# a bounded wait (SLURM_TEST_STOP_WAIT seconds, default 15). Jobs still running on the
# cluster are cancelled first (best effort), so that no slurmstepd or job process of this
# cluster outlives it. Nothing else is touched. Exits 0 when nothing is left running.
set -euo pipefail

if [ $# -ne 1 ]; then
    echo "usage: $0 STATE_DIR" >&2
    exit 2
fi
if [ ! -d "$1" ]; then
    echo "slurm/stop: $1 does not exist; nothing to stop" >&2
    exit 0
fi
STATE_DIR=$(cd "$1" && pwd)
PID_DIR="$STATE_DIR/pid"
WAIT=${SLURM_TEST_STOP_WAIT:-15}
PATH="$PATH:/usr/sbin:/sbin"

log() { echo "slurm/stop: $*" >&2; }

# running PID NAME: true when PID is a live (not zombie) process whose command is NAME.
# Checking the name guards against a pid recycled since the pid file was written; the
# state guards against an exited daemon not yet reaped by init (common in containers).
running() {
    local stat
    stat=$(cat "/proc/$1/stat" 2>/dev/null) || return 1
    # /proc/PID/stat is "PID (COMM) STATE ..."
    case "$stat" in
        *"($2) Z "*|*"($2) X "*) return 1 ;;
        *"($2) "*) return 0 ;;
        *) return 1 ;;
    esac
}

# pid NAME: the pid in NAME's pid file if that process is running NAME, else empty.
# (The daemons remove their own pid file on a clean shutdown.)
pid() {
    local p
    p=$(cat "$PID_DIR/$1.pid" 2>/dev/null || true)
    if [ -n "$p" ] && running "$p" "$1"; then
        echo "$p"
    fi
}

# Cancel this cluster's jobs while the controller still answers (best effort, bounded).
if [ -n "$(pid slurmctld)" ] && [ -f "$STATE_DIR/slurm.conf" ]; then
    export SLURM_CONF="$STATE_DIR/slurm.conf"
    jobs=$(timeout 10 squeue -h -o %A 2>/dev/null || true)
    if [ -n "$jobs" ]; then
        log "cancelling remaining jobs: $(echo $jobs)"
        # shellcheck disable=SC2086  # one job id per word
        timeout 10 scancel $jobs 2>/dev/null || true
        for _ in $(seq 1 20); do
            [ -z "$(timeout 10 squeue -h -t RUNNING,COMPLETING -o %A 2>/dev/null || true)" ] && break
            sleep 0.5
        done
    fi
fi

# stop NAME: TERM the pid from NAME's pid file, wait up to WAIT seconds for that pid
# to exit, then KILL it.
stop() {
    local name=$1 p
    p=$(pid "$name")
    if [ -z "$p" ]; then
        rm -f "$PID_DIR/$name.pid"
        return 0
    fi
    log "stopping $name (pid $p)"
    kill -TERM "$p" 2>/dev/null || true
    for _ in $(seq 1 $((WAIT * 5))); do
        running "$p" "$name" || break
        sleep 0.2
    done
    if running "$p" "$name"; then
        log "$name (pid $p) ignored TERM for ${WAIT}s; sending KILL"
        kill -KILL "$p" 2>/dev/null || true
        sleep 0.5
    fi
    rm -f "$PID_DIR/$name.pid"
    if running "$p" "$name"; then
        log "$name (pid $p) is still running"
        return 1
    fi
}

# Reverse start order: slurmd and slurmctld need munged to shut down cleanly.
rc=0
stop slurmd || rc=1
stop slurmctld || rc=1
stop munged || rc=1
exit $rc
