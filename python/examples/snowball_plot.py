"""Throw the bundled snowball against its wall and plot its centre of mass
and kinetic energy over time.

    python python/examples/snowball_plot.py [OUT.png] [--seconds S]
"""

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import firn


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default="snowball.png", help="where to save the plot")
    parser.add_argument("--seconds", type=float, default=1.0, help="simulated seconds")
    args = parser.parse_args()

    scene = firn.Scene.default()
    sim = firn.Simulation(scene, backend="cpu")
    masses = sim.masses
    times, centres, energies = [], [], []
    frames = int(round(args.seconds * scene.fps))
    for _ in range(frames + 1):
        positions, velocities = sim.positions, sim.velocities
        times.append(sim.time)
        centres.append(masses @ positions / masses.sum())
        energies.append(0.5 * float(masses @ np.einsum("ij,ij->i", velocities, velocities)))
        sim.advance_frames(1)
    centres = np.array(centres)

    figure, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for axis, label in enumerate("xyz"):
        top.plot(times, centres[:, axis], label=label)
    top.set_ylabel("centre of mass (m)")
    top.legend(loc="best")
    top.set_title(f"{scene.name}: {len(sim)} particles")
    bottom.plot(times, energies, color="tab:red")
    bottom.set_ylabel("kinetic energy (J)")
    bottom.set_xlabel("time (s)")
    figure.tight_layout()
    figure.savefig(args.out, dpi=100)
    print(f"saved {args.out}")


if __name__ == "__main__":
    main()
