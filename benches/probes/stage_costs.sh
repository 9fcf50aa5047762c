#!/usr/bin/env bash
# What two of issue 43's choices cost, whole processes on the bake
# benchmark's 1M-point clouds (`cargo bench --bench bake` leaves them in
# target/bench/bake_{bunny,dragon}_1000000), interleaved, REPS runs each,
# the fastest kept (benches/results/HISTORY.md quotes them):
#   shadows  sssingle with shadow rays against --no-shadows, both models,
#            on the bunny and the dragon;
#   physical ssmulti's physical model against the seed model on the bunny,
#            and the seed model with the Burley falloff, channel and source
#            normalisations (what the physical model's time is made of);
#   bake     whole bakes of the default bunny scene at 1M points, the seed
#            model against the physical one at the seed's kernel distances
#            (no bench clouds needed), and the physical one with the
#            approximate method (TOL 0.2, 0.4), then the physical ssmulti on
#            that bake's cloud with shorter truncations (kappa 9, 7) and
#            with the approximate method (tolerance 0.2, 0.4).
#
#     benches/probes/stage_costs.sh [shadows|physical|bake|all]   (REPS=3)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BIN=$ROOT/target/release
REPS=${REPS:-3}
what=${1:-all}

# fastest NAME CMD...: the fastest of REPS runs of CMD, in seconds.
fastest() {
  local best=
  for _ in $(seq "$REPS"); do
    local s e t
    s=$(date +%s.%N); "$@" >/dev/null 2>&1; e=$(date +%s.%N)
    t=$(echo "$e - $s" | bc)
    if [ -z "$best" ] || [ "$(echo "$t < $best" | bc)" = 1 ]; then best=$t; fi
  done
  echo "$best"
}

if [ "$what" = shadows ] || [ "$what" = all ]; then
  for name in bunny dragon; do
    d=$ROOT/target/bench/bake_${name}_1000000
    if [ "$name" = bunny ]; then sd=0.6; mfp=0.1; else sd=0.006; mfp=0.001; fi
    for model in seed physical; do
      run() {
        "$BIN/sssingle" -q "$d/ss.ply" --mesh "$d/mesh.ply" --lights "$ROOT/fixtures/lights/$name.json" \
          --camera "$ROOT/fixtures/cameras/$name.json" --model "$model" --rd 0.9,0.5,0.3 --sd "$sd" --rgb \
          --albedo 0.8 --mfp "$mfp" --g 0.4 --eta 1.3 "$@" -o /tmp/stage_costs.ply
      }
      with=$(fastest run)
      without=$(fastest run --no-shadows)
      echo "sssingle $name $model: shadows $with s, --no-shadows $without s, ratio $(echo "scale=2; $with / $without" | bc)"
    done
  done
fi

if [ "$what" = physical ] || [ "$what" = all ]; then
  d=$ROOT/target/bench/bake_bunny_1000000
  ss() { "$BIN/ssmulti" -q "$d/illum.ply" "$@" -o /tmp/stage_costs.ply; }
  seed=$(fastest ss --rd 0.9,0.5,0.3 --sd 0.6 --rgb)
  phys=$(fastest ss --model physical --color 0.85,0.5,0.3 --dmfp 0.15,0.08,0.05 --g 0.4)
  bch=$(fastest ss --rd 0.9,0.5,0.3 --sd 0.6 --rgb --falloff burley --norm channel)
  bso=$(fastest ss --rd 0.9,0.5,0.3 --sd 0.6 --rgb --falloff burley --norm source)
  echo "ssmulti bunny: seed $seed s; physical $phys s (ratio $(echo "scale=1; $phys / $seed" | bc)); burley channel $bch s; burley source $bso s"
fi
if [ "$what" = bake ] || [ "$what" = all ]; then
  out=/tmp/stage_costs_bake
  bk() { rm -rf "$out"; make -s -C "$ROOT/pipelines" OUT="$out" COUNT=1000000 "$@"; }
  # The physical medium whose kernel distances are the seed's Rd * sd.
  medium=(MODEL=physical COLOR=0.9,0.5,0.3 DMFP=0.125,0.0695,0.0417)
  seed=$(fastest bk)
  phys=$(fastest bk "${medium[@]}")
  echo "bake bunny 1M: seed $seed s; physical $phys s (ratio $(echo "scale=2; $phys / $seed" | bc))"
  for tol in 0.2 0.4; do
    t=$(fastest bk "${medium[@]}" TOL=$tol)
    echo "bake bunny 1M: physical, TOL=$tol, $t s (ratio to the seed bake $(echo "scale=2; $t / $seed" | bc))"
  done
  bk "${medium[@]}" >/dev/null 2>&1
  for kappa in 12.952642092055077 9 7; do
    t=$(fastest "$BIN/ssmulti" -q "$out/bunny_illum.ply" --model physical --color 0.9,0.5,0.3 \
      --dmfp 0.125,0.0695,0.0417 --g 0.4 --eta 1.3 --falloff burley --sigma "$kappa" -o /tmp/stage_costs.ply)
    echo "ssmulti physical bunny 1M, kappa $kappa: $t s"
  done
  for tol in 0.2 0.4; do
    t=$(fastest "$BIN/ssmulti" -q "$out/bunny_illum.ply" --model physical --color 0.9,0.5,0.3 \
      --dmfp 0.125,0.0695,0.0417 --g 0.4 --eta 1.3 --tolerance "$tol" -o /tmp/stage_costs.ply)
    echo "ssmulti physical bunny 1M, tolerance $tol: $t s"
  done
  rm -rf "$out"
fi
rm -f /tmp/stage_costs.ply
