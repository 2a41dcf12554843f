"""Type stubs of the compiled module truss_deploy._native (re-exported by
truss_deploy). Units: m, s, kg, N, J; arrays are float64 numpy arrays."""

import os
from typing import Any, Dict, List, Literal, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

class TrussDeployError(Exception): ...

class ModelError(TrussDeployError):
    """The CLI's message: `FILE:LINE: `key`: what is wrong; the fix`."""
    file: str
    line: Optional[int]

class SolverError(TrussDeployError): ...
class SweepError(TrussDeployError): ...

class LockEventDict(TypedDict):
    element: int
    name: str
    time_s: float
    impulse_ns: float
    energy_lost_j: float
    closing_speed_m_s: float
    peak_force_n: Optional[float]
    time_of_peak_s: Optional[float]
    rigid_at_s: Optional[float]

class MotorDict(TypedDict):
    cable: str
    mode: Literal["tension", "tracking", "at_limit", "slack"]
    speed_cmd_m_s: Optional[float]
    tension_n: float
    reeled_in_m: float

class MemberDict(TypedDict):
    """A member (bar or sleeve) at the end of a run: axial force (N, tension
    positive) and length (m)."""
    name: str
    kind: Literal["bar", "sleeve"]
    axial_force_n: float
    length_m: float

class RunSummaryDict(TypedDict):
    """The summary `truss-deploy simulate --json` writes (docs/cli.md)."""
    model: str
    solver: str
    dt_s: float
    deployed: bool
    deploy_time_s: Optional[float]
    time_s: float
    steps: int
    wall_time_s: float
    final_error_rel: Optional[float]
    max_constraint_violation_m: float
    energy_balance_rel_error: float
    dof_initial: int
    dof_final: int
    kinetic_energy_j: float
    energy: Dict[str, float]
    locks: List[LockEventDict]
    stop_reason: Literal["deployed", "until", "end_time", "stalled", "interrupted", "error"]
    stop_message: str
    error: Optional[str]
    solver_stats: Dict[str, Any]
    accepting_fallbacks: int
    motors: List[MotorDict]
    members: List[MemberDict]

_Path = Union[str, os.PathLike[str]]

