"""``virtual.toml``: the virtual device's truth, read and written.

``virtual.toml`` exists only for a virtual device: the true body in its own axes (absent for
an empty-fixture run; :func:`placed_body` puts it on the rig) and the fixture, the friction
law in each direction of motion, the rig's imperfections, a body seated off its stated
mounting, and the settings of the simulated runs. docs/files.md documents every key; the
config classes below declare them (rsp_inertia.infra.toml_schema). The bodies are
:class:`rsp_inertia.plant.reference_config.TrueBody`, the rigid body of reference.toml.
"""

from __future__ import annotations

import math
import os

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.toml_schema import (
    ContentError,
    config_class,
    key,
    read_file,
    read_table,
)
from rsp_inertia.infra.toml_writer import write_file
from rsp_inertia.plant.device_config import Device, Mounting
from rsp_inertia.plant.experiment import VIRTUAL_FILE, Experiment
from rsp_inertia.plant.geometry import place_body, small_rotation
from rsp_inertia.plant.reference_config import TrueBody
from rsp_inertia.plant.transducers import drive_gains, encoder_reading, error_coefficients

__all__ = [
    "ControllerSettings",
    "Friction",
    "LoggerSettings",
    "Rig",
    "RunSettings",
    "Virtual",
    "VirtualMounting",
    "experiment_virtual",
    "load_virtual",
    "placed_body",
    "write_virtual",
]

@config_class
class Friction:
    """Dissipation D = (a1 + a3 W^2) sign W + a2 W, reduced to phi (docs/method.md §3)."""

    coulomb: float = key(unit="N m", bound=">= 0", doc="a1; also the static friction at rest.")
    viscous: float = key(unit="N m s", bound=">= 0", doc="a2.")
    quadratic: float = key(unit="N m s^2", bound=">= 0", doc="a3.")
    backward_scale: float = key(
        1.0,
        bound=">= 0",
        doc="Factor on a1, a2 and a3 while the body moves backward (Omega < 0); 1 = the same "
        "friction in both directions.",
    )


@config_class
class RunSettings:
    """How the virtual device runs and logs a stage (``[run]``)."""

    release_angle_deg: float = key(
        -30.0, unit="deg", doc="Angle phi where the braking pass starts, any real."
    )
    torque_noise: float = key(
        0.0,
        unit="N m",
        bound=">= 0",
        doc="Standard deviation of the noise added to the logged torque.",
    )
    seed: int = key(0, bound=">= 0", doc="Seed of the random generator.")


@config_class
class LoggerSettings:
    """How the virtual rig's drive samples and logs: a real drive's timing imperfections
    (``[logger]``).

    The drive's loop reads the encoder, sets the torque and writes a log row at each of its
    sampling instants; the log's time stamps are those instants (rsp_inertia.plant.logs).
    """

    time_jitter: float = key(
        0.0,
        unit="fraction of a sample period",
        bound=(">= 0", "<= 0.25 (of a period)"),
        doc="Each sampling instant is off the regular grid k / sample_rate by a uniform random "
        "amount within +- this fraction of a period (the logs' limit is "
        "rsp_inertia.plant.logs.JITTER_LIMIT); the first row stays at t = 0.",
    )
    dropped_fraction: float = key(
        0.0,
        unit="fraction of rows",
        bound=(">= 0", "< 0.5"),
        doc="Fraction of the rows the logger loses at random (the drive still acts at those "
        "instants); the first and last rows are always kept.",
    )
    hold_after_stop: float = key(
        0.0,
        unit="s",
        bound=(">= 0", "<= 600"),
        doc="How long the logger goes on writing a braking's rows after the body stopped, "
        "the drive holding it (a real drive's log; the reader cuts it at the braking's "
        "turning point, rsp_inertia.plant.log_checks.turning_point); 0: the log ends at the "
        "last sample before the stop.",
    )
    hold_dither: int = key(
        0,
        unit="counts",
        bound=(">= 0", "<= 100"),
        doc="While held, each reading is off the rest's by a uniform random whole number of "
        "counts within +- this (an encoder dithering at a count's edge, a holding loop's "
        "hunting).",
    )
    backlash_counts: int = key(
        0,
        unit="counts",
        bound=(">= 0", "<= 1000"),
        doc="While held, the reading settles back against the braking's direction by this "
        "many counts, one a sample from the stop, and stays there (the body taking up the "
        "drive's backlash).",
    )
    counts: bool = key(
        False,
        doc="Write ``t,counts,torque`` with integer counts of the drive's position counter "
        "(device.toml ``[encoder] counter_bits``, which must then be set: the counts wrap "
        "there) instead of ``t,phi,torque``.",
    )


