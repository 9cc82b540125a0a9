#!/usr/bin/env bash
# Measures the run times the docs quote (README.md, scenes/README.md,
# docs/scene-format.md and the scene files' comments) again: each scene run
# as a user runs it, `firn run SCENE` with its pictures, on the CPU backend,
# with the release build. It prints the CPU (`firn info`'s lines), the
# build, the load average before and after each run and the wall time, so
# that a figure copied into the docs says where and under what load it was
# measured.
#
#   scripts/measure-doc-times.sh [SCENE...]
#
# Without scenes it measures those the docs give times for. FIRN=path times
# that binary instead of target/release/firn (which it builds first).
# RUNS=N runs each scene N times (default 1). Besides the wall time it
# prints the CPU time (user + system, all threads), which other programs on
# the machine inflate far less. The load average counts the run itself once
# it has started: compare the figure before a run with the machine's core
# count to see whether anything else was running.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-1}
if [ -z "${FIRN:-}" ]; then
    cargo build --release --quiet -p firn-cli
fi
firn=${FIRN:-target/release/firn}
if [ $# -eq 0 ]; then
    set -- scenes/snowball-wall.toml scenes/snowball-crosswind.toml scenes/cornice.toml scenes/smoke-pot.toml
fi

load() {
    if [ -r /proc/loadavg ]; then cut -d' ' -f1-3 /proc/loadavg; else echo unknown; fi
}

"$firn" info | grep -E '^(firn|cpu)'
echo "binary: $firn, checkout: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
echo "date: $(date -u '+%Y-%m-%d %H:%M UTC')"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
TIMEFORMAT='%R %U %S'
for scene in "$@"; do
    for run in $(seq 1 "$runs"); do
        before=$(load)
        if ! { time "$firn" run "$scene" --out "$out/run" --backend cpu --quiet 2>"$out/stderr"; } 2>"$out/time"; then
            cat "$out/stderr" >&2
            exit 1
        fi
        after=$(load)
        read -r wall user system <"$out/time"
        awk -v s="$scene" -v r="$run" -v w="$wall" -v u="$user" -v y="$system" -v lb="$before" -v la="$after" \
            'BEGIN { printf "%s run %d: %.1f s wall, %.1f s CPU (load average %s before, %s after)\n", s, r, w, u + y, lb, la }'
        rm -rf "$out/run"
    done
done
