"""Read the experiment's description files: ``device.toml`` and ``virtual.toml``.

``device.toml`` describes the gimbal: its spring, motor, encoder, the stages (one gear ratio
each, with the nodes where the tensor is sampled) and, optionally, the body's mass.
``virtual.toml`` exists only for a virtual device: the true body (absent for an empty-fixture
run) and fixture, the friction law in each direction of motion, the rig's imperfections and
the settings of the simulated runs. Both files are contracts of INTERFACES.md (sections
"device.toml" and "virtual.toml"); this module is the one place that reads them.

Bad input raises :class:`rsp_inertia.plant.errors.InputError` with one line that names the file, the
dotted key and the fault, for example
``device.toml: stage[2].gear_ratio: must be >= 0, got -0.5``. Indices in keys count from 1,
as the ``stage1/``, ``stage2/`` folders of an experiment do. Unknown keys and tables are
errors, so that a typo never silently falls back to a default.
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass
from typing import Any

import numpy as np

from rsp_inertia.plant.errors import InputError

__all__ = [
    "DEFAULT_GRAVITY",
    "DIRECTIONS",
    "REQUIRED_AXES",
    "Body",
    "ControllerSettings",
    "Device",
    "Encoder",
    "Friction",
    "LoggerSettings",
    "Motor",
    "Pendulum",
    "PlanGuess",
    "Rig",
    "RunSettings",
    "Spring",
    "Stage",
    "TrueBody",
    "Virtual",
    "load_device",
    "load_reference",
    "load_virtual",
]

DEFAULT_GRAVITY = 9.80665
"""Standard gravity, m/s^2: used when ``[device]`` has no ``gravity``."""

REQUIRED_AXES = 6
"""Distinct axes needed over all stages: the tensor has six entries (METHOD.md §5)."""

DIRECTIONS = ("forward", "backward")
"""Directions of a stage's run: forward, phi increases during the braking pass and decreases
during its reverse pass; backward, the other way round."""

_INERTIA_NAMES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")


# --- device.toml -------------------------------------------------------------------------


@dataclass(frozen=True)
class Spring:
    """Torsion element of the device, reduced to the phi coordinate."""

    stiffness: float
    """Stiffness, N m/rad, >= 0 (0 = no spring)."""
    zero_angle: float
    """Angle phi at which the spring is relaxed, rad."""


@dataclass(frozen=True)
class Motor:
    """Limits of the drive, reduced to the phi coordinate."""

    torque_limit: float
    """Largest torque magnitude, N m, > 0: |u| <= torque_limit."""
    torque_rate_limit: float
    """Largest torque rate magnitude, N m/s, > 0: |du/dt| <= torque_rate_limit."""
    torque_gain_std: float | None = None
    """Relative standard deviation of the logged torque's scale (torque constant), >= 0, as the
    user knows it; None (not stated) makes identify warn unless a calibration.toml fixes it."""


@dataclass(frozen=True)
class Encoder:
    """Angle encoder on phi."""

    counts_per_rev: int
    """Counts per revolution, a positive integer."""
    sample_rate: float
    """Sampling rate, Hz, > 0."""
    counter_bits: int | None = None
    """Width of the drive's position counter, bits (1 to 64), when logs give integer
    ``counts`` that wrap around at 2**counter_bits; None: counts never wrap."""

    @property
    def quantum(self) -> float:
        """One count, rad: 2 pi / counts_per_rev."""
        return 2.0 * math.pi / self.counts_per_rev

    @property
    def dt(self) -> float:
        """Sampling period, s: 1 / sample_rate."""
        return 1.0 / self.sample_rate


@dataclass(frozen=True)
class Stage:
    """One gear ratio of the gimbal and the protocol run with it (METHOD.md §1, §5)."""

    gear_ratio: float
    """lambda = tan(beta), dimensionless, >= 0 (0 = outer frame locked, spin about z)."""
    tare_inertia: float
    """M_tare(lambda), kg m^2, >= 0, reduced to phi (from an empty-fixture run)."""
    nodes_deg: tuple[float, ...]
    """Angles phi where the tensor is sampled, deg, each in [0, 360), distinct, at least one."""
    launch_speed: float
    """Speed Omega at the release of the braking pass, rad/s, > 0."""
    braking_torque: float
    """Motor torque against the motion during the braking pass, N m, >= 0."""
    directions: tuple[str, ...] = ("forward",)
    """Directions the stage is run in, each from DIRECTIONS, distinct, at least one: forward
    (phi increases while braking), backward (phi decreases while braking), or both."""
    tare_inertia_std: float | None = None
    """Standard deviation of ``tare_inertia``, kg m^2, >= 0, as the user knows it; None (not
    stated) makes identify warn unless a calibration.toml replaces the tare."""
    release_angle_deg: float | None = None
    """Where the rig releases the body for a forward braking pass, phi in deg (the backward
    pass: its negative); part of the protocol, which ``plan`` predicts for and writes. None
    (not stated): the virtual device releases at virtual.toml's ``[run] release_angle_deg``,
    and ``plan`` assumes a release rsp_inertia.ocp.plan.RELEASE_BEFORE_NODE_DEG before the first node."""

    @property
    def nodes(self) -> np.ndarray:
        """The nodes in radians, shape (n_nodes,)."""
        return np.radians(np.asarray(self.nodes_deg, dtype=float))


@dataclass(frozen=True)
class Body:
    """What the device file knows of the body under test."""

    mass: float
    """Mass, kg, > 0; with it, identify reports the centre of mass."""


@dataclass(frozen=True)
class Pendulum:
    """Torsion-pendulum baseline runs: the torsion element attached for them (motor off)."""

    stiffness: float
    """c, N m/rad, reduced to phi, > 0: the spring is zeroed at the node for each run."""
    amplitude_deg: float = 5.0
    """Initial deflection from the node, deg, > 0."""
    duration: float = 30.0
    """Logged time per run, s, > 0."""
    stiffness_std: float | None = None
    """Std of ``stiffness``, N m/rad, >= 0, as the user knows it; the best-practice pendulum
    reduction carries it into its stds. None (not stated): taken as exact, and identify warns
    unless calibration.toml has the stiffness from pendulum runs of the calibration folders."""


@dataclass(frozen=True)
class PlanGuess:
    """Rough knowledge of the body and the rig for ``rsp-inertia plan`` (``[plan]``).

    A pilot run of a stage (stageN/pilot.csv) replaces these guesses for that stage.
    """

    inertia: tuple[float, float, float] | None = None
    """Approximate principal moments of the body, kg m^2 (any order), >= 0."""
    box: tuple[float, float, float] | None = None
    """Or the body's bounding box, m: a solid block of ``[body] mass`` with these sides."""
    friction: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Guessed dissipation [a1 N m, a2 N m s, a3 N m s^2] (METHOD.md §3), >= 0."""
    com_offset: float = 0.0
    """Guessed distance of the centre of mass from the rotation axis, m, >= 0."""
    torque_noise: float | None = None
    """Std of the torque log's noise, N m, >= 0 (else from a pilot run)."""
    max_duration: float | None = None
    """Default of ``plan --max-duration``: the whole experiment's motion time, s, > 0."""

    def principal_moments(self, mass: float | None) -> tuple[float, float, float] | None:
        """The body's approximate principal moments, kg m^2 (from ``box`` with ``mass``)."""
        if self.inertia is not None:
            return self.inertia
        if self.box is None or mass is None:
            return None
        a, b, c = self.box
        return (mass * (b * b + c * c) / 12, mass * (a * a + c * c) / 12, mass * (a * a + b * b) / 12)


