#!/usr/bin/env bash
# Regenerates the pictures in the README (docs/images/): from the bundled
# default scene a still and a short animated GIF per snow style, a still
# of the curl-noise demo's trails after two seconds, and GIFs of the
# treaded wheel rolling its rut and of the boot stepping into the snow
# (needs ffmpeg).
#
#   scripts/readme-pictures.sh
#
# Takes about fifteen minutes on two cores, eleven of them the wheel's.
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
# The wheel's GIF: every other frame at 400x225 in 64 colours, without
# dithering (firn's own GIF of 145,600 shimmering sprites is 2 MB).
cargo run --release --quiet -- run scenes/wheel-rut.toml --out "$out/wheel" --size 480x270 --quiet
ffmpeg -loglevel error -y -framerate 20 -i "$out/wheel/images/points/frame_%05d.png" \
  -vf "fps=10,scale=400:-1:flags=lanczos,split[a][b];[a]palettegen=max_colors=64[p];[b][p]paletteuse=dither=none" \
  docs/images/wheel-rut.gif
cargo run --release --quiet -- run scenes/boot-print.toml --out "$out/boot" --size 480x270 --quiet
ffmpeg -loglevel error -y -framerate 24 -i "$out/boot/images/points/frame_%05d.png" \
  -vf "fps=12,scale=400:-1:flags=lanczos,split[a][b];[a]palettegen=max_colors=64[p];[b][p]paletteuse=dither=none" \
  docs/images/boot-print.gif
# The rigid bodies' GIFs, as the boot's.
for scene in crate-drop boulder-roll; do
  cargo run --release --quiet -- run "scenes/$scene.toml" --out "$out/$scene" --size 480x270 --quiet
  ffmpeg -loglevel error -y -framerate 24 -i "$out/$scene/images/points/frame_%05d.png" \
    -vf "fps=12,scale=400:-1:flags=lanczos,split[a][b];[a]palettegen=max_colors=64[p];[b][p]paletteuse=dither=none" \
    "docs/images/$scene.gif"
done
echo "docs/images updated"
