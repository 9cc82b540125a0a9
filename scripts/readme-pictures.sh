#!/usr/bin/env bash
# Regenerates the pictures in the README (docs/images/): from the bundled
# default scene a still and a short animated GIF per snow style, and a
# still of the curl-noise demo's trails after two seconds.
#
#   scripts/readme-pictures.sh
#
# Takes about four minutes on two cores.
set -euo pipefail
cd "$(dirname "$0")/.."
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
cargo run --release --quiet -- run --out "$out/run" --no-render --quiet
cargo run --release --quiet -- render "$out/run" --style points,volume --size 480x270 --legend --quiet
mkdir -p docs/images
for style in points volume; do
  cp "$out/run/images/$style.gif" "docs/images/snowball-wall-$style.gif"
  cp "$out/run/images/$style/frame_00004.png" "docs/images/snowball-wall-$style-impact.png"
done
cargo run --release --quiet -- run scenes/curl-noise-demo.toml --out "$out/flow" --frames 60 --quiet
cp "$out/flow/images/trails/frame_00060.png" docs/images/curl-noise-demo-trails.png
echo "docs/images updated"