@dataclass(frozen=True)
class Device:
    """The gimbal as described by ``device.toml``."""

    name: str
    """Name of the device, free text."""
    gravity: float
    """Gravitational acceleration, m/s^2, > 0."""
    spring: Spring
    """Torsion element; stiffness 0 when the file has no ``[spring]``."""
    motor: Motor
    """Drive limits."""
    encoder: Encoder
    """Angle encoder."""
    stages: tuple[Stage, ...]
    """The ``[[stage]]`` tables in file order; stage k lives in the folder ``stage{k}/``."""
    body: Body | None
    """The optional ``[body]`` table."""
    pendulum: Pendulum | None = None
    """The optional ``[pendulum]`` table (torsion-pendulum baseline)."""
    plan: PlanGuess | None = None
    """The optional ``[plan]`` table (guesses for experiment planning)."""

    @property
    def n_axes(self) -> int:
        """Number of distinct instantaneous axes over all stages.

        A stage with gear ratio 0 turns about z whatever its nodes, so it gives one axis;
        any other stage gives one axis per node (METHOD.md §1: e depends on lambda and phi).
        """
        axes: set[tuple[float, float]] = set()
        for stage in self.stages:
            if stage.gear_ratio == 0.0:
                axes.add((0.0, 0.0))
            else:
                axes.update((stage.gear_ratio, node) for node in stage.nodes_deg)
        return len(axes)