@config_class
class ControllerSettings:
    """The virtual device's controller (``[controller]``)."""

    speed_observer_bandwidth: float = key(
        100.0,
        unit="rad/s",
        bound="> 0",
        doc="Bandwidth of the speed estimate the controller forms from the encoder.",
    )


@config_class
class Rig:
    """Imperfections of the virtual rig: what the real one does differently from its file
    (``[rig]``)."""

    torque_gain: float = key(
        1.0,
        bound="> 0",
        doc="Logged torque over the torque physically applied; 1 = exact.",
    )
    tare_inertia: tuple[float, ...] | None = key(
        None,
        unit="kg m^2",
        bound=">= 0",
        doc="True M_tare of each stage, one per [[stage]] of device.toml (which only "
        "approximates them); None: device.toml's values are exact.",
    )
    pendulum_stiffness: float | None = key(
        None,
        unit="N m/rad",
        bound="> 0",
        doc="True stiffness of the pendulum's torsion element (device.toml's ``[pendulum] "
        "stiffness`` only approximates it); None: device.toml's is exact.",
    )
    efficiency_driving: float = key(
        1.0,
        bound=("> 0", "<= 1"),
        doc="Efficiency of the drive's transmission while the motor drives the body "
        "(torque x speed > 0): the body receives this x the motor's torque; 1 = lossless "
        "(rsp_inertia.plant.transducers).",
    )
    efficiency_backdriven: float = key(
        1.0,
        bound=("> 0", "<= 1"),
        doc="Efficiency while the body drives the motor back (torque x speed < 0, a braking "
        "torque): the body gives the motor's torque / this; 1 = lossless.",
    )
    encoder_error_amplitude: tuple[float, ...] | None = key(
        None,
        unit="rad",
        bound=">= 0",
        doc="The encoder reads phi + e(phi), e = sum_n A_n sin(n phi + p_n): A_n for the orders "
        "n = 1, 2, ... (eccentricity, runout); None = an exact encoder. Acts on every log and "
        "inside the closed loop.",
    )
    encoder_error_phase_deg: tuple[float, ...] | None = key(
        None,
        unit="deg",
        doc="p_n of each order of ``encoder_error_amplitude`` (as many entries).",
    )

    encoder_zero_deg: float = key(
        0.0,
        unit="deg",
        doc="The encoder's zero offset: it reads phi + this + e(phi), phi = 0 where the body "
        "frame's y points up (docs/method.md §1); 0 = zeroed there.",
    )
    encoder_reversed: bool = key(
        False,
        doc="The encoder counts backward: it reads minus what it should, while the torque "
        "keeps its sign (docs/method.md §1: phi must increase where a positive torque turns "
        "the shaft).",
    )
    gear_reversed: bool = key(
        False,
        doc="The gear turns the outer frame the other way: psi = -lambda phi where device.toml "
        "states gear_ratio = lambda.",
    )
    phi_left_handed: bool = key(
        False,
        doc="The shaft read from its other end: the encoder and the torque both reversed, phi "
        "left-handed about the body's z. Simulated as the rig's truth mirrored in x "
        "(Jxy, Jxz and x_c flipped) read the stated way.",
    )

    torque_constant_tempco: float = key(
        0.0,
        unit="1/K",
        bound=(">= -0.01", "<= 0.01"),
        doc="alpha: the body receives the logged torque x (1 + alpha (T_magnet - "
        "ambient_temperature)) x h_d or h_b (rsp_inertia.plant.transducers.thermal_gains); "
        "about -0.0011 for NdFeB magnets, -0.0003 for SmCo; 0 = a constant torque constant.",
    )
    torque_constant: float = key(
        1.0,
        unit="N m/A",
        bound="> 0",
        doc="The logged torque per ampere of the winding's current (the motor's nominal "
        "constant reduced to phi): the current that heats the winding is I = the logged "
        "command / this.",
    )
    winding_resistance: float = key(
        0.0,
        unit="ohm",
        bound=">= 0",
        doc="R, the winding's resistance: it dissipates P = I^2 R; 0 = no heating.",
    )
    thermal_resistance: float = key(
        0.0,
        unit="K/W",
        bound=">= 0",
        doc="R_th, from the winding to the ambient: the winding's steady rise is P R_th; "
        "0 = no heating.",
    )
    winding_time_constant: float = key(
        60.0,
        unit="s",
        bound="> 0",
        doc="tau_w of the winding's first-order rise: tau_w dT_w/dt = P R_th - (T_w - "
        "ambient) (rsp_inertia.virtual.thermal).",
    )
    magnet_lag: float = key(
        0.0,
        unit="s",
        bound=">= 0",
        doc="tau_m, the magnets' first-order lag behind the winding: tau_m dT_m/dt = T_w - "
        "T_m; 0 = the magnets at the winding's temperature.",
    )
    ambient_temperature: float = key(
        25.0,
        unit="degC",
        doc="The ambient, the torque constant's reference and every run's starting "
        "temperature of winding and magnets.",
    )
    reverse_temperature_offset: float = key(
        0.0,
        unit="K",
        doc="A prescribed extra temperature of the whole motor (winding, magnets, the logged "
        "temperature) throughout every reverse pass, on top of the thermal model: the "
        "simplest case of a torque constant that differs between the passes, (1 + alpha "
        "this) on the reverse's torque alone.",
    )
    run_start_rise: float = key(
        0.0,
        unit="K",
        doc="Run k of the experiment (0-based, in the order the device makes its runs: stage "
        "by stage, its directions in device.toml's order) starts with winding and magnets k "
        "x this above the ambient (a motor not left to cool between the runs: it cools "
        "towards its steady rise through each run, rsp_inertia.virtual.thermal); 0: every "
        "run starts at the ambient. Calibration runs that span the magnets' temperature.",
    )
    temperature_noise: float = key(
        0.05,
        unit="K",
        bound=">= 0",
        doc="Standard deviation of the logged temperature's sensor noise (then rounded to "
        "0.1 K), on a rig with a thermal model (winding_resistance and thermal_resistance > "
        "0, a reverse_temperature_offset or a run_start_rise); without one the logger writes "
        "the ambient, no noise.",
    )

    @property
    def thermal(self) -> bool:
        """Whether the motor's temperature moves: the winding heats (R and R_th > 0), the
        reverse runs at a prescribed offset or the runs start warm (rsp_inertia.virtual.thermal)."""
        heats = self.winding_resistance > 0.0 and self.thermal_resistance > 0.0
        return heats or self.reverse_temperature_offset != 0.0 or self.run_start_rise != 0.0

    @property
    def drive_gains(self) -> tuple[float, float]:
        """(h_d, h_b): torque received per unit logged torque, driving and back-driven
        (rsp_inertia.plant.transducers.drive_gains)."""
        return drive_gains(self.torque_gain, self.efficiency_driving, self.efficiency_backdriven)

    @property
    def encoder_error(self) -> np.ndarray:
        """theta_e = [c_1, s_1, c_2, s_2, ...] of the encoder's error, rad
        (rsp_inertia.plant.transducers.error_coefficients); empty for an exact encoder."""
        if self.encoder_error_amplitude is None:
            return np.zeros(0)
        return error_coefficients(self.encoder_error_amplitude, self.encoder_error_phase_deg)

    def reading(self, phi, quantum: float):
        """What this rig's encoder reads at true angle ``phi``: floor((phi + z + e(phi)) / q) q
        (rsp_inertia.plant.transducers.encoder_reading), negated when it counts backward."""
        read = encoder_reading(phi, quantum, self.encoder_error, math.radians(self.encoder_zero_deg))
        return -read if self.encoder_reversed else read

    def true_tare(self, device: Device, stage: int, source: str = VIRTUAL_FILE) -> float:
        """The true M_tare of a stage (docs/method.md §2).

        Parameters
        ----------
        device : Device
            The experiment's device: its stages, and their stated tares.
        stage : int
            The stage, 1-based.
        source : str
            The virtual.toml file, in messages.

        Returns
        -------
        float
            M_tare, kg m^2: ``tare_inertia``'s entry, or device.toml's stated tare without it.

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


@config_class
class VirtualMounting:
    """How the body really sits, against device.toml's ``[mounting]`` (``[mounting]`` of
    virtual.toml): a body not seated as the fixture's drawing says (docs/method.md §2,
    "Mountings")."""

    misalignment_deg: tuple[float, float, float] = key(
        (0.0, 0.0, 0.0),
        unit="deg",
        names=("ax", "ay", "az"),
        doc="Small angles about the rig's x, y and z axes by which the real mounting is "
        "turned from the stated one: R_true = small_rotation(ax, ay, az) R_stated "
        "(rsp_inertia.plant.geometry.small_rotation); the origin stays the stated one.",
    )


@config_class
class Virtual:
    """The virtual device as described by ``virtual.toml``.

    ``models`` is no key of the file: per stage, the true model given directly
    (rsp_inertia.plant.model.ModelParameters, both directions of motion) in place of body,
    fixture, tare and friction, for a rehearsal of a plan on its nominal model
    (rsp_inertia.design.rehearsal); None otherwise.
    """

    body: TrueBody | None = key(
        doc="The true body in its own axes (placed on the rig by device.toml's "
        "``[mounting]``: rsp_inertia.virtual.device.placed_body); None for an empty-fixture "
        "run (no ``[body]``)."
    )
    friction: Friction = key(
        doc="The true friction law; forward motion always uses its coefficients."
    )
    run: RunSettings = key(doc="Run settings.")
    controller: ControllerSettings = key(doc="Controller settings.")
    fixture: TrueBody | None = key(
        None,
        doc="The mounting plate, rigidly on the shaft with the body, in the rig's axes (the "
        "body's mounting does not move it); None: none.",
    )
    rig: Rig = key(Rig(), doc="The rig's imperfections; an exact rig by default.")
    friction_backward: Friction | None = key(
        None,
        without=("backward_scale",),
        doc="Explicit friction for backward motion (Omega < 0); None: ``friction`` scaled by "
        "its ``backward_scale``.",
    )
    logger: LoggerSettings = key(
        LoggerSettings(),
        doc="The drive's sampling and logging; regular and lossless by default.",
    )
    mounting: VirtualMounting | None = key(
        None,
        doc="How the body really sits against device.toml's ``[mounting]``; None: as stated.",
    )
    models: tuple | None = None

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


def placed_body(device: Device, virtual: Virtual) -> TrueBody | None:
    """The virtual device's true body on the rig: its tensor about O and its centre of mass,
    both in rig axes (docs/method.md §2, "Mountings").

    ``virtual.toml``'s ``[body]`` is in the body's own axes; device.toml's ``[mounting]``
    places it (rotation R, origin o), turned further by virtual.toml's ``[mounting]
    misalignment_deg`` when the body is not seated as stated: R_true =
    small_rotation(misalignment) R (rsp_inertia.plant.geometry.place_body, small_rotation).
    Every use of the truth on the rig (the simulator's model, comparisons with identify's
    result) goes through this function.

    Parameters
    ----------
    device : Device
        The gimbal; its ``mounting`` (None: R = identity, origin 0).
    virtual : Virtual
        The truth; its ``body`` and ``mounting``.

    Returns
    -------
    TrueBody or None
        None for an empty-fixture run (no ``[body]``); ``virtual.body`` itself when neither
        file has a ``[mounting]`` table (the body's axes are the rig's); else the body placed:
        the same mass, ``inertia`` about O in rig axes, ``com`` in rig axes.
    """
    body = virtual.body
    if body is None or (device.mounting is None and virtual.mounting is None):
        return body
    stated = device.mounting if device.mounting is not None else Mounting()
    rotation = stated.rotation
    if virtual.mounting is not None:
        rotation = small_rotation(virtual.mounting.misalignment_deg) @ rotation
    inertia, com = place_body(body.inertia, body.com, body.mass, rotation, stated.origin)
    return TrueBody(mass=body.mass, inertia=inertia, com=com)


def load_virtual(path: str | os.PathLike) -> Virtual:
    """Read a ``virtual.toml`` file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its name as given appears in error messages.

    Returns
    -------
    Virtual
        The true body and fixture, the friction law, the rig's imperfections and the run,
        controller and logger settings, with the fields' defaults for the optional tables
        and keys the file leaves out.

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
    doc = read_file(path)
    try:
        return _virtual(doc)
    except ContentError as error:
        raise InputError(f"{path}: {error}") from None



