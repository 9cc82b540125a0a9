#!/usr/bin/env bash
# Alternates two firn builds, the order swapped every round: the CPU bench in both
# transfer schemes and the flow bench; prints each run's line (see
# docs/benchmark-history.md, 2026-11-28, for the min/median table made from them).
#   scripts/bench-ab.sh OLD_FIRN NEW_FIRN [ROUNDS]
a=$1; b=$2; rounds=${3:-10}
for r in $(seq 1 $rounds); do
  if [ $((r % 2)) = 1 ]; then order="before after"; else order="after before"; fi
  for which in $order; do
    bin=$a; [ $which = after ] && bin=$b
    for t in pic-flip apic; do
      $bin bench --backend cpu --particles 262144 --grid 128 --transfer $t --steps 40 --warmup 3 2>/dev/null | grep "^firn backend" | sed "s/^/$which /"
    done
    $bin bench --flow --backend cpu 2>/dev/null | grep "^firn flow" | sed "s/^/$which /"
  done
done