class Model:
    """A truss model (a model file's document), changed by name and checked
    by the loader after every change."""
    @staticmethod
    def load(path: _Path) -> Model: ...
    @staticmethod
    def parse(text: str, name: str = "<string>") -> Model: ...
    def to_toml(self) -> str: ...
    def save(self, path: _Path) -> None: ...
    def copy(self) -> Model: ...
    @property
    def source(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def notes(self) -> List[str]: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def element_names(self) -> List[str]: ...
    @property
    def cable_names(self) -> List[str]: ...
    @property
    def sleeve_names(self) -> List[str]: ...
    def element_type(self, name: str) -> str: ...
    def positions(self) -> npt.NDArray[np.float64]:
        """Initial joint positions, shape (n_joints, 3), m."""
    def reference_positions(self) -> Optional[npt.NDArray[np.float64]]:
        """Deployed (reference) joint positions, shape (n_joints, 3), m."""
    dt_s: float
    """Time step (s)."""
    end_time_s: float
    """End time of a run that does not deploy (s)."""
    damping_n_s_per_m: float
    """Viscous damping on each joint's velocity (N s/m)."""
    gravity_m_s2: Tuple[float, float, float]
    elastic_members: bool
    def joint_mass(self, name: str) -> float:
        """A joint's lumped mass (kg)."""
    def set_joint_mass(self, name: str, mass_kg: float) -> int:
        """Mass (kg, > 0) of the joints matching `name` (`*` a wildcard); how many."""
    def cable_tension(self, name: str) -> float:
        """Motor tension at the start (N)."""
    def set_cable_tension(self, name: str, tension_n: float) -> int: ...
    def cable_max_tension(self, name: str) -> float:
        """Motor tension limit (N)."""
    def set_cable_max_tension(self, name: str, max_tension_n: float) -> int: ...
    def cable_mu(self, name: str) -> float:
        """Pulley friction coefficient."""
    def set_cable_mu(self, name: str, mu: float) -> int: ...
    def member_stiffness(self, name: str) -> float:
        """Axial stiffness EA of an element's members (N)."""
    def set_member_stiffness(self, name: str, ea_n: float) -> int: ...
    def latch_stiffness(self, name: str) -> Optional[float]:
        """A sleeve's latch stiffness (N/m); None for a rigid latch."""
    def latch_damping(self, name: str) -> float:
        """A sleeve's latch damping (N s/m)."""
    def set_latch_stiffness(
        self, name: str, stiffness_n_per_m: Optional[float], damping_n_s_per_m: Optional[float] = None
    ) -> int: ...
    def element_param(self, name: str, key: str) -> Union[float, str, None]: ...
    def set_element_param(self, name: str, key: str, value: Union[float, str, None]) -> int: ...
    def analyze(self) -> Dict[str, Any]:
        """`truss-deploy analyze --json`: rows, rank, mechanisms, self_stress, *_locked, ..."""
    def modes(self, count: int) -> Dict[str, Any]:
        """`truss-deploy analyze --modes COUNT`: the deployed truss's first natural modes (docs/modes.md)."""

class Snapshot:
    """A simulation's complete state; picklable (its JSON)."""
    def to_json(self) -> bytes: ...
    @staticmethod
    def from_json(data: Union[bytes, str]) -> Snapshot: ...
    @property
    def t_s(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def model_name(self) -> str: ...

RecordGroup = Literal["positions", "velocities", "motors", "cables", "energy", "progress"]

class Simulator:
    """The simulation of a model: state arrays, step, run, cable commands,
    save and restore. Picklable (its model and a Snapshot)."""
    def __init__(
        self,
        model: Model,
        solver: Literal["sparse", "dense"] = "sparse",
        record: Union[bool, Sequence[RecordGroup], None] = None,
    ) -> None: ...
    def record(self, what: Union[bool, Sequence[RecordGroup], None]) -> None: ...
    def history(self) -> Any:
        """The recorded history as a pandas DataFrame (docs/python.md)."""
    @property
    def model(self) -> Model: ...
    @property
    def solver(self) -> str: ...
    def step(self, dt: Optional[float] = None) -> int:
        """Advance by dt seconds (default the model's dt_s); latch events in the step."""
    def run(
        self, until: Optional[float] = None, max_wall_s: Optional[float] = None, dt: Optional[float] = None
    ) -> RunSummaryDict:
        """Run as `truss-deploy simulate` does; its JSON summary."""
    @property
    def last_summary(self) -> Optional[RunSummaryDict]: ...
    def set_cable_tension(self, cable: Union[str, int], tension_n: float) -> None:
        """Motor tension (N) from the next step on."""
    def set_cable_speed(self, cable: Union[str, int], speed_m_s: Optional[float]) -> None:
        """Reel-in speed (m/s, negative pays out) from the next step on; None: tension control."""
    def save(self) -> Snapshot: ...
    def restore(self, snapshot: Snapshot) -> None: ...
    def reset(self) -> None: ...
    def least_work_multipliers(self) -> npt.NDArray[np.float64]:
        """Member forces (N, Jacobian row order), least-work split."""
    @property
    def t_s(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def deployed(self) -> bool: ...
    @property
    def deploy_time_s(self) -> Optional[float]: ...
    @property
    def deploy_fraction(self) -> float: ...
    @property
    def mechanisms(self) -> int: ...
    @property
    def dof_initial(self) -> int: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def cable_names(self) -> List[str]: ...
    @property
    def lock_names(self) -> List[str]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """(n_joints, 3), m."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """(n_joints, 3), m/s."""
    @property
    def accelerations(self) -> npt.NDArray[np.float64]:
        """(n_joints, 3), m/s^2."""
    @property
    def locked(self) -> npt.NDArray[np.bool_]:
        """(n_locks,), True where latched (order of lock_names)."""
    @property
    def cable_tensions(self) -> List[npt.NDArray[np.float64]]:
        """Per cable, (n_segments,) N from the motor end."""
    @property
    def motor_tensions(self) -> npt.NDArray[np.float64]:
        """(n_cables,), N."""
    @property
    def reeled_in_m(self) -> npt.NDArray[np.float64]:
        """(n_cables,), m since the start."""
    @property
    def reel_in_rate_m_s(self) -> npt.NDArray[np.float64]:
        """(n_cables,), m/s."""
    @property
    def motor_modes(self) -> List[Literal["tension", "tracking", "at_limit", "slack"]]: ...
    @property
    def motor_speed_commands(self) -> List[Optional[float]]: ...
    @property
    def tension_commands(self) -> npt.NDArray[np.float64]: ...
    @property
    def kinetic_energy_j(self) -> float: ...
    @property
    def energy(self) -> Dict[str, float]: ...
    @property
    def max_constraint_violation_m(self) -> float: ...
    @property
    def locks(self) -> List[LockEventDict]: ...
    @property
    def solver_stats(self) -> Dict[str, Any]: ...

def _generate(kind: str, args: List[Tuple[str, Optional[str]]]) -> Model: ...
def _sweep_info(text: str, file: str, dir: str) -> Dict[str, Any]: ...
def _sweep_run_sample(text: str, file: str, dir: str, index: int, max_wall_s: Optional[float] = None) -> str: ...
def _sweep_run_local(
    text: str, file: str, dir: str, indices: List[int], jobs: int, max_wall_s: Optional[float] = None
) -> List[str]: ...
def _sweep_failed_row(text: str, file: str, dir: str, index: int, reason: str, message: str) -> str: ...
def _sweep_table(text: str, file: str, dir: str, rows: List[str]) -> Tuple[bytes, str]: ...
def _sweep_toml_from_json(json: str) -> str: ...
