#!/usr/bin/env bash
# `make test` on a fresh clone of this repository's HEAD, timed, as CI
# runs it (.ci/run): the figures of benches/results/HISTORY.md, "make test
# on a fresh clone". Prints the whole time, the build's (cargo's
# "Finished" line of the first build) and the integration tests' and unit
# tests' own times, and the count.
#   benches/probes/make_test_fresh.sh [SCRATCH_DIR]
# The clone goes in SCRATCH_DIR (default: a new temp directory), removed
# at the end. Run it with nothing else busy: the build is as long as its
# CPU on two cores.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
scratch=${1:-$(mktemp -d)}
clone=$scratch/pcsss-fresh
rm -rf "$clone"
trap 'rm -rf "$clone"' EXIT
git clone -q "$root" "$clone"
cd "$clone"
start=$(date +%s.%N)
make test >make-test.log 2>&1 || { tail -30 make-test.log >&2; exit 1; }
end=$(date +%s.%N)
awk -v s="$start" -v e="$end" 'BEGIN { t = e - s; printf "make test: %d min %.0f s (%.0f s)\n", t / 60, t % 60, t }'
grep -m1 -o 'Finished .* in .*' make-test.log | sed 's/^/build: /'
grep -o 'test result: .*' make-test.log | sed 's/^/tests: /'
tail -1 make-test.log
