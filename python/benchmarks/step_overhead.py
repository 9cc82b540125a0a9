"""The cost of a Python step call: `Simulation.step(1)` called N times
against `step(N)` on a twin simulation of the same scene, alternated every
8 substeps over rounds, at about 4k particles (the default scene) and 262k (the same
snowball, a hair smaller, on a grid four times finer); and, given the Rust
`step_cost` example, the same scene files stepped by firn-run's `Solver`
with no Python at all.

    cargo build --release --manifest-path python/Cargo.toml --example step_cost
    python python/benchmarks/step_overhead.py --rust python/target/release/examples/step_cost

Each figure is the median over the rounds of CPU time (the process's, all
threads), which other programs on a shared machine do not inflate; wall
time is printed too. `step(0)` times a call that takes no substep: the
binding's fixed cost alone. Results and the machine: docs/python.md.
"""

import argparse
import pathlib
import re
import statistics
import subprocess
import tempfile
import time

import firn

WARMUP_SUBSTEPS = 10  # as the Rust example
BLOCK = 8  # substeps between two switches of the twins (step()'s chunk)


def scenes() -> dict:
    """The scenes measured and their substeps per sample, by label."""
    small = firn.Scene.default()
    large = firn.Scene.default()
    # Four times finer: 64 times the particles at the same particles per
    # cell (268,156); the radius brings that to 262,530.
    large["domain.cell_size"] = small["domain.cell_size"] / 4
    large["bodies[0].radius"] = 0.0993
    return {"4k": (small, 200), "262k": (large, 8)}


def timed(call) -> tuple:
    """Wall-clock and CPU seconds of `call()`."""
    wall, cpu = time.perf_counter(), time.process_time()
    call()
    return time.perf_counter() - wall, time.process_time() - cpu


def measure_python(scene: firn.Scene, substeps: int, rounds: int, threads: int) -> dict:
    """Wall and CPU seconds of `substeps` calls of step(1) and of
    step(substeps) on twin simulations, per round. The two alternate every
    BLOCK substeps (8 calls of step(1), then one step(8), the order swapped
    each round), so that both see the same machine."""
    single = firn.Simulation(scene, threads=threads)
    batch = firn.Simulation(scene, threads=threads)
    single.step(WARMUP_SUBSTEPS)
    batch.step(WARMUP_SUBSTEPS)

    def one_by_one():
        """BLOCK Python calls of one substep each."""
        for _ in range(BLOCK):
            single.step(1)

    times = {"single": [], "batch": []}
    for round_ in range(rounds):
        order = [("single", one_by_one), ("batch", lambda: batch.step(BLOCK))]
        if round_ % 2:
            order.reverse()
        total = {"single": [0.0, 0.0], "batch": [0.0, 0.0]}
        for _ in range(substeps // BLOCK):
            for name, call in order:
                wall, cpu = timed(call)
                total[name][0] += wall
                total[name][1] += cpu
        for name in times:
            times[name].append(tuple(total[name]))
    assert single.substeps == batch.substeps
    return {"particles": len(single), **times}


def bare_call_us(scene: firn.Scene, calls: int = 100_000) -> float:
    """Microseconds of CPU per `step(0)` call: the binding without a substep."""
    sim = firn.Simulation(scene, threads=1)
    cpu = time.process_time()
    for _ in range(calls):
        sim.step(0)
    return (time.process_time() - cpu) / calls * 1e6


def measure_rust(binary: str, scene: firn.Scene, substeps: int, rounds: int, threads: int) -> dict:
    """Wall and CPU milliseconds per substep of the Rust example, per round."""
    with tempfile.TemporaryDirectory() as folder:
        path = pathlib.Path(folder) / "scene.toml"
        path.write_text(scene.to_toml())
        out = subprocess.run(
            [binary, str(path), str(substeps), str(rounds), str(threads)],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
    rounds = re.findall(r"([0-9.]+) ms wall, ([0-9.]+) ms cpu", out)
    return {"wall": [float(w) for w, _ in rounds], "cpu": [float(c) for _, c in rounds]}


def main() -> None:
    """Measures each scene and prints a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="rounds per measurement (alternated)")
    parser.add_argument("--threads", type=int, default=1, help="worker threads of every solver")
    parser.add_argument("--rust", help="the step_cost example binary, to measure Rust alone too")
    parser.add_argument("--sizes", default="4k,262k", help="which scenes: 4k, 262k or both")
    args = parser.parse_args()

    print(f"step(0), the binding alone: {bare_call_us(firn.Scene.default()):.2f} us of CPU per call\n")
    print(
        "| particles | N | step(1) x N, ms/substep | step(N), ms/substep | overhead per step(1) call "
        "| overhead | Rust, ms/substep | step(N) vs Rust |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for label, (scene, substeps) in scenes().items():
        if label not in args.sizes.split(","):
            continue
        python = measure_python(scene, substeps, args.rounds, args.threads)
        cpu = {name: statistics.median(t[1] for t in python[name]) / substeps for name in ("single", "batch")}
        wall = {name: statistics.median(t[0] for t in python[name]) / substeps for name in ("single", "batch")}
        per_call_us = (cpu["single"] - cpu["batch"]) * 1e6
        rust_cell, versus = "-", "-"
        if args.rust:
            rust = measure_rust(args.rust, scene, substeps, args.rounds, args.threads)
            rust_cpu = statistics.median(rust["cpu"])
            rust_cell = f"{rust_cpu:.3f} (wall {statistics.median(rust['wall']):.3f})"
            versus = f"{(cpu['batch'] * 1e3 - rust_cpu) / rust_cpu * 100:+.1f} %"
        print(
            f"| {python['particles']} | {substeps} | {cpu['single'] * 1e3:.3f} (wall {wall['single'] * 1e3:.3f}) "
            f"| {cpu['batch'] * 1e3:.3f} (wall {wall['batch'] * 1e3:.3f}) | {per_call_us:+.1f} us "
            f"| {(cpu['single'] - cpu['batch']) / cpu['batch'] * 100:+.2f} % | {rust_cell} | {versus} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
