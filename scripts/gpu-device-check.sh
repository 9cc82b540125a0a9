#!/usr/bin/env bash
# The GPU measurements of docs/gpu.md ("Bytes per kernel (roofline)"), as one
# script for a machine with a hardware GPU: the adapter and its driver,
# `firn bench --backend gpu` for APIC and PIC/FLIP at about 1M and 8M
# particles on 256^3, the curl-noise flow at 2^20 particles on the GPU, and
# the semi-implicit solve's cost per iteration. Each step runs under a time
# limit; a step that fails or times out is recorded and the others still run.
#
# Run from anywhere: scripts/gpu-device-check.sh. Everything it writes goes
# into $OUT (default ./device-out): summary.txt (the GPU, its driver, every
# step's status and the figures), log.txt (every step's output) and
# records.txt (the JSON records). Three files, written as the steps go.
#
# The firn binary: $FIRN if set (as in scripts/measure-doc-times.sh; a
# relative path starts at the repository's root), else .devbin/firn if present, else a
# release build with cargo (several minutes with 16 cores, and the crates
# must be in cargo's cache when the machine has no network). To carry a
# build instead, on a Linux x86-64 machine:
#   cargo build --release -p firn-cli
#   mkdir -p .devbin && strip -o .devbin/firn target/release/firn
# (about 19 MB stripped). Vulkan needs the loader, libvulkan.so.1; where it
# is missing, Debian packages in .gl/ (libvulkan1 at least) are unpacked.
#
# Knobs (environment): FIRN_CHECK_BUDGET_S (whole run, default 480),
# FIRN_CHECK_SMALL and FIRN_CHECK_LARGE (particles, 1048576 and 8388608),
# FIRN_CHECK_GRID (cells per side, 256), FIRN_CHECK_FLOW (flow particles,
# 1048576), FIRN_CHECK_STEPS_SMALL and FIRN_CHECK_STEPS_LARGE (timed
# substeps, 200 and 100).
set -euo pipefail

cd "$(dirname "$0")/.."
OUT="${OUT:-./device-out}"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
SUMMARY="$OUT/summary.txt"
LOG="$OUT/log.txt"
RECORDS="$OUT/records.txt"
: >"$SUMMARY"
: >"$LOG"
: >"$RECORDS"

BUDGET_S="${FIRN_CHECK_BUDGET_S:-480}"
SMALL="${FIRN_CHECK_SMALL:-1048576}"
LARGE="${FIRN_CHECK_LARGE:-8388608}"
GRID="${FIRN_CHECK_GRID:-256}"
FLOW_PARTICLES="${FIRN_CHECK_FLOW:-1048576}"
STEPS_SMALL="${FIRN_CHECK_STEPS_SMALL:-200}"
STEPS_LARGE="${FIRN_CHECK_STEPS_LARGE:-100}"
START="$(date +%s)"

# note LINE: appends LINE to the summary and echoes it.
note() {
    echo "$*" | tee -a "$SUMMARY"
}

# step NAME LIMIT COMMAND...: runs COMMAND for at most LIMIT seconds (less
# when the budget is nearly spent), its output into $WORK/NAME.log and
# log.txt, and records how it ended. Never fails itself.
step() {
    local name="$1" limit="$2"
    shift 2
    local left=$((BUDGET_S - ($(date +%s) - START)))
    if ((left < 15)); then
        note "step $name: SKIPPED (the ${BUDGET_S} s budget is spent)"
        return 0
    fi
    if ((limit > left)); then
        limit="$left"
    fi
    local began rc=0
    began="$(date +%s)"
    echo "=== $name (limit ${limit} s): $*" >>"$LOG"
    timeout --kill-after=10 "$limit" "$@" >"$WORK/$name.log" 2>&1 || rc=$?
    cat "$WORK/$name.log" >>"$LOG"
    local took=$(($(date +%s) - began))
    if ((rc == 0)); then
        note "step $name: ok (${took} s)"
    elif ((rc == 124 || rc == 137)); then
        note "step $name: TIMED OUT after ${limit} s"
    else
        note "step $name: FAILED (exit $rc after ${took} s; see log.txt)"
    fi
    return 0
}

# keep NAME JSON: appends a JSON record, if written, to records.txt.
keep() {
    if [[ -f "$2" ]]; then
        {
            echo "### $1"
            cat "$2"
            echo
        } >>"$RECORDS"
    fi
}

# value KEY FILE: the value of the first KEY=VALUE on a `firn` line of FILE.
value() {
    awk -v key="$1" '/^firn / {
        for (i = 1; i <= NF; i++) if (index($i, key "=") == 1) { print substr($i, length(key) + 2); exit }
        exit
    }' "$2" 2>/dev/null || true
}

note "firn GPU device check, $(date -u +%Y-%m-%dT%H:%M:%SZ), budget ${BUDGET_S} s"
note "commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"

