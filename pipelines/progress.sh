#!/usr/bin/env bash
# A bake's line of progress on stderr (pipelines/Makefile, PROGRESS=1):
#   progress.sh STAGE OUTPUT STAMP
# the stage, the file it wrote with its points (a PLY header's vertex
# count), and the seconds since STAMP (written as the stage started,
# removed here).
set -u
stage=$1 out=$2 stamp=$3
now=$(date +%s.%N)
t0=$(cat "$stamp" 2>/dev/null || echo "$now")
rm -f "$stamp"
points=$(LC_ALL=C head -c 65536 "$out" 2>/dev/null | LC_ALL=C grep -a -m1 '^element vertex ' | cut -d' ' -f3)
printf '%s: %s%s, %s s\n' "$stage" "$out" "${points:+, $points points}" \
  "$(awk -v a="$t0" -v b="$now" 'BEGIN { printf "%.1f", b - a }')" >&2
