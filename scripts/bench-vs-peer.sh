#!/usr/bin/env bash
# Runs `firn bench` and the peer Taichi script side by side on this machine,
# at the same particle count and grid, and prints both figures and the ratio.
# firn runs on the CPU (--backend cpu), as the peer does.
#
#   scripts/bench-vs-peer.sh [PARTICLES] [GRID] [STEPS] [RUNS]
#
# With RUNS > 1 the two alternate, firn then the peer, RUNS times, and the
# last lines give the median ratio of each transfer scheme: on a shared
# machine single runs of either drift by tens of percent.
#
# The peer is the repository's Taichi script, scripts/peer/taichi_snow.py
# (PEER=path runs another). It needs a Python with Taichi, given as
# PYTHON=path: python3 -m venv .venv-peer && .venv-peer/bin/pip install taichi,
# then PYTHON=.venv-peer/bin/python scripts/bench-vs-peer.sh ...
set -euo pipefail
cd "$(dirname "$0")/.."
particles=${1:-262144}
grid=${2:-128}
steps=${3:-200}
runs=${4:-1}
peer=${PEER:-scripts/peer/taichi_snow.py}
python=${PYTHON:-python3}
if ! [[ $runs =~ ^[1-9][0-9]*$ ]]; then
    echo "bench-vs-peer.sh: RUNS (the fourth argument) must be a whole number of at least 1, not '$runs'" >&2
    exit 2
fi

cargo build --release --quiet
ratios=target/bench-ratios.txt
: >"$ratios"
for run in $(seq 1 "$runs"); do
    ./target/release/firn bench --backend cpu --particles "$particles" --grid "$grid" --steps "$steps" --warmup 10 \
        --json target/bench-firn.json | tee target/bench-firn.txt
    "$python" "$peer" --particles "$particles" --grid "$grid" --steps "$steps" --shape ball | tee target/bench-peer.txt

    peer_ns=$(grep -o 'ns_per_particle_step=[0-9.]*' target/bench-peer.txt | tail -1 | cut -d= -f2)
    grep '^firn ' target/bench-firn.txt | while read -r line; do
        transfer=$(grep -o 'transfer=[a-z-]*' <<<"$line" | cut -d= -f2)
        ns=$(grep -o 'ns_per_particle_step=[0-9.]*' <<<"$line" | cut -d= -f2)
        awk -v r="$run" -v t="$transfer" -v f="$ns" -v p="$peer_ns" \
            'BEGIN { printf "run %d %-9s firn %7.1f ns  peer %7.1f ns  peer/firn = %.2fx\n", r, t, f, p, p / f }'
    done | tee -a "$ratios"
done

if [ "$runs" -gt 1 ]; then
    for transfer in $(awk '{ print $3 }' "$ratios" | sort -u); do
        awk -v t="$transfer" '$3 == t { sub("x", "", $NF); print $NF }' "$ratios" | sort -g |
            awk -v t="$transfer" -v n="$runs" '{ r[NR] = $1 }
                END { m = (NR % 2) ? r[(NR + 1) / 2] : (r[NR / 2] + r[NR / 2 + 1]) / 2;
                      printf "%-9s median peer/firn = %.2fx over %d runs (%.2fx to %.2fx)\n", t, m, n, r[1], r[NR] }'
    done
fi
