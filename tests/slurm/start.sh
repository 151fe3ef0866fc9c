#!/usr/bin/env bash
# start.sh STATE_DIR -- install (if needed) and start a private single-node Slurm cluster.
#
# Everything the cluster needs lives under STATE_DIR: slurm.conf, the munge key and
# socket, the controller state, the slurmd spool, logs and pid files. Nothing is written
# to /etc except by apt-get when the packages have to be installed.
#
# On success STATE_DIR/env.sh holds the environment a caller must export before running
# sbatch/squeue/scontrol/scancel against this cluster:   . STATE_DIR/env.sh
#
# Idempotent: if munged, slurmctld and slurmd are already running from this STATE_DIR
# (live pids in their pid files) and the node answers, it does nothing and exits 0.
#
# Tunables (environment): SLURM_TEST_CTLD_PORT (default 6817), SLURM_TEST_SLURMD_PORT
# (default 6818), SLURM_TEST_TIMEOUT (seconds to wait for the node to be idle, default 60).
set -euo pipefail

if [ $# -ne 1 ]; then
    echo "usage: $0 STATE_DIR" >&2
    exit 2
fi

mkdir -p "$1"
STATE_DIR=$(cd "$1" && pwd)          # absolute: daemons chdir to /
# slurm.conf values cannot hold whitespace, and the munge socket path must fit in a
# sockaddr_un (108 bytes): keep STATE_DIR short and plain (e.g. under /tmp).
case "$STATE_DIR" in
    *[[:space:]]*) echo "slurm/start: STATE_DIR must not contain whitespace: '$STATE_DIR'" >&2; exit 1 ;;
esac
if [ ${#STATE_DIR} -gt 80 ]; then
    echo "slurm/start: STATE_DIR is too long (${#STATE_DIR} > 80 chars) for the munge socket path" >&2
    exit 1
fi
CTLD_PORT=${SLURM_TEST_CTLD_PORT:-6817}
SLURMD_PORT=${SLURM_TEST_SLURMD_PORT:-6818}
TIMEOUT=${SLURM_TEST_TIMEOUT:-60}
NODE=localhost                       # node name; slurmd is started with -N so the real hostname does not matter

CONF="$STATE_DIR/slurm.conf"
MUNGE_DIR="$STATE_DIR/munge"
MUNGE_SOCKET="$MUNGE_DIR/munge.socket"
MUNGE_KEY="$MUNGE_DIR/munge.key"
PID_DIR="$STATE_DIR/pid"
LOG_DIR="$STATE_DIR/log"

log() { echo "slurm/start: $*" >&2; }

# ---------------------------------------------------------------------------
# Helpers on pid files: "alive NAME" is true when STATE_DIR/pid/NAME.pid names a live
# (not zombie) process whose command is NAME (guards against a recycled pid, and
# against an exited daemon that init has not reaped yet).
# ---------------------------------------------------------------------------
alive() {
    local pid stat
    pid=$(cat "$PID_DIR/$1.pid" 2>/dev/null) || return 1
    [ -n "$pid" ] || return 1
    stat=$(cat "/proc/$pid/stat" 2>/dev/null) || return 1
    # /proc/PID/stat is "PID (COMM) STATE ..."
    case "$stat" in
        *"($1) Z "*|*"($1) X "*) return 1 ;;
        *"($1) "*) return 0 ;;
        *) return 1 ;;
    esac
}

# ---------------------------------------------------------------------------
# 1. Install slurm-wlm and munge when the daemons are missing.
# ---------------------------------------------------------------------------
need_install=0
for bin in slurmctld slurmd munged sbatch; do
    if ! command -v "$bin" >/dev/null 2>&1 && [ ! -x "/usr/sbin/$bin" ]; then
        need_install=1
    fi
