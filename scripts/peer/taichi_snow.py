#!/usr/bin/env python3
"""firn's peer: one 3D explicit MLS-MPM / APIC snow step in Taichi, on the CPU.

This is the reference firn's speed is compared against
(scripts/bench-vs-peer.sh, docs/benchmarks.md). It is a plain, standard
Taichi program, written the way a Taichi user would write it, so that the
comparison is against ordinary good practice and not against a straw man:

* quadratic B-spline weights, a 3x3x3 stencil, APIC affine momentum
  (Jiang et al. 2015) in the MLS-MPM form (Hu et al. 2018), float32;
* Stomakhin et al. 2013 snow (the SPEC's Part A; paper eqs. 34-36 and 41-43):
  fixed-corotated energy with hardening mu, lambda = (mu0, lambda0) *
  exp(xi (1 - J_P)); plasticity clamps the singular values of
  F^_E = (I + dt C_p) F_E to [1 - theta_c, 1 + theta_s] and moves the rest
  into J_P; E = 1.4e5 Pa, nu = 0.2, xi = 10, theta_c = 2.5e-2,
  theta_s = 7.5e-3, rho = 400 kg/m^3 (Stomakhin's Table 2);
* the Kirchhoff stress tau = 2 mu (F_E - R_E) F_E^T + lambda (J_E - 1) J_E I,
  scattered as -dt V_p^0 (4/h^2) tau (x_i - x_p) w_ip together with the
  APIC term m_p C_p (x_i - x_p) w_ip (the SPEC's "stress in the form that
  avoids inverting F");
* Taichi's own ti.svd, atomic adds in the scatter, no particle sorting
  (unless --presort), and one Taichi kernel per step: clear the grid,
  particle to grid (with plasticity and stress), grid velocities (gravity
  9.8, walls), grid to particle (v_p, C_p = (4/h^2) sum w v_i (x_i - x_p)^T,
  x_p += dt v_p).

Walls: grid nodes closer than --wall (0.05) to a face of the unit box lose
the velocity component that points into that face (separating slip), or,
with --boundary sticky, their whole velocity.

Scene (firn bench's performance scene): a ball (--shape ball, as
scripts/bench-vs-peer.sh runs it) or a cube (the default) of snow, 0.3 across,
centred at (0.5, 0.6, 0.5), particles placed uniformly at random (seed 1),
at rest, each with an equal share of the body's volume. It falls freely
(centre of mass y0 - g t^2 / 2) until it lands at t = 0.286 s.

Timing covers only the --steps timed steps; the --warmup steps before them
(10; they include Taichi's JIT compile) advance the simulation but are not
timed. Both ends are bracketed by ti.sync(). The last line printed is
machine-readable:

  taichi particles=N grid=G steps=S seconds=T ns_per_particle_step=X \
dt=DT sim_time=T com_y=Y [com_t=T com_y_at_t=Y]

where ns_per_particle_step = seconds / (steps * N) and includes the dense
grid passes (G^3 nodes) of every step; com_t and com_y_at_t are the time and
height of the centre of mass at the step nearest to --com-at (0.5 s)
when the run gets that far.

Needs Taichi and NumPy (`python3 -m venv .venv-peer &&
.venv-peer/bin/pip install taichi`; tested with Taichi 1.7.4, Python 3.11).
"""

import argparse
import math
import time

import numpy as np
import taichi as ti

GRAVITY = 9.8
YOUNG, POISSON, DENSITY = 1.4e5, 0.2, 400.0
HARDENING, THETA_C, THETA_S = 10.0, 2.5e-2, 7.5e-3
MU0 = YOUNG / (2.0 * (1.0 + POISSON))
LAMBDA0 = YOUNG * POISSON / ((1.0 + POISSON) * (1.0 - 2.0 * POISSON))


def arguments():
    """The command line."""
    cli = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    cli.add_argument("--particles", type=int, default=32768, help="particle count")
    cli.add_argument(
        "--grid", type=int, default=64, help="grid cells along each side of the unit box"
    )
    cli.add_argument("--steps", type=int, default=1000, help="timed steps")
    cli.add_argument(
        "--warmup",
        type=int,
        default=10,
        help="untimed steps first (JIT compile); they advance the run",
    )
    cli.add_argument(
        "--dt", type=float, default=None, help="time step (default 0.0128 h: 2e-4 s on 64^3)"
    )
    cli.add_argument(
        "--threads", type=int, default=0, help="CPU threads (0: Taichi's default, every core)"
    )
    cli.add_argument("--f64", action="store_true", help="double precision instead of float32")
    cli.add_argument("--shape", default="cube", choices=["cube", "ball"])
    cli.add_argument("--size", type=float, default=0.3, help="cube side or ball diameter")
    cli.add_argument(
        "--center", type=float, nargs=3, default=[0.5, 0.6, 0.5], help="centre of the body"
    )
    cli.add_argument("--boundary", default="slip", choices=["slip", "sticky"])
    cli.add_argument(
        "--wall",
        type=float,
        default=0.05,
        help="nodes closer than this to a face take the wall condition",
    )
    cli.add_argument(
        "--presort",
        action="store_true",
        help="order the particles by grid cell once, before the run",
    )
    cli.add_argument(
        "--com-at",
        type=float,
        default=0.5,
        help="report the centre of mass at this time (0: never)",
    )
    cli.add_argument("--seed", type=int, default=1, help="seed of the particle placement")
    args = cli.parse_args()
    if args.particles < 1 or args.grid < 8 or args.steps < 0 or args.warmup < 0:
        cli.error("need --particles >= 1, --grid >= 8, --steps >= 0 and --warmup >= 0")
    if args.wall < 2.0 / args.grid:
        cli.error(
            f"--wall {args.wall} is under two cells (2/{args.grid}): snow would reach the edge"
        )
    return args


