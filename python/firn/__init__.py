"""firn: snow (the Material Point Method of Stomakhin et al. 2013) and
curl-noise particle flows (Bridson et al. 2007), driven from Python.

The same library as the ``firn`` command runs underneath: a scene loaded
here and run with :func:`run` writes the same bytes as ``firn run``.

>>> import firn
>>> scene = firn.Scene.default()
>>> sim = firn.Simulation(scene, backend="cpu")
>>> sim.advance_frames(2)
2
>>> sim.positions.shape[1]
3
"""

from firn._firn import (
    FlowSimulation,
    Scene,
    SceneError,
    Simulation,
    SimulationError,
    Solver,
    __version__,
    run,
)

__all__ = [
    "FlowSimulation",
    "Scene",
    "SceneError",
    "Simulation",
    "SimulationError",
    "Solver",
    "__version__",
    "run",
]
