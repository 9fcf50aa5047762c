#!/usr/bin/env bash
# A tiled bake on Slurm: the tiles `pctile split` made in TILE_DIR as a
# job array, one task per tile (its index is SLURM_ARRAY_TASK_ID), then
# `pctile merge` as a job that starts only when every task succeeded
# (--dependency=afterok; a failed tile cancels it).
#   submit.sh [--wait] TILE_DIR OUT_DIR MERGED STAGE [STAGE ARGS...]
# Prints the array's and the merge's job ids. --wait: returns when the
# merge has ended, with its exit status. Extra sbatch options (partition,
# memory a task) go in SBATCH_* variables, as sbatch reads them. BIN: the
# stages' directory, as for tile-task.sh (exported to the jobs).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
wait=()
if [[ ${1:-} == --wait ]]; then wait=(--wait); shift; fi
if (( $# < 4 )); then
    echo "usage: submit.sh [--wait] TILE_DIR OUT_DIR MERGED STAGE [STAGE ARGS...]" >&2
    exit 2
fi
abs() { mkdir -p "$(dirname "$1")"; echo "$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"; }
tdir=$(cd "$1" && pwd)
odir=$(abs "$2")
merged=$(abs "$3")
shift 3
export BIN=${BIN:-$(cd "$here/../../target/release" && pwd)}
n=$(grep -c '"file": "tile_' "$tdir/manifest.json")
mkdir -p "$odir"
task=$(printf '%q ' "$here/../tile-task.sh" "$tdir" "$odir")'"$SLURM_ARRAY_TASK_ID" '$(printf '%q ' "$@")
array=$(sbatch --parsable --job-name=pcsss-tiles --array=0-$((n - 1)) \
    --output="$odir/slurm-%A_%a.log" --wrap "$task")
merge=$(printf '%q ' "$BIN/pctile" -q merge "$tdir" --from "$odir" -o "$merged")
echo "tiles: job array $array ($n tasks)"
job=$(sbatch --parsable --job-name=pcsss-merge --dependency=afterok:"$array" --kill-on-invalid-dep=yes \
    --output="$odir/slurm-merge-%j.log" --wrap "$merge")
echo "merge: job $job"
if (( ${#wait[@]} )); then
    # The merge job's state, asked every 0.25 s at first and every 2 s
    # after a few. (`sbatch --wait` asks 2, 10 and 42 s after the
    # submission, then every 32 s: a bake of seconds would return up to
    # half a minute late.) A state that cannot be read 10 times running
    # (the controller gone, the job purged) ends the wait.
    state='' asked=0 lost=0
    pauses=(0.25 0.5 1)
    while :; do
        state=$(scontrol show job "$job" -o 2>/dev/null | grep -o 'JobState=[A-Z_]*' | cut -d= -f2 || true)
        case $state in
            COMPLETED | FAILED | CANCELLED | TIMEOUT | NODE_FAIL | PREEMPTED | BOOT_FAIL | DEADLINE | OUT_OF_MEMORY) break ;;
            '') (( ++lost < 10 )) || break ;;
            *) lost=0 ;;
        esac
        sleep "${pauses[asked++]:-2}"
    done
    if [[ $state != COMPLETED ]]; then
        echo "submit.sh: the merge job $job ended ${state:-unknown}: a tile failed or was cancelled (logs: $odir/slurm-*.log)" >&2
        exit 1
    fi
fi
