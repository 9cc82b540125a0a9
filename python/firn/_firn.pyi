"""Type stubs of firn's native module (``firn._firn``)."""

from os import PathLike
from typing import Any, Callable, Dict, Literal, Optional, Union

import numpy as np
import numpy.typing as npt

__version__: str

Backend = Literal["cpu", "gpu", "auto"]
Style = Literal["points", "volume", "billboards", "trails"]
Progress = Callable[[Dict[str, Any]], Any]

class SceneError(ValueError):
    """A scene that is not valid; the message names the file, line and key,
    what is wrong and how to fix it, as the command line does."""

    file: str
    line: Optional[int]
    column: Optional[int]
    key: Optional[str]
    hint: str

class SimulationError(RuntimeError):
    """A simulation that cannot start or go on (no GPU, a blow-up, an
    unwritable run directory)."""

class Scene:
    """A valid scene with the keys of firn's TOML scene format."""

    @staticmethod
    def load(path: Union[str, PathLike[str]]) -> Scene:
        """Loads and validates a scene file (TOML)."""
    @staticmethod
    def default() -> Scene:
        """The bundled default scene (``firn run`` without a scene file)."""
    @staticmethod
    def from_dict(values: Dict[str, Any], origin: str = "<dict>") -> Scene:
        """A scene from nested dicts and lists with the keys of the TOML
        format; errors name ``origin`` and a line of ``to_toml()``."""
    def to_dict(self) -> Dict[str, Any]:
        """The scene's keys as nested dicts and lists."""
    def to_toml(self) -> str:
        """The scene as TOML text."""
    def validate(self) -> None:
        """Checks the scene again (it is always valid)."""
    def __getitem__(self, path: str) -> Any:
        """The value at a key path such as ``"bodies[0].velocity"``."""
    def __setitem__(self, path: str, value: Any) -> None:
        """Sets a key path and validates; raises SceneError and keeps the
        old value if the scene would not be valid."""
    def __contains__(self, path: str) -> bool:
        """Whether the scene sets a key path."""
    @property
    def name(self) -> str:
        """The scene's name."""
    @property
    def kind(self) -> Literal["snow", "flow"]:
        """What the scene simulates."""
    @property
    def fps(self) -> float:
        """Frames per second of the output."""
    @property
    def duration(self) -> float:
        """Simulated seconds."""
    @property
    def frame_count(self) -> int:
        """Frames after frame 0."""
    @property
    def origin(self) -> str:
        """Where the scene came from."""

class Solver:
    """A scene running on some backend; stepping releases the GIL and stops
    cleanly on Ctrl-C (KeyboardInterrupt) between substeps or frames."""

    def step(self, substeps: int = 1) -> int:
        """Takes substeps; returns how many were taken."""
    def advance_frames(self, frames: int = 1, progress: Optional[Progress] = None) -> int:
        """Steps whole frames; returns the frame reached. ``progress`` gets
        a dict (frame, time, substeps, substeps_per_second,
        elapsed_seconds, eta_seconds) after each frame."""
    def advance_to(self, time: float, progress: Optional[Progress] = None) -> int:
        """Steps to a simulated time in seconds; returns the substeps taken."""
    @property
    def time(self) -> float:
        """Simulated time in seconds."""
    @property
    def substeps(self) -> int:
        """Substeps taken so far."""
    @property
    def frame(self) -> int:
        """Frames completed so far."""
    @property
    def backend(self) -> Literal["cpu", "gpu"]:
        """Where the simulation runs."""
    @property
    def scene(self) -> Scene:
        """The scene simulated."""
    @property
    def memory_bytes(self) -> int:
        """Bytes the simulation holds (host or device buffers)."""
    def render(
        self, width: Optional[int] = None, height: Optional[int] = None, style: Optional[Style] = None
    ) -> npt.NDArray[np.uint8]:
        """The simulation now through the scene's camera, in ``style``
        (default: the scene's first ``[render] styles``) at ``width`` x
        ``height`` pixels (default: ``[render] size``, each side 16 to 8192):
        an (height, width, 3) sRGB array, the pixels of ``firn run``'s PNG."""
    def project(
        self, points: npt.ArrayLike, width: Optional[int] = None, height: Optional[int] = None
    ) -> npt.NDArray[np.float64]:
        """Where (M, 3) points fall in a picture of ``width`` x ``height``
        rendered now: (M, 2) pixel coordinates, x right and y down from the
        top-left corner; NaN behind the camera."""
    def __len__(self) -> int:
        """Particles."""

class Simulation(Solver):
    """Snow. Arrays are copies in the solver's current particle order."""

    def __init__(self, scene: Scene, backend: Backend = "cpu", threads: Optional[int] = None) -> None:
        """Starts a snow scene at time 0."""
    positions: npt.NDArray[np.float32]
    """Positions in metres, (N, 3); settable from finite (N, 3) numbers."""
    velocities: npt.NDArray[np.float32]
    """Velocities in m/s, (N, 3); settable from finite (N, 3) numbers."""
    @property
    def elastic_deformation(self) -> npt.NDArray[np.float32]:
        """F_E, (N, 3, 3), row-major."""
    @property
    def plastic_j(self) -> npt.NDArray[np.float32]:
        """J_P = det F_P, (N,)."""
    @property
    def density(self) -> npt.NDArray[np.float32]:
        """Densities in kg/m^3, (N,)."""
    @property
    def masses(self) -> npt.NDArray[np.float32]:
        """Masses in kg, (N,)."""
    @property
    def material(self) -> npt.NDArray[np.uint16]:
        """Material indices, (N,)."""

class FlowSimulation(Solver):
    """A curl-noise flow. Arrays are copies in the flow's current order."""

    def __init__(self, scene: Scene, backend: Backend = "cpu", threads: Optional[int] = None) -> None:
        """Starts a flow scene at time 0."""
    @property
    def positions(self) -> npt.NDArray[np.float32]:
        """Positions in metres, (N, 3)."""
    @property
    def velocities(self) -> npt.NDArray[np.float32]:
        """Velocities of the last step in m/s, (N, 3)."""
    @property
    def ages(self) -> npt.NDArray[np.float32]:
        """Ages in seconds, (N,)."""
    @property
    def lifetimes(self) -> npt.NDArray[np.float32]:
        """Lifetimes in seconds, (N,)."""
    def velocity_at(self, points: npt.ArrayLike, time: Optional[float] = None) -> npt.NDArray[np.float64]:
        """The field's velocity at (M, 3) points, (M, 3)."""
    def divergence_at(
        self, points: npt.ArrayLike, time: Optional[float] = None, h: float = 1e-4
    ) -> npt.NDArray[np.float64]:
        """The field's divergence at (M, 3) points by central differences, (M,)."""

def run(
    scene: Scene,
    out: Optional[Union[str, PathLike[str]]] = None,
    frames: Optional[int] = None,
    render: bool = True,
    resume: bool = False,
    backend: Optional[Backend] = None,
    progress: Optional[Progress] = None,
) -> str:
    """A whole run as ``firn run`` makes it; returns the run directory.

    An exception raised by ``progress``, or Ctrl-C (KeyboardInterrupt),
    stops the run after the frame being simulated and is raised; the run
    directory then ends at that frame with a checkpoint of it (its manifest
    says ``running``, as after a killed ``firn run``), and ``resume=True``
    continues it to the same bytes as a run never stopped."""
