#!/usr/bin/env bash
# Regenerates the stills in scenes/README.md (scenes/images/NAME.png): each
# bundled scene is run up to the frame that tells its story and that frame's
# picture is kept, at 480x270.
#
#   scripts/scene-stills.sh [NAME ...]     (default: every scene)
#
# The bunny (183,000 particles) and the wheel (145,600 particles, ten
# minutes) dominate: about half an hour on two cores for everything.
set -euo pipefail
cd "$(dirname "$0")/.."
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

# Scene name, the frame of its still, and the style to keep.
stills=(
  "snowball-wall 12 points"
  "snowball-drop 15 volume"
  "snowball-wall-a 30 points"
  "snowball-wall-b 30 points"
  "snowball-wall-c 30 points"
  "snowball-wall-d 30 points"
  "snowball-wall-e 30 points"
  "bunny 9 points"
  "snow-on-bunny 15 points"
  "tower 27 points"
  "dry-vs-wet 15 points"
  "curl-noise-demo 60 trails"
  "snowball-crosswind 15 points"
  "smoke-pot 150 billboards"
  "cornice 10 points"
  "wheel-rut 33 points"
  "plough-swing 24 points"
  "boot-print 36 points"
  "crate-drop 30 points"
  "boulder-roll 39 points"
  "ball-row 29 points"
)

wanted=("$@")
mkdir -p scenes/images
cargo build --release --quiet
for entry in "${stills[@]}"; do
  read -r name frame style <<<"$entry"
  if [ ${#wanted[@]} -gt 0 ] && [[ ! " ${wanted[*]} " =~ " $name " ]]; then
    continue
  fi
  echo "== $name (frame $frame)"
  target/release/firn run "scenes/$name.toml" --out "$out/$name" --frames "$frame" \
    --size 480x270 --quiet
  cp "$out/$name/images/$style/$(printf 'frame_%05d.png' "$frame")" "scenes/images/$name.png"
done
echo "scenes/images updated"
