"""arcsim: proton-arc delivery on a jerk-limited gantry, from Python.

Plans and machines are read as the `arcsim` command reads them, results equal the command's
(`Delivery.to_json()` is `arcsim simulate --json`), and every long computation releases the GIL.
Units are in the names: degrees, seconds, MeV.
"""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Floats = Union[float, Sequence[float], npt.NDArray[np.float64]]
_Path = Union[str, "PathLike[str]"]

class PlanError(ValueError):
    """A plan or machine that cannot be read or is invalid (the message says where)."""

class SweepError(ValueError):
    """A sweep file (or dict) that cannot be read or is invalid."""

class LogError(ValueError):
    """A delivery log that cannot be read (the message gives file, line and column)."""

class ProfileError(ValueError):
    """A move with invalid input or no feasible profile."""

class SimulationError(RuntimeError):
    """The sequencer found no feasible delivery (or failed to verify one)."""

class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during a sweep; `result` holds the rows finished before it."""

    result: "SweepResult"

class Plan:
    """A validated arc plan, with the file it came from."""

    @staticmethod
    def from_arrays(
        angles_deg: _Floats,
        irradiation_times_s: _Floats,
        energies_mev: _Floats,
        window_deg: Optional[_Floats] = None,
        switching_times_s: Optional[_Floats] = None,
        direction: str = "CW",
        name: str = "plan from arrays",
    ) -> "Plan":
        """A one-arc plan, one entry per energy layer in delivery order (consecutive layers at one
        angle share a control point). `window_deg`: one value or one per layer (None: the
        machine's default); `switching_times_s`: one per transition, overriding the machine's
        ELST; `direction`: "CW" (angle increases) or "CC". Raises PlanError."""
    @property
    def name(self) -> str: ...
    @property
    def file(self) -> str:
        """The path as given, or how the plan was built."""
    @property
    def sha256(self) -> str:
        """SHA-256 of the file's bytes (of the plan's JSON when built in memory)."""
    @property
    def arcs(self) -> int: ...
    @property
    def layers(self) -> int: ...
    def to_json(self) -> str:
        """The plan as arcsim-plan/1 JSON."""

def load_plan(path: _Path) -> Plan:
    """arcsim-plan/1 JSON or a DICOM RT Ion Plan (recognised by content). Raises PlanError."""

class Machine:
    """A gantry and beam model (arcsim-machine/1)."""

    @staticmethod
    def atom() -> "Machine":
        """The built-in ATOM machine (scenarios/machine-atom.json), simulate's default."""
    def with_limits(
        self,
        jerk: Optional[float] = None,
        accel: Optional[float] = None,
        speed: Optional[float] = None,
        decel: Optional[float] = None,
    ) -> "Machine":
        """A copy with other gantry limits (deg/s³, deg/s², deg/s). Raises PlanError."""
    @property
    def name(self) -> str: ...
    @property
    def file(self) -> str: ...
    @property
    def jerk(self) -> float:
        """J (deg/s³)."""
    @property
    def accel(self) -> float:
        """A (deg/s²)."""
    @property
    def decel(self) -> float:
        """Deceleration limit (deg/s²); A unless the machine sets its own."""
    @property
    def speed(self) -> float:
        """V (deg/s)."""
    @property
    def servo_period_s(self) -> Optional[float]: ...
    @property
    def default_window_deg(self) -> float: ...
    def to_json(self) -> str: ...

def load_machine(path: _Path) -> Machine:
    """An arcsim-machine/1 JSON file. Raises PlanError."""

def load_log(path: _Path, columns: Optional[str] = None) -> Dict[str, npt.NDArray[Any]]:
    """A delivery log (arcsim-log/1) as columns t_s, gantry_angle_deg, beam_on, energy_mev,
    spot, mu (NaN where empty); `columns` maps another CSV's names
    ("t_s=TIME,gantry_angle_deg=GantryAngle,beam_on=Beam"). Raises LogError."""

