#!/usr/bin/env bash
# smoke.sh STATE_DIR -- prove the cluster from tests/slurm/start.sh STATE_DIR runs jobs.
#
# Submits a 3-task array job (each task writes its $SLURM_ARRAY_TASK_ID into a file) and
# a merge job with --dependency=afterok:<array id> that concatenates the three files,
# the same shape as `isar-clutter slurm --submit` (array of shards + merge job). Waits
# (bounded: SLURM_TEST_TIMEOUT seconds, default 60) for the merge job by polling
# `scontrol show job` (no accounting, so no sacct), then checks the merged file.
# Exit 0 on success, 1 on failure (with the job's state and output printed).
set -euo pipefail

if [ $# -ne 1 ]; then
    echo "usage: $0 STATE_DIR" >&2
    exit 2
fi
STATE_DIR=$(cd "$1" && pwd)
TIMEOUT=${SLURM_TEST_TIMEOUT:-60}
# shellcheck source=/dev/null
. "$STATE_DIR/env.sh"          # SLURM_CONF (and PATH) for sbatch/scontrol

log() { echo "slurm/smoke: $*" >&2; }

WORK=$(mktemp -d "$STATE_DIR/smoke.XXXXXX")
log "working in $WORK"

# The array: task i writes "i" into shard-i.txt.
array_id=$(sbatch --parsable --array=0-2 --cpus-per-task=1 --job-name=smoke-shard \
    --chdir="$WORK" --output="$WORK/shard-%a.out" \
    --wrap 'echo "$SLURM_ARRAY_TASK_ID" > "shard-$SLURM_ARRAY_TASK_ID.txt"')
# With --parsable the answer is "jobid" or "jobid;cluster".
array_id=${array_id%%;*}
log "array job $array_id"

# The merge: runs only if every array task exited 0.
merge_id=$(sbatch --parsable --dependency="afterok:$array_id" --cpus-per-task=1 \
    --job-name=smoke-merge --chdir="$WORK" --output="$WORK/merge.out" \
    --wrap 'cat shard-0.txt shard-1.txt shard-2.txt > merged.txt')
merge_id=${merge_id%%;*}
log "merge job $merge_id (afterok:$array_id)"

# job_field ID FIELD: one field of `scontrol -o show job ID` (empty once the job is purged).
job_field() {
    scontrol -o show job "$1" 2>/dev/null | tr ' ' '\n' | sed -n "s/^$2=//p" | head -n 1
}

deadline=$(( $(date +%s) + TIMEOUT ))
state=""
while :; do
    state=$(job_field "$merge_id" JobState)
    reason=$(job_field "$merge_id" Reason)
    case "$state" in
        COMPLETED) break ;;
        FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY|BOOT_FAIL|DEADLINE|PREEMPTED)
            log "merge job ended $state"; break ;;
        "")
            # Purged from the controller (MinJobAge passed): judge by the output file.
            log "merge job no longer known to the controller"; break ;;
    esac
    if [ "$reason" = DependencyNeverSatisfied ]; then
        log "merge job can never run: an array task failed"
        break
    fi
    if [ "$(date +%s)" -ge "$deadline" ]; then
        log "timed out after ${TIMEOUT}s (merge job state $state, reason $reason)"
        break
    fi
    sleep 0.5
done

expected=$(printf '0\n1\n2\n')
if [ "$state" != "" ] && [ "$state" != COMPLETED ] || [ ! -f "$WORK/merged.txt" ] \
    || [ "$(cat "$WORK/merged.txt")" != "$expected" ]; then
    log "FAILED"
    scontrol show job "$array_id" >&2 2>/dev/null || true
    scontrol show job "$merge_id" >&2 2>/dev/null || true
    for f in "$WORK"/*; do echo "--- $f" >&2; cat "$f" >&2; done
    exit 1
fi
log "OK: array $array_id (3 tasks) + merge $merge_id -> $(tr '\n' ' ' <"$WORK/merged.txt")"
rm -rf "$WORK"
