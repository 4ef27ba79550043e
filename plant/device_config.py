"""``device.toml``: the gimbal and the protocol run on it, read and written.

The file describes the gimbal's spring, motor and encoder, the stages (one gear ratio each,
with the nodes where the tensor is sampled) and, optionally, the body's mass, how the body is
mounted, the torsion-pendulum baseline and guesses for planning; docs/files.md documents
every key. The config classes below declare the keys (rsp_inertia.infra.toml_schema): each
field's name is its key, with its unit, bounds, default and doc.
"""

from __future__ import annotations

import math
import os

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.toml_schema import (
    Bound,
    ContentError,
    config_class,
    key,
    read_file,
    read_table,
)
from rsp_inertia.infra.toml_writer import write_file
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.log_layout import LogFormat, LogLayout, TorqueUnit

DEFAULT_GRAVITY = 9.80665
"""Standard gravity, m/s^2: used when ``[device]`` has no ``gravity``."""

REQUIRED_AXES = 6
"""Distinct axes needed over all stages: the tensor has six entries (docs/method.md §5)."""

PROTOCOL = ("launch_speed", "braking_torque")
"""A stage's keys that ``rsp-inertia plan`` chooses: device.toml may leave them out until
plan has written them (:func:`require_protocol`)."""


def _distinct(values: tuple, key: str, noun: str, at_least: str) -> None:
    """Refuse an empty list (``at_least``: what it must have) or a repeated ``noun``."""
    if not values:
        raise ContentError(key, f"must {at_least}")
    if len(set(values)) < len(values):
        duplicate = next(value for value in values if values.count(value) > 1)
        raise ContentError(key, f"duplicate {noun} {duplicate!r}")


def _distinct_nodes(nodes: tuple[float, ...], key: str) -> None:
    _distinct(nodes, key, "node", "have at least one node")


def _distinct_directions(directions: tuple[Direction, ...], key: str) -> None:
    _distinct(directions, key, "direction", "name at least one direction")


@config_class
class Spring:
    """Torsion element of the device, reduced to the phi coordinate (``[spring]``)."""

    stiffness: float = key(0.0, unit="N m/rad", bound=">= 0", doc="c; 0 = no spring.")
    zero_angle: float = key(0.0, unit="rad", doc="phi0, the angle where the spring is relaxed.")


