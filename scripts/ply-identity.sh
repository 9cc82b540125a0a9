#!/usr/bin/env bash
# Runs the default scene, the tower, the crosswind and the cornice on the CPU with two
# firn builds and compares every frame's PLY byte for byte (the bit-identity check of
# a change that must not move results; docs/benchmark-history.md, 2026-11-28).
#   scripts/ply-identity.sh OLD_FIRN NEW_FIRN OUT_DIR
set -u
before=$1; after=$2; out=$3
mkdir -p $out
for spec in "default::30" "scenes/tower.toml:tower:24" "scenes/snowball-crosswind.toml:crosswind:30" "scenes/cornice.toml:cornice:24"; do
  scene=${spec%%:*}; rest=${spec#*:}; name=${rest%%:*}; frames=${rest#*:}
  scene_arg=$scene; [ -z "$name" ] && { name=default; scene_arg=; }
  for which in before after; do
    bin=$before; [ $which = after ] && bin=$after
    rm -rf $out/$name-$which
    /usr/bin/time -f "$name $which %e s" $bin run $scene_arg --out $out/$name-$which --frames $frames --no-render --backend cpu -q >/dev/null 2>$out/$name-$which.err || { echo "$name $which FAILED"; tail -3 $out/$name-$which.err; }
    tail -1 $out/$name-$which.err
  done
  n=0; bad=0
  for f in $(cd $out/$name-before && find . -name '*.ply' | sort); do
    n=$((n+1)); cmp -s $out/$name-before/$f $out/$name-after/$f || { bad=$((bad+1)); echo "DIFF $name $f"; }
  done
  echo "$name: $n PLYs compared, $bad differ"
done