def load_device(path: str | os.PathLike) -> Device:
    """Read a ``device.toml`` file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its name as given appears in error messages.

    Returns
    -------
    Device
        The gimbal, with defaults filled in: gravity 9.80665 m/s^2, no spring,
        tare inertia 0, stages run forward only, no body.

    Raises
    ------
    InputError
        The file is missing or is not TOML; a key is missing, unknown, of the wrong type
        or out of range; or the stages give fewer than six distinct axes.

    Examples
    --------
    >>> device = load_device("EXP/device.toml")  # doctest: +SKIP
    >>> device.n_axes, device.stages[0].gear_ratio  # doctest: +SKIP
    (6, 0.7639320225)
    """
    doc = _read(path)
    try:
        return _device(doc)
    except _ContentError as error:
        raise InputError(f"{path}: {error}") from None


def _device(doc: dict[str, Any]) -> Device:
    _known(
        doc, "", {"device", "spring", "motor", "encoder", "stage", "body", "pendulum", "plan"}
    )

    table = _table(doc, "device", {"name", "gravity"})
    name = _get(table, "device", "name", str)
    gravity = _get(table, "device", "gravity", float, default=DEFAULT_GRAVITY, bound="> 0")

    table = _table(doc, "spring", {"stiffness", "zero_angle"}, required=False) or {}
    spring = Spring(
        stiffness=_get(table, "spring", "stiffness", float, default=0.0, bound=">= 0"),
        zero_angle=_get(table, "spring", "zero_angle", float, default=0.0),
    )

    table = _table(doc, "motor", {"torque_limit", "torque_rate_limit", "torque_gain_std"})
    motor = Motor(
        torque_limit=_get(table, "motor", "torque_limit", float, bound="> 0"),
        torque_rate_limit=_get(table, "motor", "torque_rate_limit", float, bound="> 0"),
        torque_gain_std=_get(table, "motor", "torque_gain_std", float, default=None, bound=">= 0"),
    )

    table = _table(doc, "encoder", {"counts_per_rev", "sample_rate", "counter_bits"})
    encoder = Encoder(
        counts_per_rev=_get(table, "encoder", "counts_per_rev", int, bound="> 0"),
        sample_rate=_get(table, "encoder", "sample_rate", float, bound="> 0"),
        counter_bits=_get(table, "encoder", "counter_bits", int, default=None, bound="> 0"),
    )
    if encoder.counter_bits is not None and encoder.counter_bits > 64:
        raise _ContentError("encoder.counter_bits", f"must be at most 64, got {encoder.counter_bits}")

    stages = tuple(_stage(stage, f"stage[{k}]") for k, stage in enumerate(_stages(doc), 1))

    table = _table(doc, "body", {"mass"}, required=False)
    body = None if table is None else Body(mass=_get(table, "body", "mass", float, bound="> 0"))

    table = _table(
        doc, "pendulum", {"stiffness", "stiffness_std", "amplitude_deg", "duration"}, required=False
    )
    pendulum = None
    if table is not None:
        pendulum = Pendulum(
            stiffness=_get(table, "pendulum", "stiffness", float, bound="> 0"),
            amplitude_deg=_get(table, "pendulum", "amplitude_deg", float, default=5.0, bound="> 0"),
            duration=_get(table, "pendulum", "duration", float, default=30.0, bound="> 0"),
            stiffness_std=_get(
                table, "pendulum", "stiffness_std", float, default=None, bound=">= 0"
            ),
        )

    table = _table(
        doc,
        "plan",
        {"inertia", "box", "friction", "com_offset", "torque_noise", "max_duration"},
        required=False,
    )
    plan = None if table is None else _plan_guess(table, body)

    device = Device(name, gravity, spring, motor, encoder, stages, body, pendulum, plan)
    if device.n_axes < REQUIRED_AXES:
        raise _ContentError(
            "stage",
            f"the stages give {device.n_axes} distinct axes, {REQUIRED_AXES} are needed",
        )
    return device