done
if [ "$need_install" = 1 ]; then
    if [ "$(id -u)" != 0 ]; then
        echo "slurm/start: slurmctld/slurmd/munged are not installed and this is not root;" >&2
        echo "slurm/start: install them first:  apt-get install --no-install-recommends slurm-wlm munge" >&2
        exit 1
    fi
    log "installing slurm-wlm and munge with apt-get"
    # The packages' maintainer scripts would start system-wide munged/slurmd/slurmctld
    # (on /run/munge, /etc/slurm). Forbid that with a policy-rc.d (exit 101), unless one
    # is already there (Docker images ship one); remove ours afterwards.
    own_policy=0
    if [ ! -e /usr/sbin/policy-rc.d ]; then
        printf '#!/bin/sh\nexit 101\n' >/usr/sbin/policy-rc.d
        chmod 755 /usr/sbin/policy-rc.d
        own_policy=1
    fi
    export DEBIAN_FRONTEND=noninteractive
    rc=0
    { apt-get update -qq && apt-get install -y -qq --no-install-recommends slurm-wlm munge; } \
        >"${TMPDIR:-/tmp}/slurm-apt.log" 2>&1 || rc=$?
    if [ "$own_policy" = 1 ]; then rm -f /usr/sbin/policy-rc.d; fi
    if [ "$rc" != 0 ]; then
        tail -n 30 "${TMPDIR:-/tmp}/slurm-apt.log" >&2
        log "apt-get failed (exit $rc); full log in ${TMPDIR:-/tmp}/slurm-apt.log"
        exit 1
    fi
fi
PATH="$PATH:/usr/sbin:/sbin"

# ---------------------------------------------------------------------------
# 2. Already running from this STATE_DIR? Then nothing to do.
# ---------------------------------------------------------------------------
if alive munged && alive slurmctld && alive slurmd && [ -f "$STATE_DIR/env.sh" ]; then
    if (. "$STATE_DIR/env.sh" && sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'); then
        log "already running from $STATE_DIR"
        exit 0
    fi
fi
if alive munged || alive slurmctld || alive slurmd; then
    echo "slurm/start: some daemons from $STATE_DIR are running but the cluster is not healthy;" >&2
    echo "slurm/start: run tests/slurm/stop.sh $STATE_DIR first" >&2
    exit 1
fi

# Daemons run as root (SlurmUser=root): running as another user would need a dedicated
# account and chowned state; the test harness runs as root anyway.
if [ "$(id -u)" != 0 ]; then
    log "starting the daemons needs root (slurmd must run as root to launch jobs)"
    exit 1
fi

# ---------------------------------------------------------------------------
# 3. Directories, munge key and slurm.conf (rewritten on every cold start).
# ---------------------------------------------------------------------------
mkdir -p "$MUNGE_DIR" "$PID_DIR" "$LOG_DIR" "$STATE_DIR/ctld" "$STATE_DIR/spool"
# munged refuses a key others can read, and a socket dir that others can write or
# cannot traverse (clients connect to the socket): 755 for the dir, 400 for the key.
chmod 755 "$MUNGE_DIR"
chmod 755 "$STATE_DIR"   # slurmstepd and the job (root here) need to traverse it
if [ ! -s "$MUNGE_KEY" ]; then
    # 1024 random bytes, as mungekey(8) would create; no need for the mungekey tool.
    dd if=/dev/urandom of="$MUNGE_KEY" bs=1024 count=1 status=none
fi
chmod 400 "$MUNGE_KEY"

CPUS=$(nproc)
# RealMemory: half of MemTotal in MiB (never above what slurmd detects, which would
# drain the node); with CR_CPU memory is not a consumable anyway.
MEM_MB=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 / 2 }' /proc/meminfo)
[ "$MEM_MB" -ge 1 ] || MEM_MB=1

cat >"$CONF" <<EOF
# Single-node test cluster written by tests/slurm/start.sh; do not edit, it is rewritten.
ClusterName=isartest
SlurmctldHost=localhost
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root

AuthType=auth/munge
AuthInfo=socket=$MUNGE_SOCKET
CredType=cred/munge