@config_class
class Motor:
    """Limits of the drive, reduced to the phi coordinate (``[motor]``)."""

    torque_limit: float = key(
        unit="N m", bound="> 0", doc="Largest torque magnitude: |u| <= torque_limit."
    )
    torque_rate_limit: float = key(
        unit="N m/s", bound="> 0", doc="Largest torque rate magnitude: |du/dt| <= this."
    )
    torque_gain_std: float | None = key(
        None,
        unit="relative",
        bound=">= 0",
        doc="Relative standard deviation of the logged torque's scale (torque constant), as "
        "the user knows it; None (not stated) makes identify warn unless a calibration.toml "
        "fixes it.",
    )
    torque_constant: float | None = key(
        None,
        unit="N m/A",
        bound="> 0",
        doc="The drive's torque per ampere, reduced to phi: with ``[log] torque_unit = 'A'`` "
        "(logs of the motor current, needed then and refused otherwise) the torque is the "
        "current times this.",
    )
    torque_constant_std: float | None = key(
        None,
        unit="N m/A",
        bound=">= 0",
        doc="Standard deviation of ``torque_constant``, as the user knows it (needs it); "
        "relative to it, the logged torque's scale error without a calibration.",
    )
    torque_constant_tempco: float | None = key(
        None,
        unit="1/K",
        bound=Bound(
            "within +-0.01 (a relative change per kelvin: -0.11 %/K is -0.0011)",
            lambda alpha: abs(alpha) <= 0.01,
        ),
        doc="alpha, the torque constant's relative change per kelvin of magnet temperature "
        "(about -0.0011 for NdFeB, -0.0004 for SmCo): every log's torque is taken as the "
        "logged one times 1 + alpha (T_mag - reference_temperature), T_mag the logged "
        "temperature through ``temperature_lag`` (rsp_inertia.plant.transducers."
        "thermal_torque_factor). Needs ``[log] temperature_column`` and "
        "``reference_temperature``. None: no compensation.",
    )
    torque_constant_tempco_std: float | None = key(
        None,
        unit="1/K",
        bound=">= 0",
        doc="Standard deviation of ``torque_constant_tempco`` (needs it); identify's budget "
        "line 'torque constant vs temperature'. None: the tempco is taken as exact.",
    )
    temperature_lag: float | None = key(
        None,
        unit="s",
        bound="> 0",
        doc="tau, the magnets follow the logged (winding or housing) temperature through a "
        "first-order lag dT_mag/dt = (T - T_mag) / tau (needs ``torque_constant_tempco`` or "
        "``winding_time_constant``; with the latter, the lag behind the modelled winding). "
        "None: the magnets are at the logged (or modelled) winding temperature.",
    )
    winding_time_constant: float | None = key(
        None,
        unit="s",
        bound="> 0",
        doc="tau_w, the winding's thermal time constant to the ambient (the motor's "
        "datasheet): a motor that warms with the heat its logged torque dissipates, its "
        "temperature not logged. identify and calibrate then fit one coefficient c for the "
        "experiment, the torque's scale 1 + c m(t), m the magnets' rise that the logged "
        "torque's squares drive through tau_w and ``temperature_lag`` from each run's start "
        "(rsp_inertia.estimation.balance.warming_work; docs/method.md §5). Refused with "
        "``torque_constant_tempco`` (a logged temperature compensates the warming). None: "
        "not fitted.",
    )
    reverse_delay: float | None = key(
        None,
        unit="s",
        bound=">= 0",
        doc="The time from a braking log's last row to its reverse log's first row: the "
        "modelled motor cools over it (``winding_time_constant``), and the magnets' lag "
        "behind the logged temperature decays over it (``temperature_lag``: a reverse's "
        "magnets start where its braking left them). Needs one of the two. None: 0, the "
        "reverse follows its braking at once.",
    )
    reference_temperature: float | None = key(
        None,
        unit="deg C",
        doc="T_ref, the magnet temperature at which the torque's scale holds: the one at which "
        "the rig was calibrated (the calibration runs' mean temperature, which ``check`` "
        "reports per pass), else the one of ``torque_constant``'s datasheet. Needed by "
        "``torque_constant_tempco``, refused without it.",
    )
    torque_constant_drift_std: float | None = key(
        None,
        unit="relative",
        bound=Bound("within [0, 0.01] (relative: 0.02 % is 0.0002)", lambda s: 0 <= s <= 0.01),
        doc="The relative std of a change of the torque's scale between a run's braking and "
        "its reverse pass that the rig may have and does not measure (a motor warming between "
        "the passes, its temperature not logged or not compensated): identify propagates it, "
        "independently for each run, as the budget line 'torque scale between the passes' "
        "(docs/method.md §5). None: the passes share one scale.",
    )


    def torque_scale_std(self) -> float | None:
        """The relative std of the logged torque's scale as stated: ``torque_gain_std`` and,
        for logs of the motor current, ``torque_constant_std / torque_constant``, in
        quadrature (independent: the current's measurement and the constant); None when
        neither is stated."""
        parts = [self.torque_gain_std]
        if self.torque_constant is not None and self.torque_constant_std is not None:
            parts.append(self.torque_constant_std / self.torque_constant)
        stated = [v for v in parts if v is not None]
        return math.hypot(*stated) if stated else None