# --- the machine and the GPU ---------------------------------------------
step machine 30 bash -c 'uname -a; nproc; free -g
    nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.memory --format=csv && nvidia-smi || echo "no nvidia-smi"'
if grep -q '^name, driver_version' "$WORK/machine.log" 2>/dev/null; then
    note "gpu (nvidia-smi): $(grep -A1 '^name, driver_version' "$WORK/machine.log" | tail -1)"
fi

ldconfig -p >"$WORK/ldconfig.txt" 2>/dev/null || true
if ! grep -q 'libvulkan\.so\.1' "$WORK/ldconfig.txt"; then
    if compgen -G ".gl/*.deb" >/dev/null; then
        for package in .gl/*.deb; do
            dpkg -x "$package" /
        done
        ldconfig
        note "vulkan loader: unpacked from .gl/"
    else
        note "WARNING: no libvulkan.so.1 and no .gl/*.deb: wgpu will find no Vulkan adapter"
    fi
fi
NVIDIA_ICD=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [[ -z "${VK_DRIVER_FILES:-}" && -f "$NVIDIA_ICD" ]]; then
    export VK_DRIVER_FILES="$NVIDIA_ICD"
    note "vulkan driver: VK_DRIVER_FILES=$NVIDIA_ICD"
fi

# --- the firn binary ---------------------------------------------------------
FIRN="${FIRN:-}"
if [[ -n "$FIRN" ]]; then
    note "firn: taken from FIRN"
elif [[ -x .devbin/firn ]]; then
    FIRN="$PWD/.devbin/firn"
elif cargo --version >>"$LOG" 2>&1; then
    note "cargo: $(cargo --version)"
    step build 420 bash -c 'cargo build --release --offline -p firn-cli || cargo build --release -p firn-cli'
    FIRN="$PWD/target/release/firn"
else
    note "ERROR: no cargo on this machine (cargo --version failed) and no carried binary:"
    note "  build here with 'cargo build --release -p firn-cli', or carry one as .devbin/firn or FIRN=path"
fi
if [[ -z "$FIRN" || ! -x "$FIRN" ]]; then
    note "ERROR: no firn binary at '${FIRN}'; nothing measured"
    exit 1
fi
note "firn: $FIRN ($("$FIRN" --version 2>&1 || echo 'does not start'))"

step info 60 "$FIRN" info
grep -E '^ +[0-9]+\. |backend .*driver|^--backend auto' "$WORK/info.log" 2>/dev/null | sed 's/^/adapter: /' | tee -a "$SUMMARY" || true

# --- the snowball: APIC and PIC/FLIP at ~1M and ~8M ---------------------------
for size in small large; do
    if [[ "$size" == small ]]; then
        particles="$SMALL" steps="$STEPS_SMALL" warmup=20 limit=150
    else
        particles="$LARGE" steps="$STEPS_LARGE" warmup=10 limit=240
    fi
    step "bench-$size" "$limit" "$FIRN" bench --backend gpu --particles "$particles" \
        --grid "$GRID" --transfer both --steps "$steps" --warmup "$warmup" \
        --memory-budget-gib 100 --phases --json "$WORK/bench-$size.json"
    keep "bench-$size" "$WORK/bench-$size.json"
    grep -h '^firn \|gpu memory\|phases\|^  [a-z_ ]\+ \+[0-9.]\+ ns' "$WORK/bench-$size.log" 2>/dev/null | tee -a "$SUMMARY" || true
done
if grep -q 'phases: not measured' "$WORK"/bench-*.log 2>/dev/null; then
    note "per-stage timings: none (the adapter has no timestamp queries)"
fi

# --- the flow at 2^20 particles on the GPU -------------------------------
# The scene of `firn bench --flow` (crates/firn-cli/src/bench_flow.rs), run
# on the GPU through --scene for two durations: 60 steps per simulated
# second, so the difference of the two runs is the cost of 1,800 steps
# without the start-up.
cat >"$WORK/flow.toml" <<EOF
format = 1
name = "bench-curl-noise"
kind = "flow"

[domain]
max = [100.0, 100.0, 100.0]

[time]
duration = 100.0
fps = 60

[flow]
noise_share = 0.5
noise_strength = 40.0
length_scale = 20.0
background_strength = 12.0
evolution_rate = 0.04
curl = "analytic"
integration = "rk2"
substeps = 1

[[flow.obstacles]]
center = [50.0, 50.0, 50.0]
radius = 15.0
influence = 10.0

[[flow.emitters]]
shape = "box"
center = [50.0, 50.0, 50.0]
size = [100.0, 100.0, 100.0]
count = $FLOW_PARTICLES
EOF
for duration in 5 35; do
    step "flow-$duration" 120 "$FIRN" bench --scene "$WORK/flow.toml" --backend gpu \
        --duration "$duration" --json "$WORK/flow-$duration.json"
    keep "flow-$duration" "$WORK/flow-$duration.json"
    grep -h '^firn ' "$WORK/flow-$duration.log" 2>/dev/null | tee -a "$SUMMARY" || true
done
flow_figures() {
    local s1 w1 s2 w2 n
    s1="$(value substeps "$WORK/flow-5.log")" w1="$(value wall_s "$WORK/flow-5.log")"
    s2="$(value substeps "$WORK/flow-35.log")" w2="$(value wall_s "$WORK/flow-35.log")"
    n="$(value particles "$WORK/flow-35.log")"
    if [[ -z "$s1" || -z "$w1" || -z "$s2" || -z "$w2" ]]; then
        note "flow: no figure (a run failed or was skipped)"
        return 0
    fi
    awk -v s1="$s1" -v w1="$w1" -v s2="$s2" -v w2="$w2" -v n="$n" 'BEGIN {
        printf "flow, GPU, %d particles: %.0f steps/s over %d steps with start-up; ", n, s2 / w2, s2
        if (w2 > w1 && s2 > s1) printf "%.0f steps/s, %.3f ns per particle-step, without (the two runs'"'"' difference)\n", (s2 - s1) / (w2 - w1), (w2 - w1) * 1e9 / ((s2 - s1) * n)
        else printf "the difference is not positive\n"
    }' | tee -a "$SUMMARY"
}
flow_figures

# --- the semi-implicit solve's cost per iteration ----------------------------
# The snowball resting on a sticky floor (so that the solve has work from
# the first substep), 6 fixed substeps, a tolerance no f32 solve reaches:
# each solve runs to its iteration limit. Two limits; the difference of the
# runs over the difference of their iterations is the cost of one.
implicit_scene() { # FILE TRANSFER PARTICLES ITERATIONS
    awk -v grid="$GRID" -v n="$3" 'BEGIN {
        h = 1.0 / grid
        cells = 4.0 / 3.0 * 3.14159265 * (0.15 / h) ^ 3
        ppc = int(n / cells + 0.5); if (ppc < 1) ppc = 1; if (ppc > 64) ppc = 64
        printf "H=%.10g\nY=%.10g\nPPC=%d\n", h, 0.15 + 0.5 * h, ppc
    }' >"$WORK/implicit.env"
    # shellcheck disable=SC1091
    source "$WORK/implicit.env"
    cat >"$1" <<EOF
format = 1
name = "bench-snowball-semi-implicit"

[domain]
max = [1.0, 1.0, 1.0]
cell_size = $H
walls = { mode = "sticky", friction = 0.0 }

[time]
duration = 0.003
fps = 30
step = "fixed"
dt = 5e-4

[solver]
transfer = "$2"
integrator = "semi-implicit"
implicit_beta = 0.5
solver_tolerance = 1e-9
solver_max_iterations = $4

[[bodies]]
shape = "sphere"
center = [0.5, $Y, 0.5]
radius = 0.15
material = "snow"
particles_per_cell = $PPC
EOF
}
implicit_figures() { # LABEL FEW MANY
    local few="$WORK/$2.log" many="$WORK/$3.log"
    local w1 s1 i1 w2 s2 i2 n
    w1="$(value wall_s "$few")" s1="$(value substeps "$few")" i1="$(value mean_iterations "$few")"
    w2="$(value wall_s "$many")" s2="$(value substeps "$many")" i2="$(value mean_iterations "$many")"
    n="$(value particles "$many")"
    if [[ -z "$w1" || -z "$i1" || -z "$w2" || -z "$i2" ]]; then
        note "semi-implicit $1: no figure (a run failed or was skipped)"
        return 0
    fi
    awk -v l="$1" -v w1="$w1" -v s1="$s1" -v i1="$i1" -v w2="$w2" -v s2="$s2" -v i2="$i2" -v n="$n" 'BEGIN {
        d = s2 * i2 - s1 * i1
        printf "semi-implicit %s, %d particles on the grid: mean iterations %s and %s; ", l, n, i1, i2
        if (d > 0) printf "%.3f ms per iteration (%.3f ns per particle)\n", (w2 - w1) * 1e3 / d, (w2 - w1) * 1e9 / (d * n)
        else printf "no figure (the iterations did not grow)\n"
    }' | tee -a "$SUMMARY"
}
for size in small large; do
    particles="$SMALL"
    if [[ "$size" == large ]]; then
        particles="$LARGE"
    fi
    for transfer in apic pic-flip; do
        for iterations in 8 24; do
            name="implicit-$size-$transfer-$iterations"
            implicit_scene "$WORK/$name.toml" "$transfer" "$particles" "$iterations"
            step "$name" 150 "$FIRN" bench --scene "$WORK/$name.toml" --backend gpu \
                --json "$WORK/$name.json"
            keep "$name" "$WORK/$name.json"
            grep -h '^firn ' "$WORK/$name.log" 2>/dev/null | tee -a "$SUMMARY" || true
        done
        implicit_figures "$transfer $size" "implicit-$size-$transfer-8" "implicit-$size-$transfer-24"
    done
done

note "done in $(($(date +%s) - START)) s; files in $OUT"