StateSaveLocation=$STATE_DIR/ctld
SlurmdSpoolDir=$STATE_DIR/spool
SlurmctldPidFile=$PID_DIR/slurmctld.pid
SlurmdPidFile=$PID_DIR/slurmd.pid
SlurmctldLogFile=$LOG_DIR/slurmctld.log
SlurmdLogFile=$LOG_DIR/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info

# No cgroups: they do not work inside containers.
ProctrackType=proctrack/pgid
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
SwitchType=switch/none

SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
# A job whose afterok dependency fails (e.g. an array task exits non-zero) is cancelled
# instead of pending forever with Reason=DependencyNeverSatisfied.
DependencyParameters=kill_invalid_depend
# Quick turnaround for tests.
SchedulerParameters=sched_interval=1
MinJobAge=300
KillWait=5
SlurmctldTimeout=30
SlurmdTimeout=30

NodeName=$NODE NodeAddr=127.0.0.1 NodeHostname=$NODE CPUs=$CPUS RealMemory=$MEM_MB State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF

cat >"$STATE_DIR/env.sh" <<EOF
# Source this (. $STATE_DIR/env.sh) to use the test cluster's sbatch/squeue/scontrol.
export SLURM_CONF=$CONF
export PATH="\$PATH:/usr/sbin:/sbin"
EOF

export SLURM_CONF="$CONF"

# ---------------------------------------------------------------------------
# 4. Start the daemons (each daemonises itself and writes its pid file).
# ---------------------------------------------------------------------------
# From here on, a failure stops whatever this run started (by its pid files), so that
# a failed start leaves no daemon behind.
HERE=$(cd "$(dirname "$0")" && pwd)
cleanup_on_failure() {
    local rc=$?
    if [ "$rc" != 0 ]; then
        log "start failed (exit $rc); stopping what was started"
        "$HERE/stop.sh" "$STATE_DIR" || true
    fi
    exit "$rc"
}
trap cleanup_on_failure EXIT

log "starting munged"
rm -f "$MUNGE_SOCKET" "$MUNGE_SOCKET.lock"
munged --key-file="$MUNGE_KEY" --socket="$MUNGE_SOCKET" \
    --pid-file="$PID_DIR/munged.pid" --log-file="$LOG_DIR/munged.log" \
    --seed-file="$MUNGE_DIR/munged.seed"

log "starting slurmctld"
# -c: discard job/node state left by an earlier run in the same STATE_DIR, so every
# start is a fresh cluster (job ids, though, keep counting up).
slurmctld -f "$CONF" -c

log "starting slurmd"
slurmd -f "$CONF" -N "$NODE"

# ---------------------------------------------------------------------------
# 5. Wait (bounded) until the node is idle.
# ---------------------------------------------------------------------------
deadline=$(( $(date +%s) + TIMEOUT ))
state=""
while :; do
    state=$(sinfo -h -n "$NODE" -o '%T' 2>/dev/null || true)
    case "$state" in
        idle) break ;;
    esac
    # A daemon that died (port in use, bad config...) will not come back: fail now.
    for d in munged slurmctld slurmd; do
        if ! alive "$d"; then
            log "$d is not running; see $LOG_DIR/$d.log:"
            tail -n 15 "$LOG_DIR/$d.log" >&2 2>/dev/null || true
            exit 1
        fi
    done
    if [ "$(date +%s)" -ge "$deadline" ]; then
        log "node not idle after ${TIMEOUT}s (state: '${state:-no answer}'); last log lines:"
        for f in munged slurmctld slurmd; do
            echo "--- $LOG_DIR/$f.log" >&2
            tail -n 15 "$LOG_DIR/$f.log" >&2 2>/dev/null || true
        done
        exit 1
    fi
    sleep 0.5
done
log "cluster up: node $NODE idle, $CPUS CPUs; now run:  . $STATE_DIR/env.sh"