@config_class
class Encoder:
    """Angle encoder on phi (``[encoder]``)."""

    counts_per_rev: int = key(bound="> 0", doc="Counts per revolution.")
    sample_rate: float = key(unit="Hz", bound="> 0", doc="The drive's sampling rate.")
    counter_bits: int | None = key(
        None,
        unit="bits",
        bound=("> 0", Bound("at most 64", lambda bits: bits <= 64)),
        doc="Width of the drive's position counter, when logs give integer ``counts`` that "
        "wrap around at 2**counter_bits; None: counts never wrap.",
    )
    error_cos: tuple[float, ...] | None = key(
        None,
        unit="rad",
        doc="The encoder's reading error e(phi) = sum_n c_n cos(n phi) + s_n sin(n phi), as the "
        "maker's calibration certificate states it (rsp_inertia.plant.transducers): c_n for "
        "n = 1, 2, ...; identify takes every reading back to the true angle with it, unless "
        "a calibration.toml measured the error. None: the encoder is taken as exact.",
    )
    error_sin: tuple[float, ...] | None = key(
        None, unit="rad", doc="s_n of the same series (as many entries as ``error_cos``)."
    )
    error_std: tuple[float, ...] | None = key(
        None,
        unit="rad",
        bound=">= 0",
        doc="Standard deviation of c_n and of s_n, one per order (as many entries); None (not "
        "stated): the stated error is taken as exact.",
    )

    @property
    def error(self) -> np.ndarray:
        """theta_e = [c_1, s_1, c_2, s_2, ...] of the stated reading error, rad; empty when
        none is stated."""
        if self.error_cos is None:
            return np.zeros(0)
        out = np.empty(2 * len(self.error_cos))
        out[0::2], out[1::2] = self.error_cos, self.error_sin
        return out

    @property
    def quantum(self) -> float:
        """One count, rad: 2 pi / counts_per_rev."""
        return 2.0 * math.pi / self.counts_per_rev

    @property
    def dt(self) -> float:
        """Sampling period, s: 1 / sample_rate."""
        return 1.0 / self.sample_rate


@config_class
class Stage:
    """One gear ratio of the gimbal and the protocol run with it (``[[stage]]``;
    docs/method.md §1, §4)."""

    gear_ratio: float = key(
        bound=">= 0", doc="lambda = tan(beta); 0 = outer frame locked, spin about z."
    )
    tare_inertia: float = key(
        absent=0.0,
        unit="kg m^2",
        bound=">= 0",
        doc="M_tare(lambda), reduced to phi (from an empty-fixture run).",
    )
    nodes_deg: tuple[float, ...] = key(
        unit="deg",
        bound=Bound("in [0, 360)", lambda node: 0.0 <= node < 360.0),
        check=_distinct_nodes,
        doc="Angles phi where the tensor is sampled: distinct, at least one.",
    )
    launch_speed: float | None = key(
        None,
        unit="rad/s",
        bound="> 0",
        doc="Speed Omega at the release of the braking pass. None (left out): ``plan`` "
        "chooses it; every command that runs the protocol needs it (:func:`require_protocol`).",
    )
    braking_torque: float | None = key(
        None,
        unit="N m",
        bound=">= 0",
        doc="Motor torque against the motion during the braking pass, at most "
        "``motor.torque_limit`` (the motor applies it). None (left out): ``plan`` chooses it; "
        "every command that runs the protocol needs it (:func:`require_protocol`).",
    )
    braking_torque_2: float | None = key(
        None,
        unit="N m",
        bound=">= 0",
        doc="A two-level braking (docs/method.md, \"A torque scale that differs between the "
        "passes\"): the motor torque against the motion after ``braking_switch_turns`` turns "
        "from the release, at most ``motor.torque_limit``; ``braking_torque`` is held before. "
        "None (left out): one braking torque throughout. A braking whose two levels differ "
        "lets identify fit one pass gain per run (the reverse pass's torque scale against the "
        "braking's: a warming motor).",
    )
    braking_switch_turns: float | None = key(
        None,
        unit="turns",
        bound="> 0",
        doc="Where a two-level braking switches from ``braking_torque`` to "
        "``braking_torque_2``: the turns of phi from the release (the drive switches at the "
        "first sample past it). Given with ``braking_torque_2`` and only with it.",
    )
    directions: tuple[Direction, ...] = key(
        (Direction.FORWARD,),
        check=_distinct_directions,
        doc="Directions the stage is run in, distinct, at least one: forward (phi increases "
        "while braking), backward (phi decreases while braking), or both.",
    )
    tare_inertia_std: float | None = key(
        None,
        unit="kg m^2",
        bound=">= 0",
        doc="Standard deviation of ``tare_inertia``, as the user knows it; None (not stated) "
        "makes identify warn unless a calibration.toml replaces the tare.",
    )
    release_angle_deg: float | None = key(
        None,
        unit="deg",
        doc="Where the rig releases the body for a forward braking pass (the backward pass: "
        "its negative); part of the protocol, which ``plan`` predicts for and writes. None: "
        "the virtual device releases at virtual.toml's ``[run] release_angle_deg``, and "
        "``plan`` assumes a release rsp_inertia.design.plan.RELEASE_BEFORE_NODE_DEG before the "
        "first node.",
    )

    @property
    def nodes(self) -> np.ndarray:
        """The nodes in radians, shape (n_nodes,)."""
        return np.radians(np.asarray(self.nodes_deg, dtype=float))