def experiment_virtual(exp: Experiment) -> Virtual:
    """The virtual device's truth of an experiment folder (``EXP/virtual.toml``); an error if
    the folder is not a virtual experiment.

    Also checks virtual.toml against device.toml (``rig.tare_inertia``: one per stage).

    Parameters
    ----------
    exp : rsp_inertia.plant.experiment.Experiment
        The experiment folder.

    Returns
    -------
    Virtual
        What ``exp.virtual_path`` holds.

    Raises
    ------
    InputError
        No virtual.toml in the folder (the message says where to get one), or one that
        :func:`load_virtual` or :meth:`Rig.true_tare` refuses.
    """
    if not exp.virtual_path.is_file():
        raise InputError(
            f"{exp.virtual_path}: not found: only a virtual device (with virtual.toml) "
            "can be simulated; write one (the true body, friction and rig: docs/files.md "
            "lists its keys, docs/real-rig.md shows a rig's), or python -c \"import "
            f"rsp_inertia; rsp_inertia.create_experiment({str(exp.root)!r})\" writes the "
            "default one (the paper's body on an exact gimbal) and keeps the device.toml "
            "there"
        )
    virtual = load_virtual(exp.virtual_path)
    virtual.rig.true_tare(exp.device, 1, source=str(exp.virtual_path))
    return virtual