def _plan_guess(table: dict[str, Any], body: Body | None) -> PlanGuess:
    """The ``[plan]`` table: every number >= 0, three-vectors where the contract says so."""

    def triple(key: str, names: tuple[str, ...]) -> tuple[float, float, float] | None:
        if key not in table:
            return None
        values = _numbers(table, "plan", key, names)
        for k, value in enumerate(values, 1):
            if value < 0:
                raise _ContentError(f"plan.{key}[{k}]", f"must be >= 0, got {value!r}")
        return values  # type: ignore[return-value]

    inertia = triple("inertia", ("I1", "I2", "I3"))
    box = triple("box", ("a", "b", "c"))
    if inertia is not None and box is not None:
        raise _ContentError("plan", "give either inertia or box, not both")
    if box is not None and body is None:
        raise _ContentError("plan.box", "needs the body's mass ([body] mass)")
    return PlanGuess(
        inertia=inertia,
        box=box,
        friction=triple("friction", ("a1", "a2", "a3")) or (0.0, 0.0, 0.0),
        com_offset=_get(table, "plan", "com_offset", float, default=0.0, bound=">= 0"),
        torque_noise=_get(table, "plan", "torque_noise", float, default=None, bound=">= 0"),
        max_duration=_get(table, "plan", "max_duration", float, default=None, bound="> 0"),
    )