@config_class
class Body:
    """What the device file knows of the body under test (``[body]``)."""

    mass: float = key(
        unit="kg", bound="> 0", doc="Mass; with it, identify reports the centre of mass."
    )


ROTATION_TOLERANCE = 1e-9
"""How far ``[mounting] rotation`` may be from a rotation: largest entry of R R^T - I and
distance of det R from +1."""

_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def _rotation(rows: tuple[tuple[float, ...], ...], key: str) -> None:
    """Refuse a ``rotation`` that is not a 3 x 3 rotation matrix (orthonormal, det +1, to
    :data:`ROTATION_TOLERANCE`)."""
    if len(rows) != 3:
        raise ContentError(key, f"must have 3 rows (a 3 x 3 rotation), got {len(rows)}")
    R = np.array(rows, dtype=float)
    off = float(np.abs(R @ R.T - np.eye(3)).max())
    if not off <= ROTATION_TOLERANCE:
        raise ContentError(
            key,
            f"must be orthonormal (R R^T = I to {ROTATION_TOLERANCE:g}), got an entry of "
            f"R R^T - I of {off:.3g}",
        )
    det = float(np.linalg.det(R))
    if not abs(det - 1.0) <= ROTATION_TOLERANCE:
        raise ContentError(
            key, f"must have determinant +1 (a rotation, not a reflection), got {det:.6g}"
        )


@config_class
class Mounting:
    """How the body sits on the gimbal (``[mounting]``; docs/method.md §2, "Mountings"): its
    own axes turned by ``rotation`` and its origin at ``origin``, both in the rig's axes (z
    along the shaft, x and y as at phi = 0: the axes of result.json).

    Two mountings are equal when their arrays are."""

    rotation: tuple[tuple[float, ...], ...] = key(
        _IDENTITY,
        names=("x", "y", "z"),
        check=_rotation,
        doc="R, body axes -> rig axes (v_rig = R v_body), given by rows: row k is rig axis k "
        "in body axes, column j body axis j in rig axes; orthonormal with determinant +1; "
        "shape (3, 3), read-only.",
    )
    origin: tuple[float, float, float] = key(
        (0.0, 0.0, 0.0),
        unit="m",
        names=("x", "y", "z"),
        doc="o, the body frame's origin in rig axes, from the rig's centre O; shape (3,), "
        "read-only.",
    )

    def __post_init__(self) -> None:
        # Own read-only copies, so that a frozen mounting stays frozen however it was built.
        for name, shape in (("rotation", (3, 3)), ("origin", (3,))):
            array = np.array(getattr(self, name), dtype=float)
            if array.shape != shape:
                raise ValueError(f"Mounting.{name} must have shape {shape}, got {array.shape}")
            array.flags.writeable = False
            object.__setattr__(self, name, array)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Mounting):
            return NotImplemented
        return np.array_equal(self.rotation, other.rotation) and np.array_equal(
            self.origin, other.origin
        )


@config_class
class Pendulum:
    """Torsion-pendulum baseline runs: the torsion element attached for them, motor off
    (``[pendulum]``)."""

    stiffness: float = key(
        unit="N m/rad",
        bound="> 0",
        doc="c, reduced to phi: the spring is zeroed at the node for each run.",
    )
    amplitude_deg: float = key(
        5.0, unit="deg", bound="> 0", doc="Initial deflection from the node."
    )
    duration: float = key(30.0, unit="s", bound="> 0", doc="Logged time per run.")
    stiffness_std: float | None = key(
        None,
        unit="N m/rad",
        bound=">= 0",
        doc="Std of ``stiffness``, as the user knows it; the best-practice pendulum reduction "
        "carries it into its stds. None (not stated): taken as exact, and identify warns "
        "unless calibration.toml has the stiffness from pendulum runs of the calibration "
        "folders.",
    )