class Delivery:
    """A simulated delivery: what `arcsim simulate` computes."""

    @property
    def total_s(self) -> float: ...
    @property
    def breakdown(self) -> Dict[str, float]:
        """beam_on_s (= spot_irradiation_s + scanning_s + burst_switching_s + spill_waiting_s),
        energy_switching_s, lost_s (what the gantry adds beyond beam-on and energy switching)."""
    @property
    def limiter_counts(self) -> Dict[str, int]: ...
    @property
    def margins(self) -> Optional[Dict[str, Any]]: ...
    @property
    def lost_time(self) -> Dict[str, Any]: ...
    @property
    def switching(self) -> Dict[str, Any]:
        """Energy switches by class (by_class) and band of energy step (by_step): count, elst_s,
        time_s, lost_s; small_upward: the upward steps below 1 MeV with their control points and
        cost_s (ELST beyond the quicker switch), as `arcsim simulate` prints them."""
    def certify(self) -> Dict[str, float]:
        """Constant-speed deliveries: a proven lower bound of every constant-speed schedule
        (lower_bound_s) and the gap to it (gap_s), as `simulate --certify`; ValueError for free
        motion. Takes seconds on a 180-layer plan."""
    @property
    def options(self) -> Tuple[str, str, str]:
        """(schedule, motion, arc ends) used."""
    @property
    def warnings(self) -> List[str]: ...
    @property
    def notes(self) -> List[str]: ...
    @property
    def layers(self) -> Dict[str, Any]:
        """One entry per layer, as columns (numpy arrays; lists for text)."""
    @property
    def transitions(self) -> Dict[str, Any]:
        """One entry per transition, as columns."""
    @property
    def spots(self) -> Dict[str, Any]:
        """One entry per spot delivery (one painting of a spot, or its part in one spill), as
        columns: layer_index, arc, control_point, layer, spot, painting, burst, spill (None
        without bursts / spills), x_mm, y_mm (NaN without positions), mu, t_start_s, t_end_s,
        angle_start_deg, angle_end_deg; as `simulate --spots` writes them."""
    def to_pandas(self, table: str = "layers") -> Any:
        """`layers`, `transitions` or `spots` as a pandas DataFrame (needs pandas)."""
    def timeline(self, dt: Optional[float] = None) -> Dict[str, npt.NDArray[Any]]:
        """t_s, angle_deg, speed_deg_per_s, accel_deg_per_s2, jerk_deg_per_s3, energy_mev (NaN
        with the beam off), beam_on (bool), layer (-1 with the beam off), every dt s (None:
        0.01 s)."""
    def save_rrd(self, path: _Path, dt: Optional[float] = None) -> None:
        """The delivery for the Rerun viewer, as `simulate --rrd` writes it, sampled every dt s
        (None: 0.02 s)."""
    def to_log(
        self,
        path: Optional[_Path] = None,
        period: float = 0.01,
        angle_noise_deg: float = 0.0,
        seed: int = 0,
    ) -> Dict[str, npt.NDArray[Any]]:
        """The delivery as a machine would log it (`simulate --log`): columns t_s,
        gantry_angle_deg, beam_on, energy_mev, spot, mu (NaN where empty), a sample every
        `period` s; seeded Gaussian noise of `angle_noise_deg` on the angles. With `path`, also
        writes the arcsim-log/1 CSV. Raises ValueError for a bad period or noise."""
    def monte_carlo(self, draws: int, seed: int = 0) -> Dict[str, Any]:
        """Percentiles of the total over `draws` deliveries with the machine's timing spreads
        (per switch and layer) and fitted values' uncertainty (once per delivery), both measured
        by `calibrate`, as `simulate --monte-carlo`: p5_s, p50_s, p95_s, mean_s, sd_s, totals_s,
        and with both sources spreads_only_sd_s, parameters_only_sd_s, dominant. Raises
        SimulationError when the machine has neither."""
    def to_json(self) -> str:
        """The result document, equal to `arcsim simulate --json` for the same inputs."""

class Comparison:
    """A delivery log beside the simulation of its plan (`arcsim compare`)."""

    @property
    def difference_s(self) -> float:
        """Logged minus simulated total (s)."""
    @property
    def summary(self) -> Dict[str, Any]:
        """The logged and simulated splits, differences by class, worst layers, motion fits,
        observed gantry limits (everything but the per-layer rows)."""
    @property
    def layers(self) -> Dict[str, Any]:
        """One row per layer, logged and simulated start, end, angles, beam-on and transition
        times, as columns."""
    def to_pandas(self) -> Any:
        """The per-layer rows as a pandas DataFrame (needs pandas)."""
    def to_json(self) -> str:
        """The comparison as `arcsim compare --json` writes it."""

def compare(
    plan: Plan,
    log: _Path,
    machine: Optional[Machine] = None,
    motion: Optional[str] = None,
    schedule: Optional[str] = None,
    columns: Optional[str] = None,
) -> Comparison:
    """`arcsim compare`: the log matched to the plan's layers and set beside its simulation
    under the machine's controller (motion/schedule override it). Raises LogError for a log
    that cannot be read or does not fit the plan (its MU column included)."""

def calibrate(
    machine: Machine,
    runs: Sequence[Tuple[Plan, _Path]],
    elst: str = "constant",
    motion: Optional[str] = None,
    schedule: Optional[str] = None,
    columns: Optional[str] = None,
) -> Tuple[Machine, Dict[str, Any]]:
    """`arcsim calibrate`: a machine fitted to (plan, log) pairs, starting from `machine`;
    elst "constant" or "poly". The controller is learnt from the logs (motion forces it).
    Returns the fitted machine (with its controller, spreads and uncertainty) and the report
    (values with 95 % intervals, what the logs do not determine, the controller's evidence,
    warnings, residuals before and after)."""