def place_particles(args):
    """Uniformly random positions filling the body, and the body's volume."""
    rng = np.random.default_rng(args.seed)
    n, size = args.particles, args.size
    if args.shape == "cube":
        offsets = size * (rng.random((n, 3)) - 0.5)
        volume = size**3
    else:
        radius = 0.5 * size
        directions = rng.normal(size=(n, 3))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        offsets = directions * (radius * np.cbrt(rng.random(n)))[:, None]
        volume = 4.0 / 3.0 * math.pi * radius**3
    return np.asarray(args.center) + offsets, volume


def by_cell(positions, grid):
    """The positions reordered by the linear index of their grid cell."""
    cell = np.clip(np.floor(positions * grid).astype(np.int64), 0, grid - 1)
    key = (cell[:, 0] * grid + cell[:, 1]) * grid + cell[:, 2]
    return positions[np.argsort(key, kind="stable")]


class Snow:
    """The particles, the dense grid and the step kernel."""

    def __init__(self, args, positions, body_volume):
        real = ti.f64 if args.f64 else ti.f32
        n, g = len(positions), args.grid
        self.n = n
        self.dx = 1.0 / g
        self.particle_volume = body_volume / n
        self.particle_mass = DENSITY * self.particle_volume
        self.x = ti.Vector.field(3, real, n)
        self.v = ti.Vector.field(3, real, n)
        self.affine = ti.Matrix.field(3, 3, real, n)
        self.elastic = ti.Matrix.field(3, 3, real, n)
        self.plastic_j = ti.field(real, n)
        self.node_momentum = ti.Vector.field(3, real, (g, g, g))
        self.node_mass = ti.field(real, (g, g, g))
        self.x.from_numpy(positions.astype(np.float64 if args.f64 else np.float32))
        self.v.fill(0.0)
        self.affine.fill(0.0)
        self.elastic.from_numpy(
            np.broadcast_to(np.eye(3), (n, 3, 3)).astype(np.float64 if args.f64 else np.float32)
        )
        self.plastic_j.fill(1.0)
        self.step = self.compile(real, args.wall, args.boundary == "sticky")

    def compile(self, real, wall, sticky):
        """The step kernel, with this run's sizes and constants built in."""
        x, v, affine, elastic, plastic_j = self.x, self.v, self.affine, self.elastic, self.plastic_j
        node_momentum, node_mass = self.node_momentum, self.node_mass
        dx, inv_dx = self.dx, 1.0 / self.dx
        volume, mass = self.particle_volume, self.particle_mass
        apic_scale = 4.0 * inv_dx * inv_dx  # M_p^-1 of quadratic B-splines

        @ti.func
        def stencil(position):
            """The stencil's first node, the offset from it in cells, and the
            quadratic B-spline weights along each axis."""
            cell = position * inv_dx
            base = ti.cast(cell - 0.5, ti.i32)
            frac = cell - base
            weights = [0.5 * (1.5 - frac) ** 2, 0.75 - (frac - 1.0) ** 2, 0.5 * (frac - 0.5) ** 2]
            return base, frac, weights

        @ti.func
        def yield_and_stress(p, dt):
            """Plasticity on F^_E = (I + dt C_p) F_E, then the Kirchhoff stress."""
            identity = ti.Matrix.identity(real, 3)
            u, sigma, w = ti.svd((identity + dt * affine[p]) @ elastic[p])
            j_plastic = plastic_j[p]
            j_elastic = 1.0
            for d in ti.static(range(3)):
                clamped = ti.min(ti.max(sigma[d, d], 1.0 - THETA_C), 1.0 + THETA_S)
                j_plastic *= sigma[d, d] / clamped
                j_elastic *= clamped
                sigma[d, d] = clamped
            f_e = u @ sigma @ w.transpose()
            elastic[p] = f_e
            plastic_j[p] = j_plastic
            hardening = ti.exp(HARDENING * (1.0 - j_plastic))
            rotation = u @ w.transpose()
            return (
                2.0 * MU0 * hardening * (f_e - rotation) @ f_e.transpose()
                + (LAMBDA0 * hardening * j_elastic * (j_elastic - 1.0)) * identity
            )

        @ti.func
        def wall_velocity(node, velocity):
            """The wall condition on a node's velocity."""
            position = node.cast(real) * dx
            near = False
            for d in ti.static(range(3)):
                if position[d] < wall:
                    near = True
                    velocity[d] = ti.max(velocity[d], 0.0)
                if position[d] > 1.0 - wall:
                    near = True
                    velocity[d] = ti.min(velocity[d], 0.0)
            if ti.static(sticky):
                if near:
                    velocity = ti.Vector.zero(real, 3)
            return velocity

        @ti.kernel
        def step(dt: real):
            for node in ti.grouped(node_mass):
                node_momentum[node] = ti.Vector.zero(real, 3)
                node_mass[node] = 0.0
            for p in x:
                base, frac, weights = stencil(x[p])
                tau = yield_and_stress(p, dt)
                momentum_affine = mass * affine[p] - (dt * volume * apic_scale) * tau
                momentum = mass * v[p]
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    offset = ti.Vector([i, j, k])
                    weight = weights[i][0] * weights[j][1] * weights[k][2]
                    to_node = (offset.cast(real) - frac) * dx
                    node_momentum[base + offset] += weight * (momentum + momentum_affine @ to_node)
                    node_mass[base + offset] += weight * mass
            for node in ti.grouped(node_mass):
                if node_mass[node] > 0.0:
                    velocity = node_momentum[node] / node_mass[node]
                    velocity.y -= dt * GRAVITY
                    node_momentum[node] = wall_velocity(node, velocity)
            for p in x:
                base, frac, weights = stencil(x[p])
                velocity = ti.Vector.zero(real, 3)
                gradient = ti.Matrix.zero(real, 3, 3)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    offset = ti.Vector([i, j, k])
                    weight = weights[i][0] * weights[j][1] * weights[k][2]
                    to_node = (offset.cast(real) - frac) * dx
                    node_velocity = node_momentum[base + offset]
                    velocity += weight * node_velocity
                    gradient += (apic_scale * weight) * node_velocity.outer_product(to_node)
                v[p] = velocity
                affine[p] = gradient
                # Only a guard that keeps the stencil inside the grid; the
                # walls stop the snow well before it binds.
                x[p] = ti.min(ti.max(x[p] + dt * velocity, dx), 1.0 - 2.0 * dx)

        return step

    def centre_of_mass(self):
        """The mean particle position (every particle has the same mass)."""
        return self.x.to_numpy().astype(np.float64).mean(axis=0)