@config_class
class PlanGuess:
    """Rough knowledge of the body and the rig for ``rsp-inertia plan`` (``[plan]``).

    A pilot run of a stage (stageN/pilot.csv) replaces these guesses for that stage.
    """

    inertia: tuple[float, float, float] | None = key(
        None,
        unit="kg m^2",
        bound=">= 0",
        names=("I1", "I2", "I3"),
        doc="Approximate principal moments of the body, any order.",
    )
    box: tuple[float, float, float] | None = key(
        None,
        unit="m",
        bound=">= 0",
        names=("a", "b", "c"),
        doc="Or the body's bounding box: a solid block of ``[body] mass`` with these sides.",
    )
    friction: tuple[float, float, float] = key(
        (0.0, 0.0, 0.0),
        unit="[N m, N m s, N m s^2]",
        bound=">= 0",
        names=FRICTION.names,
        doc="Guessed dissipation [a1, a2, a3] (docs/method.md §3).",
    )
    com_offset: float = key(
        0.0,
        unit="m",
        bound=">= 0",
        doc="Guessed distance of the centre of mass from the rotation axis.",
    )
    torque_noise: float | None = key(
        None, unit="N m", bound=">= 0", doc="Std of the torque log's noise (else a pilot run's)."
    )
    max_duration: float | None = key(
        None,
        unit="s",
        bound="> 0",
        doc="Default of ``plan --max-duration``: the whole experiment's motion time.",
    )

    def principal_moments(self, mass: float | None) -> tuple[float, float, float] | None:
        """The body's approximate principal moments, kg m^2 (from ``box`` with ``mass``)."""
        if self.inertia is not None:
            return self.inertia
        if self.box is None or mass is None:
            return None
        a, b, c = self.box
        return (
            mass * (b * b + c * c) / 12,
            mass * (a * a + c * c) / 12,
            mass * (a * a + b * b) / 12,
        )


@config_class
class Device:
    """The gimbal as described by ``device.toml``."""

    name: str = key(table="device", doc="Name of the device, free text.")
    gravity: float = key(
        absent=DEFAULT_GRAVITY,
        table="device",
        unit="m/s^2",
        bound="> 0",
        doc="Gravitational acceleration.",
    )
    spring: Spring = key(doc="Torsion element; no ``[spring]``: stiffness 0.")
    motor: Motor = key(doc="Drive limits.")
    encoder: Encoder = key(doc="Angle encoder.")
    stages: tuple[Stage, ...] = key(
        name="stage",
        doc="The ``[[stage]]`` tables in file order; stage k lives in the folder stage{k}/.",
    )
    body: Body | None = key(doc="The optional ``[body]`` table.")
    pendulum: Pendulum | None = key(
        None, doc="The optional ``[pendulum]`` table (torsion-pendulum baseline)."
    )
    plan: PlanGuess | None = key(
        None, doc="The optional ``[plan]`` table (guesses for experiment planning)."
    )
    mounting: Mounting | None = key(
        None,
        doc="The optional ``[mounting]`` table: how the body's axes sit in the rig's; None: "
        "they are the rig's (R = identity, origin 0).",
    )
    log: LogLayout = key(
        LogLayout(),
        doc="The ``[log]`` table: how the rig's logger writes its logs (format, columns, "
        "units); left out: CSV ``t,phi,torque`` (or ``t,counts,torque``) in s, rad, N m.",
    )
    asset_id: str | None = key(
        None,
        table="device",
        doc="The rig's asset number in the lab's register (a record of the result: "
        "result.json ``record.asset_id``).",
    )
    calibration_interval_days: int | None = key(
        None,
        table="device",
        unit="days",
        bound="> 0",
        doc="How long a calibration of this rig stays valid: identify after calibration.toml's "
        "``[calibration] date`` plus this many days warns that the calibration is overdue. "
        "None: no interval, never overdue.",
    )

    @property
    def n_axes(self) -> int:
        """Number of distinct instantaneous axes over all stages.

        A stage with gear ratio 0 turns about z whatever its nodes, so it gives one axis;
        any other stage gives one axis per node (docs/method.md §1: e depends on lambda and
        phi).
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
        The gimbal, with the fields' defaults for the keys and tables the file leaves out
        (a stage's protocol None until ``plan`` has written it: :func:`require_protocol`).

    Raises
    ------
    InputError
        The file is missing or is not TOML; a key is missing, unknown, of the wrong type
        or out of range; a stage's ``braking_torque`` exceeds ``motor.torque_limit``;
        ``[plan]`` gives both ``inertia`` and ``box``, or ``box`` without
        ``[body]``; ``[mounting] rotation`` is not a rotation (3 x 3, orthonormal with
        determinant +1 to :data:`ROTATION_TOLERANCE`); or the stages give fewer than six
        distinct axes.

    Examples
    --------
    >>> device = load_device("EXP/device.toml")  # doctest: +SKIP
    >>> device.n_axes, device.stages[0].gear_ratio  # doctest: +SKIP
    (6, 0.7639320225)
    """
    doc = read_file(path)
    try:
        return _device(doc)
    except ContentError as error:
        raise InputError(f"{path}: {error}") from None