def _stages(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """The ``[[stage]]`` array of tables, checked for shape."""
    if "stage" not in doc:
        raise _ContentError("stage", "missing required [[stage]] array")
    stages = doc["stage"]
    if not isinstance(stages, list):
        raise _ContentError(
            "stage", f"must be an array of tables ([[stage]]), got {_describe(stages)}"
        )
    if not stages:
        raise _ContentError("stage", "must have at least one [[stage]]")
    for k, table in enumerate(stages, 1):
        if not isinstance(table, dict):
            raise _ContentError(f"stage[{k}]", f"must be a table, got {_describe(table)}")
    return stages


def _stage(table: dict[str, Any], where: str) -> Stage:
    _known(
        table,
        where,
        {
            "gear_ratio",
            "tare_inertia",
            "nodes_deg",
            "launch_speed",
            "braking_torque",
            "directions",
            "tare_inertia_std",
            "release_angle_deg",
        },
    )
    gear_ratio = _get(table, where, "gear_ratio", float, bound=">= 0")
    tare_inertia = _get(table, where, "tare_inertia", float, default=0.0, bound=">= 0")

    nodes = _numbers(table, where, "nodes_deg")
    key = f"{where}.nodes_deg"
    if not nodes:
        raise _ContentError(key, "must have at least one node")
    for k, node in enumerate(nodes, 1):
        if not 0.0 <= node < 360.0:
            raise _ContentError(f"{key}[{k}]", f"must be in [0, 360), got {node!r}")
    if len(set(nodes)) < len(nodes):
        duplicate = next(node for node in nodes if nodes.count(node) > 1)
        raise _ContentError(key, f"duplicate node {duplicate!r}")

    return Stage(
        gear_ratio=gear_ratio,
        tare_inertia=tare_inertia,
        nodes_deg=nodes,
        launch_speed=_get(table, where, "launch_speed", float, bound="> 0"),
        braking_torque=_get(table, where, "braking_torque", float, bound=">= 0"),
        directions=_directions(table, where),
        tare_inertia_std=_get(table, where, "tare_inertia_std", float, default=None, bound=">= 0"),
        release_angle_deg=_get(table, where, "release_angle_deg", float, default=None),
    )


def _directions(table: dict[str, Any], where: str) -> tuple[str, ...]:
    """``stage[k].directions``: a non-empty array of distinct names from DIRECTIONS."""
    key = f"{where}.directions"
    if "directions" not in table:
        return ("forward",)
    values = table["directions"]
    if not isinstance(values, list):
        raise _ContentError(key, f"must be an array of strings, got {_describe(values)}")
    if not values:
        raise _ContentError(key, "must name at least one direction")
    allowed = ", ".join(repr(name) for name in DIRECTIONS)
    for k, value in enumerate(values, 1):
        name = _convert(value, str, f"{key}[{k}]")
        if name not in DIRECTIONS:
            raise _ContentError(f"{key}[{k}]", f"must be one of {allowed}, got {name!r}")
    if len(set(values)) < len(values):
        duplicate = next(name for name in values if values.count(name) > 1)
        raise _ContentError(key, f"duplicate direction {duplicate!r}")
    return tuple(values)


# --- virtual.toml ------------------------------------------------------------------------


@dataclass(frozen=True)
class TrueBody:
    """A rigid part a virtual device carries on its shaft: the body under test (the truth that
    identification should recover) or the fixture that holds it."""

    mass: float
    """Mass, kg, > 0."""
    inertia: np.ndarray
    """[Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2, shape (6,), about O in the body frame,
    products as tensor entries (Jxy = -integral of x y dm), read-only."""
    com: np.ndarray
    """Centre of mass [x, y, z] in the body frame, m, shape (3,), read-only."""

    def __post_init__(self) -> None:
        # Own read-only copies, so that a frozen body stays frozen however it was built.
        for name, size in (("inertia", 6), ("com", 3)):
            array = np.array(getattr(self, name), dtype=float)
            if array.shape != (size,):
                raise ValueError(f"TrueBody.{name} must have shape ({size},), got {array.shape}")
            array.flags.writeable = False
            object.__setattr__(self, name, array)

    @property
    def tensor(self) -> np.ndarray:
        """The inertia tensor J, kg m^2, shape (3, 3) (METHOD.md §2)."""
        jx, jy, jz, jxy, jyz, jxz = self.inertia
        return np.array([[jx, jxy, jxz], [jxy, jy, jyz], [jxz, jyz, jz]])


@dataclass(frozen=True)
class Friction:
    """Dissipation D = (a1 + a3 W^2) sign W + a2 W, reduced to phi (METHOD.md §4)."""

    coulomb: float
    """a1, N m, >= 0; also the static friction at rest."""
    viscous: float
    """a2, N m s, >= 0."""
    quadratic: float
    """a3, N m s^2, >= 0."""
    backward_scale: float = 1.0
    """Factor on a1, a2 and a3 while the body moves backward (Omega < 0), >= 0; 1 = the same
    friction in both directions."""


@dataclass(frozen=True)
class RunSettings:
    """How the virtual device runs and logs a stage."""

    release_angle_deg: float = -30.0
    """Angle phi where the braking pass starts, deg, any real."""
    torque_noise: float = 0.0
    """Standard deviation of the noise added to the logged torque, N m, >= 0."""
    seed: int = 0
    """Seed of the random generator, integer >= 0."""


@dataclass(frozen=True)
class LoggerSettings:
    """How the virtual rig's drive samples and logs (a real drive's timing imperfections).

    The drive's loop reads the encoder, sets the torque and writes a log row at each of its
    sampling instants; the log's time stamps are those instants (rsp_inertia.plant.logs).
    """

    time_jitter: float = 0.0
    """Each sampling instant is off the regular grid k / sample_rate by a uniform random
    amount within +- this fraction of a period, 0 <= time_jitter <= 0.25 (the logs' limit,
    rsp_inertia.plant.logs.JITTER_LIMIT); the first row stays at t = 0."""
    dropped_fraction: float = 0.0
    """Fraction of the rows the logger loses at random (the drive still acts at those
    instants), 0 <= dropped_fraction < 0.5; the first and last rows are always kept."""
    counts: bool = False
    """Write ``t,counts,torque`` with integer counts of the drive's position counter
    (device.toml ``[encoder] counter_bits``, which must then be set: the counts wrap there)
    instead of ``t,phi,torque``."""


@dataclass(frozen=True)
class ControllerSettings:
    """The virtual device's controller."""

    speed_observer_bandwidth: float = 100.0
    """Bandwidth of the speed estimate the controller forms from the encoder, rad/s, > 0."""


@dataclass(frozen=True)
class Rig:
    """Imperfections of the virtual rig: what the real one does differently from its file."""

    torque_gain: float = 1.0
    """Logged torque over the torque physically applied, dimensionless, > 0 (1 = exact)."""
    tare_inertia: tuple[float, ...] | None = None
    """True M_tare of each stage, kg m^2, >= 0, one per [[stage]] of device.toml (which only
    approximates them); None: device.toml's values are exact."""
    pendulum_stiffness: float | None = None
    """True stiffness of the pendulum's torsion element, N m/rad, > 0 (device.toml's
    ``[pendulum] stiffness`` only approximates it); None: device.toml's is exact."""

    def true_tare(self, device: Device, stage: int, source: str = "virtual.toml") -> float:
        """The true M_tare of stage ``stage`` (1-based), kg m^2 (METHOD.md §2).

        Raises
        ------
        InputError
            ``tare_inertia`` does not have one entry per stage of ``device``; the message
            names ``source`` (the virtual.toml file) and the key.
        """
        if self.tare_inertia is None:
            return device.stages[stage - 1].tare_inertia
        if len(self.tare_inertia) != len(device.stages):
            raise InputError(
                f"{source}: rig.tare_inertia: must have one entry per [[stage]] of device.toml "
                f"({len(device.stages)}), got {len(self.tare_inertia)}"
            )
        return self.tare_inertia[stage - 1]


@dataclass(frozen=True)
class Virtual:
    """The virtual device as described by ``virtual.toml``."""

    body: TrueBody | None
    """The true body; None for an empty-fixture run (no ``[body]``)."""
    friction: Friction
    """The true friction law; forward motion always uses its coefficients."""
    run: RunSettings
    """Run settings; defaults when the file has no ``[run]``."""
    controller: ControllerSettings
    """Controller settings; defaults when the file has no ``[controller]``."""
    fixture: TrueBody | None = None
    """The mounting plate, rigidly on the shaft with the body; None when the file has none."""
    rig: Rig = Rig()
    """The rig's imperfections; an exact rig when the file has no ``[rig]``."""
    friction_backward: Friction | None = None
    """Explicit friction for backward motion (Omega < 0), from ``[friction_backward]``; None:
    ``friction`` scaled by its ``backward_scale``."""
    logger: LoggerSettings = LoggerSettings()
    """The drive's sampling and logging; regular and lossless when the file has no
    ``[logger]``."""
    models: tuple | None = None
    """Per stage, the true model given directly (rsp_inertia.plant.model.ModelParameters, both directions
    of motion) in place of body, fixture, tare and friction: a rehearsal of a plan on its
    nominal model (rsp_inertia.ocp.rehearsal). Never read from virtual.toml."""

    def friction_for(self, direction: float) -> Friction:
        """The friction coefficients while the body moves in ``direction`` (sign of Omega).

        Forward (+1) motion uses ``[friction]``; backward (-1) motion ``[friction_backward]``
        if given, else ``[friction]``'s coefficients times its ``backward_scale``.
        """
        if direction > 0:
            return self.friction
        if self.friction_backward is not None:
            return self.friction_backward
        scale = self.friction.backward_scale
        if scale == 1.0:
            return self.friction
        return Friction(
            coulomb=self.friction.coulomb * scale,
            viscous=self.friction.viscous * scale,
            quadratic=self.friction.quadratic * scale,
        )


def load_virtual(path: str | os.PathLike) -> Virtual:
    """Read a ``virtual.toml`` file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its name as given appears in error messages.

    Returns
    -------
    Virtual
        The true body and fixture, the friction law, the rig's imperfections and the run and
        controller settings, with defaults for the optional tables (``[body]``,
        ``[fixture]``, ``[rig]``, ``[friction_backward]``, ``[run]``, ``[controller]``) and
        their keys.

    Raises
    ------
    InputError
        The file is missing or is not TOML; a key is missing, unknown, of the wrong type
        or out of range; an inertia is not that of a physical body (a diagonal entry
        <= 0, not positive definite, or principal moments breaking the triangle inequality);
        or both ``friction.backward_scale`` and ``[friction_backward]`` are given.
        (``rig.tare_inertia``'s length is checked against the device by
        :meth:`Rig.true_tare`.)

    Examples
    --------
    >>> virtual = load_virtual("EXP/virtual.toml")  # doctest: +SKIP
    >>> virtual.body.tensor.shape  # doctest: +SKIP
    (3, 3)
    """
    doc = _read(path)
    try:
        return _virtual(doc)
    except _ContentError as error:
        raise InputError(f"{path}: {error}") from None


def _virtual(doc: dict[str, Any]) -> Virtual:
    _known(
        doc,
        "",
        {"body", "fixture", "friction", "friction_backward", "rig", "run", "controller", "logger"},
    )
    body = _true_body(doc, "body")
    fixture = _true_body(doc, "fixture")

    table = _table(doc, "friction", {"coulomb", "viscous", "quadratic", "backward_scale"})
    friction = Friction(
        coulomb=_get(table, "friction", "coulomb", float, bound=">= 0"),
        viscous=_get(table, "friction", "viscous", float, bound=">= 0"),
        quadratic=_get(table, "friction", "quadratic", float, bound=">= 0"),
        backward_scale=_get(table, "friction", "backward_scale", float, default=1.0, bound=">= 0"),
    )
    table = _table(doc, "friction_backward", {"coulomb", "viscous", "quadratic"}, required=False)
    friction_backward = None
    if table is not None:
        if friction.backward_scale != 1.0:
            raise _ContentError(
                "friction_backward",
                "give either friction.backward_scale or [friction_backward], not both",
            )
        friction_backward = Friction(
            coulomb=_get(table, "friction_backward", "coulomb", float, bound=">= 0"),
            viscous=_get(table, "friction_backward", "viscous", float, bound=">= 0"),
            quadratic=_get(table, "friction_backward", "quadratic", float, bound=">= 0"),
        )

    table = _table(
        doc, "rig", {"torque_gain", "tare_inertia", "pendulum_stiffness"}, required=False
    ) or {}
    tare = None
    if "tare_inertia" in table:
        tare = _numbers(table, "rig", "tare_inertia")
        for k, value in enumerate(tare, 1):
            if not value >= 0.0:
                raise _ContentError(f"rig.tare_inertia[{k}]", f"must be >= 0, got {value!r}")
    rig = Rig(
        torque_gain=_get(table, "rig", "torque_gain", float, default=1.0, bound="> 0"),
        tare_inertia=tare,
        pendulum_stiffness=_get(
            table, "rig", "pendulum_stiffness", float, default=None, bound="> 0"
        ),
    )

    table = _table(doc, "run", {"release_angle_deg", "torque_noise", "seed"}, required=False)
    table, default = table or {}, RunSettings()
    run = RunSettings(
        release_angle_deg=_get(
            table, "run", "release_angle_deg", float, default=default.release_angle_deg
        ),
        torque_noise=_get(
            table, "run", "torque_noise", float, default=default.torque_noise, bound=">= 0"
        ),
        seed=_get(table, "run", "seed", int, default=default.seed, bound=">= 0"),
    )

    table = _table(doc, "controller", {"speed_observer_bandwidth"}, required=False)
    table, default = table or {}, ControllerSettings()
    controller = ControllerSettings(
        speed_observer_bandwidth=_get(
            table,
            "controller",
            "speed_observer_bandwidth",
            float,
            default=default.speed_observer_bandwidth,
            bound="> 0",
        ),
    )
    return Virtual(
        body, friction, run, controller, fixture, rig, friction_backward, _logger(doc)
    )


def _logger(doc: dict[str, Any]) -> LoggerSettings:
    table = _table(
        doc, "logger", {"time_jitter", "dropped_fraction", "counts"}, required=False
    ) or {}
    default = LoggerSettings()
    jitter = _get(table, "logger", "time_jitter", float, default=default.time_jitter, bound=">= 0")
    if jitter > 0.25:
        raise _ContentError("logger.time_jitter", f"must be <= 0.25 (of a period), got {jitter!r}")
    dropped = _get(
        table, "logger", "dropped_fraction", float, default=default.dropped_fraction, bound=">= 0"
    )
    if not dropped < 0.5:
        raise _ContentError("logger.dropped_fraction", f"must be < 0.5, got {dropped!r}")
    counts = table.get("counts", default.counts)
    if not isinstance(counts, bool):
        raise _ContentError("logger.counts", f"must be a boolean, got {_describe(counts)}")
    return LoggerSettings(time_jitter=jitter, dropped_fraction=dropped, counts=counts)


def load_reference(path: str | os.PathLike) -> TrueBody:
    """Read a calibration's ``reference.toml``: the reference body's ``[body]`` table.

    The same keys as virtual.toml's ``[body]``: ``mass`` (kg), ``inertia = [Jx, Jy, Jz, Jxy,
    Jyz, Jxz]`` (kg m^2, body frame about O) and ``com = [x, y, z]`` (m).

    Raises
    ------
    InputError
        The file is missing or is not TOML; a key is missing, unknown or out of range; the
        inertia is not that of a physical body.
    """
    doc = _read(path)
    try:
        _known(doc, "", {"body"})
        body = _true_body(doc, "body", required=True)
    except _ContentError as error:
        raise InputError(f"{path}: {error}") from None
    return body


def _true_body(doc: dict[str, Any], name: str, required: bool = False) -> TrueBody | None:
    """The optional table ``[name]`` (``body`` or ``fixture``) with mass, inertia and com."""
    table = _table(doc, name, {"mass", "inertia", "com"}, required=required)
    if table is None:
        return None
    return TrueBody(
        mass=_get(table, name, "mass", float, bound="> 0"),
        inertia=_inertia(table, name),
        com=_numbers(table, name, "com", names=("x", "y", "z")),
    )


def _inertia(table: dict[str, Any], where: str) -> tuple[float, ...]:
    """``where.inertia``, checked to be the tensor of a physical body (METHOD.md §2)."""
    key = f"{where}.inertia"
    inertia = _numbers(table, where, "inertia", names=_INERTIA_NAMES)
    for name, value in zip(_INERTIA_NAMES[:3], inertia[:3], strict=True):
        if not value > 0.0:
            raise _ContentError(key, f"{name} must be > 0, got {value!r}")
    jx, jy, jz, jxy, jyz, jxz = inertia
    moments = np.linalg.eigvalsh([[jx, jxy, jxz], [jxy, jy, jyz], [jxz, jyz, jz]])
    # Ascending order: only the smallest can be <= 0 and only the largest can exceed the
    # sum of the others. A flat plate has I3 = I1 + I2 exactly, hence the rounding margin.
    if moments[0] <= 0.0 or moments[2] > moments[0] + moments[1] + 1e-12 * moments.sum():
        listed = ", ".join(f"{moment:.6g}" for moment in moments)
        fault = (
            "not positive definite"
            if moments[0] <= 0.0
            else "the largest exceeds the sum of the other two (triangle inequality)"
        )
        raise _ContentError(
            key,
            f"not a physical inertia tensor: principal moments [{listed}] kg m^2, {fault}",
        )
    return inertia


# --- reading and checking ----------------------------------------------------------------

_REQUIRED: Any = object()


class _ContentError(Exception):
    """A fault at a dotted key; the public loaders prefix the file name."""

    def __init__(self, key: str, fault: str) -> None:
        super().__init__(f"{key}: {fault}")


def _read(path: str | os.PathLike) -> dict[str, Any]:
    """Parse a TOML file; every failure becomes a one-line InputError."""
    try:
        with open(path, "rb") as file:
            return tomllib.load(file)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except OSError as error:
        raise InputError(f"{path}: cannot read: {error.strerror or error}") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text") from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"{path}: invalid TOML: {' '.join(str(error).split())}") from None


def _known(table: dict[str, Any], where: str, allowed: set[str]) -> None:
    """Reject keys the contract does not define (typos would otherwise become defaults)."""
    for key, value in table.items():
        if key not in allowed:
            kind = "table" if not where and isinstance(value, (dict, list)) else "key"
            raise _ContentError(_dotted(where, key), f"unknown {kind}")


def _table(
    doc: dict[str, Any], name: str, allowed: set[str], required: bool = True
) -> dict[str, Any] | None:
    """The top-level table ``[name]`` with only ``allowed`` keys; None if optional and absent."""
    if name not in doc:
        if required:
            raise _ContentError(name, f"missing required table [{name}]")
        return None
    table = doc[name]
    if not isinstance(table, dict):
        raise _ContentError(name, f"must be a table, got {_describe(table)}")
    _known(table, name, allowed)
    return table


def _get(
    table: dict[str, Any],
    where: str,
    key: str,
    kind: type,
    *,
    default: Any = _REQUIRED,
    bound: str | None = None,
) -> Any:
    """``table[key]`` as ``kind`` (float, int or str), or ``default`` if absent.

    ``bound`` is ``"> 0"`` or ``">= 0"`` for numbers that have one.
    """
    dotted = _dotted(where, key)
    if key not in table:
        if default is _REQUIRED:
            raise _ContentError(dotted, "missing required key")
        return default
    value = _convert(table[key], kind, dotted)
    if bound is not None and not (value > 0 if bound == "> 0" else value >= 0):
        raise _ContentError(dotted, f"must be {bound}, got {value!r}")
    return value


def _numbers(
    table: dict[str, Any], where: str, key: str, names: tuple[str, ...] | None = None
) -> tuple[float, ...]:
    """``table[key]`` as a tuple of floats; exactly ``len(names)`` of them if names given."""
    dotted = _dotted(where, key)
    if key not in table:
        raise _ContentError(dotted, "missing required key")
    values = table[key]
    if not isinstance(values, list):
        raise _ContentError(dotted, f"must be an array of numbers, got {_describe(values)}")
    if names is not None and len(values) != len(names):
        raise _ContentError(
            dotted,
            f"must have {len(names)} entries [{', '.join(names)}], got {len(values)}",
        )
    return tuple(_convert(value, float, f"{dotted}[{k}]") for k, value in enumerate(values, 1))


def _convert(value: Any, kind: type, key: str) -> Any:
    """Check the TOML type of ``value``; integers are accepted as floats, booleans never."""
    if kind is str:
        if not isinstance(value, str):
            raise _ContentError(key, f"must be a string, got {_describe(value)}")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise _ContentError(key, f"must be an integer, got {_describe(value)}")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _ContentError(key, f"must be a number, got {_describe(value)}")
    value = float(value)
    if not math.isfinite(value):
        raise _ContentError(key, f"must be finite, got {value!r}")
    return value


def _describe(value: Any) -> str:
    """A short phrase for a TOML value of the wrong type, for messages."""
    if isinstance(value, bool):
        return f"a boolean ({str(value).lower()})"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return f"a string ({value!r})"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "a table"
    return f"a {type(value).__name__}"


def _dotted(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key