def main():
    """Runs the warm-up and the timed steps and prints the figures."""
    args = arguments()
    ti_options = {"arch": ti.cpu, "default_fp": ti.f64 if args.f64 else ti.f32}
    if args.threads > 0:
        ti_options["cpu_max_num_threads"] = args.threads
    ti.init(**ti_options)

    positions, body_volume = place_particles(args)
    if args.presort:
        positions = by_cell(positions, args.grid)
    snow = Snow(args, positions, body_volume)
    dt = args.dt if args.dt is not None else 0.0128 * snow.dx
    com_step = round(args.com_at / dt) if args.com_at > 0 else -1
    print(
        f"peer taichi_snow.py: N={snow.n} G={args.grid} dt={dt:.6g} shape={args.shape} "
        f"boundary={args.boundary} wall={args.wall} presort={args.presort} "
        f"fp={'f64' if args.f64 else 'f32'} threads={args.threads or 'default'} "
        f"com0_y={snow.centre_of_mass()[1]:.6f}",
        flush=True,
    )

    done = 0
    com_at = None

    def advance():
        nonlocal done, com_at
        snow.step(dt)
        done += 1
        if done == com_step:
            com_at = (done * dt, snow.centre_of_mass()[1])
            print(f"centre of mass at t={com_at[0]:.4f} s: y={com_at[1]:.6f}", flush=True)

    start = time.perf_counter()
    for _ in range(args.warmup):
        advance()
    ti.sync()
    warmup_seconds = time.perf_counter() - start

    start = time.perf_counter()
    for _ in range(args.steps):
        advance()
    ti.sync()
    seconds = time.perf_counter() - start

    y = snow.x.to_numpy()[:, 1]
    com_y = snow.centre_of_mass()[1]
    j_p = snow.plastic_j.to_numpy()
    print(
        f"warm-up {args.warmup} steps {warmup_seconds:.2f} s (with the JIT compile); "
        f"y in [{y.min():.4f}, {y.max():.4f}], J_P in [{j_p.min():.4f}, {j_p.max():.4f}], "
        f"finite={bool(np.isfinite(y).all())}"
    )
    ns = seconds / (args.steps * snow.n) * 1e9 if args.steps > 0 else float("nan")
    at = f" com_t={com_at[0]:.4f} com_y_at_t={com_at[1]:.6f}" if com_at else ""
    print(
        f"taichi particles={snow.n} grid={args.grid} steps={args.steps} seconds={seconds:.3f} "
        f"ns_per_particle_step={ns:.2f} dt={dt:.6g} sim_time={done * dt:.4f} com_y={com_y:.6f}{at}"
    )


if __name__ == "__main__":
    main()