def write_device(path: str | os.PathLike, device: Device) -> None:
    """Write ``device`` to ``path`` as a ``device.toml`` that :func:`load_device` reads back
    equal; atomically (rsp_inertia.infra.files.write_atomic).

    Every key whose value is not None is written, in the order of the fields, with its unit
    as a comment.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its folder must exist.
    device : Device
        The gimbal, e.g. a loaded one changed by ``dataclasses.replace``.

    Raises
    ------
    ValueError
        ``device`` breaks a rule of device.toml; the message is load_device's (with ``path``
        in front), and nothing is written.

    Examples
    --------
    >>> device = load_device("EXP/device.toml")  # doctest: +SKIP
    >>> encoder = dataclasses.replace(device.encoder, counts_per_rev=4096)  # doctest: +SKIP
    >>> changed = dataclasses.replace(device, encoder=encoder)  # doctest: +SKIP
    >>> write_device("EXP/device.toml", changed)  # doctest: +SKIP
    """
    header = "device.toml: written by rsp_inertia.plant.config.write_device"
    write_file(path, device, header, _device)


def require_protocol(device: Device, path: str | os.PathLike) -> None:
    """Refuse a device whose stages do not all state their protocol (:data:`PROTOCOL`).

    A device.toml may leave a stage's ``launch_speed`` and ``braking_torque`` out for
    ``rsp-inertia plan``, which chooses them and writes them into the file; every command
    that runs or reads the protocol calls this first (rsp_inertia.plant.experiment.
    open_experiment does, unless told otherwise).

    Parameters
    ----------
    device : Device
        The gimbal, as :func:`load_device` read it.
    path : str or os.PathLike
        Its device.toml, for the message; the folder holding it is the experiment.

    Raises
    ------
    InputError
        The first stage without one of the keys: one line naming the file, the stage's key
        and ``rsp-inertia plan``.
    """
    for k, stage in enumerate(device.stages, 1):
        for name in PROTOCOL:
            if getattr(stage, name) is None:
                raise InputError(
                    f"{path}: stage[{k}].{name}: missing: the protocol is chosen by "
                    f"rsp-inertia plan {os.path.dirname(path) or '.'}, which writes it here"
                )


_CSV_KEYS = ("delimiter", "decimal", "header_line", "skip_after_header")
"""``[log]`` keys that only a CSV log has."""


def _log_rules(device: Device) -> None:
    """The rules that join ``[log]`` to itself and to ``[motor]`` (docs/files.md, [log])."""
    log, motor = device.log, device.motor
    if log.format is LogFormat.CSV:
        if log.delimiter == "," and log.decimal == ",":
            raise ContentError(
                "log.decimal", "',' needs another delimiter than ',' (set log.delimiter)"
            )
    else:
        default = LogLayout()
        for name in _CSV_KEYS:
            if getattr(log, name) != getattr(default, name):
                raise ContentError(
                    f"log.{name}", f"a CSV key, but log.format is {log.format.value!r}"
                )
    if log.format is not LogFormat.TDMS and log.tdms_group:
        raise ContentError("log.tdms_group", f"a TDMS key, but log.format is {log.format.value!r}")
    if log.format is not LogFormat.TDMS and not log.time_column:
        raise ContentError(
            "log.time_column",
            "empty (waveform timing) only with log.format = 'tdms': name the time column",
        )
    for name in ("torque_column", "angle_column"):
        if getattr(log, name) == "":
            raise ContentError(f"log.{name}", "must name a column, got ''")
    current = log.torque_unit is TorqueUnit.A
    if current and motor.torque_constant is None:
        raise ContentError(
            "log.torque_unit",
            "'A' (the motor current) needs motor.torque_constant (N m/A) to give the torque",
        )
    if not current and motor.torque_constant is not None:
        raise ContentError(
            "motor.torque_constant",
            f"given, but log.torque_unit is {log.torque_unit.value!r}: the logs hold no "
            "current (set log.torque_unit = 'A', or leave torque_constant out)",
        )
    if motor.torque_constant_std is not None and motor.torque_constant is None:
        raise ContentError("motor.torque_constant_std", "needs motor.torque_constant")
    _thermal_rules(device)


