#!/bin/sh
# Alternates two firn builds on the CPU bench scene, both transfer schemes,
# ROUNDS times, and prints each run's line and phase profile.
#   scripts/bench-builds.sh OLD_FIRN NEW_FIRN [ROUNDS] [PARTICLES] [GRID] [STEPS]
# e.g. scripts/bench-builds.sh /tmp/firn-before target/release/firn 3
set -eu
old=$1
new=$2
rounds=${3:-3}
particles=${4:-262144}
grid=${5:-128}
steps=${6:-12}
round=1
while [ "$round" -le "$rounds" ]; do
  for build in "$old" "$new"; do
    for transfer in pic-flip apic; do
      echo "== $build, round $round"
      "$build" bench --backend cpu --particles "$particles" --grid "$grid" \
        --transfer "$transfer" --steps "$steps" --warmup 3 --phases
    done
  done
  round=$((round + 1))
done
