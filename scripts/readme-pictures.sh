#!/usr/bin/env bash
# Regenerates the pictures in the README (docs/images/) from the bundled
# default scene: a still per style and a short animated GIF per style.
#
#   scripts/readme-pictures.sh
#
# Takes about two minutes on two cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
cargo run --release --quiet -- run --out "$out/run" --no-render --quiet
cargo run --release --quiet -- render "$out/run" --style points,volume --size 480x270 --legend --quiet
mkdir -p docs/images
for style in points volume; do
  cp "$out/run/images/$style.gif" "docs/images/snowball-wall-$style.gif"
  cp "$out/run/images/$style/frame_00006.png" "docs/images/snowball-wall-$style-impact.png"
done
echo "docs/images updated"
