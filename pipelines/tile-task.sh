#!/usr/bin/env bash
# One tile of a tiled bake, the same line under make -j, Slurm and Open
# Job Description:
#   tile-task.sh TILE_DIR OUT_DIR INDEX STAGE [STAGE ARGS...]
# runs STAGE on TILE_DIR/tile_NNNN.ply (INDEX, from 0, as `pctile split`
# numbered it) and writes OUT_DIR/tile_NNNN.ply. The stage writes its
# output atomically, so a task retried or run twice is harmless. In the
# stage's arguments `{tile}` stands for the tile's file (`filter --cloud
# {tile}`). BIN: the stages' directory (default: this repository's
# target/release).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin=${BIN:-$here/../target/release}
if (( $# < 4 )); then
    echo "usage: tile-task.sh TILE_DIR OUT_DIR INDEX STAGE [STAGE ARGS...]" >&2
    exit 2
fi
tdir=$1 odir=$2 idx=$3 stage=$4
shift 4
[[ $idx =~ ^[0-9]+$ ]] || { echo "tile-task.sh: INDEX '$idx' is not a tile number" >&2; exit 2; }
name=$(printf 'tile_%04d.ply' "$((10#$idx))")
tile=$tdir/$name
[[ -f $tile ]] || { echo "tile-task.sh: $tile: no such tile" >&2; exit 1; }
mkdir -p "$odir"
# Under Slurm, the cores the task was given (else rayon takes them all).
if [[ -n ${SLURM_CPUS_PER_TASK:-} ]]; then export RAYON_NUM_THREADS=$SLURM_CPUS_PER_TASK; fi
args=()
for a in "$@"; do args+=("${a//\{tile\}/$tile}"); done
exec "$bin/$stage" -q "$tile" "${args[@]}" -o "$odir/$name"