def write_virtual(path: str | os.PathLike, virtual: Virtual) -> None:
    """Write ``virtual`` to ``path`` as a ``virtual.toml`` that :func:`load_virtual` reads
    back equal; atomically (rsp_inertia.infra.files.write_atomic).

    Every key whose value is not None is written, in the order of the fields, with its unit
    as a comment.

    Raises
    ------
    ValueError
        ``virtual`` breaks a rule of virtual.toml (load_virtual's message, with ``path`` in
        front), or holds what the file cannot: ``models``, or a ``friction_backward`` with a
        ``backward_scale``. Nothing is written.
    """
    header = "virtual.toml: written by rsp_inertia.virtual.config.write_virtual"
    write_file(path, virtual, header, _virtual)


def _virtual(doc: dict) -> Virtual:
    """The Virtual of a parsed virtual.toml, with the rule that joins its friction tables."""
    virtual = read_table(Virtual, doc)
    amplitude, phase = virtual.rig.encoder_error_amplitude, virtual.rig.encoder_error_phase_deg
    if (amplitude is None) != (phase is None) or (
        amplitude is not None and len(amplitude) != len(phase)
    ):
        raise ContentError(
            "rig.encoder_error_phase_deg",
            "must have one entry per order of rig.encoder_error_amplitude "
            f"({0 if amplitude is None else len(amplitude)}), got "
            f"{0 if phase is None else len(phase)}",
        )
    if virtual.friction_backward is not None and virtual.friction.backward_scale != 1.0:
        raise ContentError(
            "friction_backward",
            "give either friction.backward_scale or [friction_backward], not both",
        )
    return virtual
