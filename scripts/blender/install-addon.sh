#!/usr/bin/env bash
# Installs the firn add-on into Blender (3.4 or later; Debian's package or a
# blender.org build) and enables it:
#
#   scripts/blender/install-addon.sh                 # builds the firn module
#   BLENDER=~/blender-4.2/blender scripts/blender/install-addon.sh
#   scripts/blender/install-addon.sh --module DIR    # a firn package already built
#
# 1. Asks Blender for its user scripts folder (BLENDER_USER_SCRIPTS is
#    honoured) and its Python's version.
# 2. Builds the firn Python module with maturin (release) as a wheel; the
#    module is abi3 (CPython 3.9 and later), so one build serves Debian's
#    Blender (the system's Python 3.11) and blender.org's bundled Python.
#    --module DIR copies the `firn` package in DIR instead (the folder that
#    holds firn/__init__.py and firn/_firn.abi3.so, e.g. a venv's
#    site-packages after `pip install ./python`).
# 3. Puts the module into SCRIPTS/modules (on Blender's sys.path) and the
#    add-on into SCRIPTS/addons/firn_blender, then enables it and saves the
#    preferences.
set -euo pipefail
cd "$(dirname "$0")/../.."

blender="${BLENDER:-blender}"
module_dir=""
if [ "${1:-}" = "--module" ]; then
  module_dir="${2:?--module needs the folder holding the firn package}"
fi

scripts=$("$blender" -b --factory-startup --python-expr \
  "import bpy; print('SCRIPTS=' + bpy.utils.user_resource('SCRIPTS'))" 2>/dev/null \
  | sed -n 's/^SCRIPTS=//p')
if [ -z "$scripts" ]; then
  echo "error: could not ask $blender for its scripts folder; set BLENDER to Blender's executable" >&2
  exit 2
fi
echo "Blender's user scripts: $scripts"
mkdir -p "$scripts/modules" "$scripts/addons"

if [ -z "$module_dir" ]; then
  build=$(mktemp -d)
  trap 'rm -rf "$build"' EXIT
  python3 -m venv "$build/venv"
  "$build/venv/bin/pip" install -q maturin
  "$build/venv/bin/maturin" build --release --manifest-path python/Cargo.toml --out "$build/wheel"
  python3 -m zipfile -e "$build"/wheel/firn-*.whl "$build/unpacked"
  module_dir="$build/unpacked"
fi
if [ ! -f "$module_dir/firn/__init__.py" ]; then
  echo "error: $module_dir/firn/__init__.py not found" >&2
  exit 2
fi
rm -rf "$scripts/modules/firn" "$scripts/addons/firn_blender"
cp -r "$module_dir/firn" "$scripts/modules/firn"
cp -r blender/firn_blender "$scripts/addons/firn_blender"
rm -rf "$scripts/addons/firn_blender/__pycache__"

enabled=$("$blender" -b --python-expr "
import addon_utils, bpy, firn
addon_utils.enable('firn_blender', default_set=True)
bpy.ops.wm.save_userpref()
print('INSTALLED firn', firn.__version__)
" 2>&1) || true
if ! grep -q '^INSTALLED firn' <<<"$enabled"; then
  echo "$enabled" >&2
  echo "error: Blender could not enable the add-on" >&2
  exit 1
fi
echo "firn $(sed -n 's/^INSTALLED firn //p' <<<"$enabled") and the firn add-on are installed and enabled in $blender"