def calibrate_spots(
    machine: Machine,
    runs: Sequence[Tuple[Plan, _Path]],
) -> Tuple[Machine, Dict[str, Any]]:
    """`arcsim calibrate-spots`: a `scanning` beam's spot timing (time per MU factor, minimum
    spot time, scanning speed, settling, burst switching) fitted to (plan, per-spot log) pairs,
    starting from `machine`. Returns the fitted machine and the report (values with 95 %
    intervals, the clock's resolution, outliers, residuals, warnings). Raises LogError for a
    log that cannot be read, ValueError for a beam it cannot fit."""

def simulate(
    plan: Plan,
    machine: Optional[Machine] = None,
    schedule: Optional[str] = None,
    period_s: Optional[float] = None,
    motion: Optional[str] = None,
    arc_ends: str = "rest",
    strict: bool = False,
) -> Delivery:
    """`arcsim simulate`: schedule "optimal", "scan", "prescribed", "step-and-shoot" or None
    (the machine's controller's); motion "free", "constant" or None (the machine's
    controller); period_s a servo period. Raises PlanError, SimulationError."""

def resequence(
    plan: Plan,
    machine: Optional[Machine] = None,
    schedule: Optional[str] = None,
    motion: Optional[str] = None,
    turn_arcs: bool = False,
    search_layers: Optional[int] = None,
) -> Tuple[Plan, Dict[str, Any]]:
    """`arcsim resequence`: the plan with each control point's layers in the order the machine
    delivers fastest (the same spots, MU, energies and control points, checked) and the report
    `resequence --json` writes (total_before_s, total_after_s, resequenced, moved_layers,
    breakdown_before/after, switching_before/after, candidates). The plan as given where no
    order is faster."""

def schedule_arrays(
    irradiation_times_s: _Floats,
    switching_times_s: _Floats,
    spacing_deg: float,
    max_window_deg: float,
    jerk: float,
    accel: float,
    speed: float,
    decel: Optional[float] = None,
    schedule: str = "optimal",
) -> Tuple[float, npt.NDArray[np.float64]]:
    """ATOM-style: total time (s) and constant layer speeds (deg/s) of one arc."""

class Profile:
    """A jerk-limited move."""

    @property
    def duration_s(self) -> float: ...
    @property
    def servo_added_time_s(self) -> Optional[float]: ...
    @property
    def peak_speed_deg_per_s(self) -> float: ...
    @property
    def phases(self) -> Dict[str, npt.NDArray[np.float64]]:
        """start_s, duration_s, jerk_deg_per_s3 of each constant-jerk phase."""
    def sample(self, t: _Floats) -> Dict[str, npt.NDArray[np.float64]]:
        """position_deg, speed_deg_per_s, accel_deg_per_s2, jerk_deg_per_s3 at times t."""

def profile(
    distance: float,
    v_start: float,
    v_end: float,
    jerk: float,
    accel: float,
    vel: float,
    decel: Optional[float] = None,
    min_duration: Optional[float] = None,
    period_s: Optional[float] = None,
    reverse: str = "forbid",
) -> Profile:
    """`arcsim profile`: the minimum-time move (lasting at least min_duration when given: exactly
    that when the move can, else the shortest longer duration; phases on the servo period when
    given). Raises ProfileError."""

def profile_batch(
    distance: _Floats,
    v_start: _Floats,
    v_end: _Floats,
    jerk: _Floats,
    accel: _Floats,
    vel: _Floats,
    decel: Optional[_Floats] = None,
    min_duration: Optional[_Floats] = None,
    period_s: Optional[float] = None,
    reverse: str = "forbid",
) -> Dict[str, Any]:
    """Many moves in parallel: duration_s (NaN where none), ok, peak_speed_deg_per_s, error."""

class SweepResult:
    """A sweep's rows and summary."""

    @property
    def name(self) -> str: ...
    @property
    def combinations(self) -> int: ...
    @property
    def complete(self) -> bool: ...
    @property
    def rows(self) -> Dict[str, Any]:
        """The rows as columns: index, plan, schedule, status, the limits (jerk_deg_per_s3 to
        window_deg, scan_speed_mm_per_s, dose_rate_scale, burst_switching_time_s, spill_charge_mu,
        spill_refill_time_s, spill_max_layers; NaN where the base machine's),
        total_s, speedup, lower_bound_s and gap_s (the certificate, with "certify": true;
        None or NaN otherwise), breakdown.* (beam_on_s = spot_irradiation_s + scanning_s +
        burst_switching_s + spill_waiting_s, energy_switching_s, lost_s), limiter_counts.*, message."""
    def to_pandas(self) -> Any: ...
    @property
    def summary(self) -> Optional[Dict[str, Any]]: ...
    def summary_table(self) -> Optional[str]: ...
    def to_json(self) -> str:
        """Rows and summary as `arcsim sweep --json` writes them."""

def sweep(
    sweep: Union[_Path, Dict[str, Any]],
    threads: Optional[int] = None,
    progress: bool = True,
) -> SweepResult:
    """`arcsim sweep`: a sweep file or dict, in parallel with the GIL released. Ctrl-C raises
    SweepInterrupted with the finished rows. Raises SweepError."""