def _thermal_rules(device: Device) -> None:
    """The rules of the torque constant's temperature compensation (docs/files.md, [motor])."""
    motor = device.motor
    paused = (motor.winding_time_constant, motor.temperature_lag)
    if motor.reverse_delay is not None and paused == (None, None):
        raise ContentError(
            "motor.reverse_delay",
            "needs motor.winding_time_constant or motor.temperature_lag (s: the motor's "
            "cooling or the magnets' lag that the pause acts on; leave this out, or state one)",
        )
    if motor.winding_time_constant is not None and motor.torque_constant_tempco is not None:
        raise ContentError(
            "motor.winding_time_constant",
            "models a warming whose temperature is not logged, and "
            "motor.torque_constant_tempco compensates the logged one: state one of them",
        )
    if motor.torque_constant_tempco is None:
        # The magnets' lag is the modelled winding's too (winding_time_constant).
        lag = () if motor.winding_time_constant is not None else ("temperature_lag",)
        for name in ("torque_constant_tempco_std", *lag, "reference_temperature"):
            if getattr(motor, name) is not None:
                raise ContentError(
                    f"motor.{name}",
                    "needs motor.torque_constant_tempco (1/K; leave this out, or state it)",
                )
        return
    if not device.log.temperature_column:
        raise ContentError(
            "motor.torque_constant_tempco",
            "needs the logs' temperature: set log.temperature_column (or leave the tempco out)",
        )
    if motor.reference_temperature is None:
        raise ContentError(
            "motor.torque_constant_tempco",
            "needs motor.reference_temperature (deg C: where the torque's scale holds, the "
            "calibration's temperature)",
        )


def _device(doc: dict) -> Device:
    """The Device of a parsed device.toml, with the rules that join its tables."""
    device = read_table(Device, doc)
    encoder = device.encoder
    orders = None if encoder.error_cos is None else len(encoder.error_cos)
    for name in ("error_sin", "error_std"):
        value = getattr(encoder, name)
        if value is not None and orders is None:
            raise ContentError(f"encoder.{name}", "needs encoder.error_cos")
        if orders is not None and name == "error_sin" and value is None:
            raise ContentError("encoder.error_sin", "missing: encoder.error_cos needs it")
        if value is not None and len(value) != orders:
            raise ContentError(
                f"encoder.{name}",
                f"must have one entry per order of encoder.error_cos ({orders}), got {len(value)}",
            )
    if device.plan is not None:
        if device.plan.inertia is not None and device.plan.box is not None:
            raise ContentError("plan", "give either inertia or box, not both")
        if device.plan.box is not None and device.body is None:
            raise ContentError("plan.box", "needs the body's mass ([body] mass)")
    limit = device.motor.torque_limit
    for k, stage in enumerate(device.stages, 1):
        for name in ("braking_torque", "braking_torque_2"):
            value = getattr(stage, name)
            if value is not None and value > limit:
                raise ContentError(
                    f"stage[{k}].{name}",
                    f"must be <= motor.torque_limit = {limit!r} (the motor applies it), "
                    f"got {value!r}",
                )
        if (stage.braking_torque_2 is None) != (stage.braking_switch_turns is None):
            given, missing = (
                ("braking_torque_2", "braking_switch_turns")
                if stage.braking_switch_turns is None
                else ("braking_switch_turns", "braking_torque_2")
            )
            raise ContentError(
                f"stage[{k}].{given}",
                f"a two-level braking needs stage[{k}].{missing} too (or leave both out)",
            )
    _log_rules(device)
    if device.n_axes < REQUIRED_AXES:
        raise ContentError(
            "stage", f"the stages give {device.n_axes} distinct axes, {REQUIRED_AXES} are needed"
        )
    return device
