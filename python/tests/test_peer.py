"""The peer of scripts/bench-vs-peer.sh is part of the repository, so that the
comparison with Taichi runs from a clone; where Taichi is installed, the peer
runs and prints the line the script reads."""

import importlib.util
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
BENCH = ROOT / "scripts" / "bench-vs-peer.sh"


def default_peer() -> pathlib.Path:
    """The peer script bench-vs-peer.sh runs when PEER is not set."""
    found = re.search(r"^peer=\$\{PEER:-([^}]+)\}$", BENCH.read_text(), re.MULTILINE)
    assert found, "bench-vs-peer.sh has no `peer=${PEER:-path}` line"
    return ROOT / found.group(1)


def test_the_default_peer_is_a_file_of_the_repository():
    peer = default_peer().resolve()
    assert peer.is_relative_to(ROOT), f"the default peer {peer} is outside the repository {ROOT}"
    assert peer.is_file(), f"the default peer {peer} does not exist"
    assert "import taichi" in peer.read_text()


def test_no_readme_doc_or_script_points_outside_the_repository():
    files = [
        ROOT / "README.md",
        *ROOT.glob("docs/**/*.md"),
        *(p for p in ROOT.glob("scripts/**/*") if p.is_file()),
    ]
    outside = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in files
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1)
        if "../shared/" in line or "shared/peers" in line
    ]
    assert not outside, "paths outside the repository:\n" + "\n".join(outside)


def fields(line: str) -> dict:
    """The key=value pairs of one line."""
    return dict(pair.split("=", 1) for pair in line.split() if "=" in pair)


@pytest.mark.skipif(
    importlib.util.find_spec("taichi") is None,
    reason="taichi is not installed (pip install taichi)",
)
def test_the_peer_falls_freely_and_prints_the_line_the_bench_script_reads():
    warmup, steps, dt = 2, 5, 2e-3
    options = f"--particles 4096 --grid 64 --shape ball --warmup {warmup} --steps {steps} --dt {dt}"
    run = subprocess.run(
        [sys.executable, str(default_peer()), *options.split(), "--threads", "1"],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    lines = run.stdout.strip().splitlines()
    last = fields(lines[-1])
    assert lines[-1].startswith("taichi "), lines[-1]
    assert (last["particles"], last["grid"], last["steps"]) == ("4096", "64", str(steps))
    assert float(last["seconds"]) > 0 and float(last["ns_per_particle_step"]) > 0
    # Free fall before the landing: after n steps of symplectic Euler the
    # centre of mass has dropped by g dt^2 n (n + 1) / 2.
    start = float(fields(next(line for line in lines if "com0_y=" in line))["com0_y"])
    n = warmup + steps
    assert float(last["com_y"]) == pytest.approx(start - 9.8 * dt * dt * n * (n + 1) / 2, abs=2e-6)
