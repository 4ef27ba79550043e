"""The gimbal in MuJoCo: an independent 3-D engine against the reduced model, and a rig made of it.

    python -m benchmarks.engine [--seeds N] [--jobs N] [--out DIR]

**The engine's gimbal** (:func:`gimbal_xml`, :class:`GimbalEngine`) is built from physical
frames, not from the reduced model (docs/method.md §1): a world with z up and gravity -z; an
outer frame on a hinge about the world's vertical (joint ``psi``) with its inertia I about
it; a shaft carried by the outer frame on a horizontal hinge (joint ``phi``) about the shaft
body's own z, the shaft's frame turned by Rx(pi/2) from the outer frame's, so that the body
frame is R = Rz(psi) Rx(pi/2) Rz(phi) for qpos = (psi, phi); the body under test and the
fixture welded to the shaft, each a :class:`rsp_inertia.plant.reference_config.TrueBody`
(tensor about O in body axes, centre of mass), handed to MuJoCo as its inertia about the
centre of mass (``fullinertia``, the parallel-axis theorem: :func:`central_inertia`); a motor
on ``phi``; the gear as MuJoCo's joint equality psi = lambda phi (``polycoef``); joint
friction; gravity. tests/plant/test_engine.py checks the reduced model of
:mod:`rsp_inertia.plant.model` against it: M(phi) from the engine's 2 x 2 joint-space mass
matrix, the energies, the acceleration, and the sign conventions of a reversed gear and of
an encoder read from the other end.

**The engine-made rig** (:func:`braking_pass`, :func:`reverse_pass`, :func:`run_experiment`)
writes an experiment's logs as a real rig would (docs/files.md, Logs): the braking pass from
the release to rest, then the reverse pass executing ``program.csv`` in closed loop with the
virtual device's drive (:class:`rsp_inertia.virtual.drive.SpeedObserver`,
:class:`rsp_inertia.virtual.drive.ProgramDrive`). The benchmark (:func:`main`) runs the
calibrated route on engine-made logs (an empty-fixture and a reference-body calibration
folder, then the body) and writes benchmarks/results/engine.md.

How the engine is run, and why (MuJoCo's documentation, Computation and XML reference):

- **Integrator.** RK4 (``integrator="RK4"``), ENGINE_STEPS steps per encoder sample: the
  drive's torque is a zero-order hold over the sample, and every velocity-dependent force
  MuJoCo computes itself (Coriolis, joint damping, the constraints) is re-evaluated at each of
  RK4's four stages. With the semi-implicit Euler integrator they would be set once per step
  from the step's starting speed, a lag of half a step that makes the friction work differ
  between a decelerating braking and its accelerating mirror.
- **The gear** is a soft constraint in MuJoCo, like every constraint: it behaves as a
  spring-damper on its violation r = psi - lambda phi, r'' + d b r' + d k r = (1 - d) a0
  (a0 the unconstrained acceleration of r). At the default solref/solimp (0.02 s, d = 0.9)
  r reaches 1e-4 rad at speed, which would show in M(phi). The gear is made as stiff as the
  engine allows: impedance d = 0.9999 (mjMAXIMP) and a time constant of GEAR_TIMECONST_STEPS
  steps, so r ~ 1e-4 a0 (timeconst)^2 < 1e-10 rad.
- **Coulomb friction** is the joint's ``frictionloss``, a soft constraint too: while the
  joint slides faster than about a1 / (M b) (b = 2 / timeconst of solreffriction, about
  1e-5 rad/s here) its force is clamped at exactly a1; slower, it is a steep viscous law,
  so a body under a braking torque still passes through zero speed, where the braking pass
  ends. The viscous part a2 is the joint's ``damping``. MuJoCo has no quadratic friction:
  a3 W |W| is applied as a joint force (``qfrc_applied``) set once per engine step, at the
  speed predicted at the step's middle from the last acceleration, W + eps h / 2, so that it
  is second-order in h like the rest (set from W alone it would lag by half a step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from rsp_inertia.plant.geometry import tensor_from_entries
from rsp_inertia.plant.reference_config import TrueBody

ENGINE_STEPS = 10
"""RK4 steps of the engine per encoder sample (0.1 ms at 1 kHz)."""

GEAR_TIMECONST_STEPS = 4.0
"""The gear constraint's solref time constant in engine steps (MuJoCo asks for >= 2)."""

MAX_IMPEDANCE = 0.9999
"""mjMAXIMP: the largest constraint impedance MuJoCo accepts (solimp's d0 = dwidth)."""


@dataclass(frozen=True)
class Gimbal:
    """A gimbal for the engine: the moving parts, the gear, gravity and the joint friction."""

    gear_ratio: float
    """lambda, psi = lambda phi (may be negative: a reversed gear)."""
    body: TrueBody | None
    """The body under test on the shaft (tensor about O and centre of mass in body axes);
    None: an empty fixture."""
    fixture: TrueBody | None = None
    """The fixture welded to the shaft with the body, in body axes; None: none."""
    frame_inertia: float = 0.0
    """I, kg m^2: the outer frame about the vertical z1."""
    frame_side_inertia: tuple[float, float] | None = None
    """kg m^2, the outer frame about its own horizontal x and y: it only turns about z1, so
    they never enter (the tests show it); None: I / 2 each, a flat ring's (MuJoCo refuses a
    tensor that breaks the triangle inequality)."""
    gravity: float = 9.80665
    """m/s^2."""
    coulomb: float = 0.0
    """a1, N m: the phi joint's frictionloss."""
    viscous: float = 0.0
    """a2, N m s: the phi joint's damping."""
    quadratic: float = 0.0
    """a3, N m s^2: applied as a joint force by the rig (:meth:`GimbalEngine.step`)."""
    timestep: float = 1e-4
    """s, the engine's step."""
    parts: tuple[TrueBody, ...] = field(init=False, repr=False, compare=False)
    """The parts welded to the shaft (body, fixture), those present."""

    def __post_init__(self) -> None:
        parts = tuple(p for p in (self.body, self.fixture) if p is not None)
        object.__setattr__(self, "parts", parts)


def central_inertia(part: TrueBody) -> np.ndarray:
    """The part's tensor about its centre of mass in body axes, kg m^2, shape (3, 3): the
    parallel-axis theorem J_O = J_G + m (|c|^2 1 - c c^T) solved for J_G (docs/method.md §2,
    Mountings)."""
    c = np.asarray(part.com, dtype=float)
    return tensor_from_entries(part.inertia) - part.mass * (c @ c * np.eye(3) - np.outer(c, c))


def _numbers(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _inertial(part: TrueBody) -> str:
    """MJCF ``<inertial>`` of a part: mass, centre of mass, full inertia about it in the order
    MuJoCo reads it (Ixx Iyy Izz Ixy Ixz Iyz, tensor entries)."""
    J = central_inertia(part)
    full = (J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[0, 2], J[1, 2])
    return (
        f'<inertial pos="{_numbers(part.com)}" mass="{float(part.mass)!r}" '
        f'fullinertia="{_numbers(full)}"/>'
    )


def gimbal_xml(gimbal: Gimbal) -> str:
    """The MJCF text of the gimbal (module docstring).

    The shaft's frame is the outer frame's turned by +90 deg about x (quaternion
    (cos 45, sin 45, 0, 0)), and ``phi`` turns about its z: the body frame of qpos (psi, phi)
    is Rz(psi) Rx(pi/2) Rz(phi), docs/method.md §1's ZXZ Euler angles with theta = pi/2. The
    gear is ``<equality><joint joint1="psi" joint2="phi" polycoef="0 lambda 0 0 0">``:
    psi - psi_ref = lambda (phi - phi_ref), both references 0.
    """
    h = gimbal.timestep
    side = gimbal.frame_side_inertia
    ix, iy = (gimbal.frame_inertia / 2,) * 2 if side is None else side
    # MuJoCo needs a positive mass on a moving body's inertial; the outer frame's sits on the
    # vertical axis at O, where gravity does no work on it.
    frame = f'<inertial pos="0 0 0" mass="1.0" diaginertia="{_numbers((ix, iy, gimbal.frame_inertia))}"/>'
    parts = "\n".join(
        f'        <body name="{name}">{_inertial(part)}</body>'
        for name, part in (("body", gimbal.body), ("fixture", gimbal.fixture))
        if part is not None
    )
    half = math.sqrt(0.5)
    gear_solref = f"{GEAR_TIMECONST_STEPS * h!r} 1"
    gear_solimp = f"{MAX_IMPEDANCE} {MAX_IMPEDANCE} 0.001 0.5 2"
    return f"""<mujoco model="rsp-gimbal">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{h!r}" integrator="RK4" gravity="0 0 {-gimbal.gravity!r}">
    <flag energy="enable" contact="disable"/>
  </option>
  <worldbody>
    <body name="outer_frame">
      <joint name="psi" type="hinge" axis="0 0 1"/>
      {frame}
      <body name="shaft" quat="{half!r} {half!r} 0 0">
        <joint name="phi" type="hinge" axis="0 0 1" frictionloss="{gimbal.coulomb!r}" damping="{gimbal.viscous!r}"/>
{parts}
      </body>
    </body>
  </worldbody>
  <equality>
    <joint name="gear" joint1="psi" joint2="phi" polycoef="0 {float(gimbal.gear_ratio)!r} 0 0 0" solref="{gear_solref}" solimp="{gear_solimp}"/>
  </equality>
  <actuator>
    <motor name="motor" joint="phi"/>
  </actuator>
</mujoco>
"""


class GimbalEngine:
    """A MuJoCo model of a :class:`Gimbal` and its state (MjData).

    The gimbal's one degree of freedom phi lives in the engine as qpos = (psi, phi) =
    (lambda phi, phi), qvel = Omega (lambda, 1) = Omega g, g = (lambda, 1).

    Attributes
    ----------
    gimbal : Gimbal
        What it models.
    model : mujoco.MjModel
        Built from :func:`gimbal_xml`.
    data : mujoco.MjData
        The engine's state.
    """

    def __init__(self, gimbal: Gimbal) -> None:
        self.gimbal = gimbal
        self.model = mujoco.MjModel.from_xml_string(gimbal_xml(gimbal))
        self.data = mujoco.MjData(self.model)
        self.g = np.array([gimbal.gear_ratio, 1.0])
        self._psi = self.model.joint("psi").qposadr[0]
        self._phi = self.model.joint("phi").qposadr[0]
        self._phi_dof = self.model.joint("phi").dofadr[0]
        self._eps = 0.0  # the last engine step's mean acceleration, rad/s^2 (:meth:`step`)

    def set_state(self, phi: float, Omega: float, torque: float = 0.0, applied: float = 0.0) -> None:
        """Put the engine at (phi, Omega) on the gear, the motor at ``torque`` (N m) and a joint
        force ``applied`` (N m) on phi, and evaluate it (mj_forward)."""
        d = self.data
        d.qpos[self._psi] = self.gimbal.gear_ratio * phi
        d.qpos[self._phi] = phi
        d.qvel[:] = Omega * self.g
        d.ctrl[0] = torque
        d.qfrc_applied[:] = 0.0
        d.qfrc_applied[self._phi_dof] = applied
        mujoco.mj_forward(self.model, d)

    def mass_matrix(self) -> np.ndarray:
        """The engine's 2 x 2 joint-space mass matrix at its state (mj_fullM), kg m^2."""
        M2 = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, M2)
        return M2

    def reduced_inertia(self, phi: float) -> float:
        """M(phi) = g^T M2 g, kg m^2: the kinetic energy of qvel = Omega g is M Omega^2 / 2."""
        self.set_state(phi, 0.0)
        return float(self.g @ self.mass_matrix() @ self.g)

    def energies(self, phi: float, Omega: float) -> tuple[float, float]:
        """The engine's (potential, kinetic) energy at (phi, Omega), J (mjENBL_ENERGY)."""
        self.set_state(phi, Omega)
        return float(self.data.energy[0]), float(self.data.energy[1])

    def acceleration(
        self, phi: float, Omega: float, torque: float, applied: float = 0.0
    ) -> float:
        """eps, rad/s^2, from the engine's forces: the gear holds q = g phi, so qacc = g eps,
        and its constraint force is normal to g (the gradient of psi - lambda phi is
        (1, -lambda), and g . (1, -lambda) = 0): projected on g, the engine's equation
        M2 qacc + bias = tau + constraint force gives

            g^T M2 g eps = g^T (tau - bias),

        tau the motor's, the joint's passive (damping) and the applied forces, bias MuJoCo's
        qfrc_bias (Coriolis, centrifugal, gravity). Frictionloss, a constraint, is not in it:
        set ``coulomb`` to 0 here, and pass a dissipative torque as ``applied``.
        """
        self.set_state(phi, Omega, torque, applied)
        d = self.data
        tau = d.qfrc_actuator + d.qfrc_passive + d.qfrc_applied
        return float(self.g @ (tau - d.qfrc_bias) / (self.g @ self.mass_matrix() @ self.g))

    def step(self, torque: float, steps: int) -> None:
        """Advance the engine by ``steps`` steps with the motor at ``torque`` (N m, held: the
        drive's zero-order hold), the quadratic friction -a3 W |W| applied per step at the
        step's predicted mid-speed W + eps h / 2, eps the previous step's mean acceleration
        (module docstring)."""
        m, d = self.model, self.data
        h = self.gimbal.timestep
        a3 = self.gimbal.quadratic
        d.ctrl[0] = torque
        for _ in range(steps):
            W = d.qvel[self._phi_dof]
            mid = W + self._eps * h / 2
            d.qfrc_applied[self._phi_dof] = -a3 * mid * abs(mid)
            mujoco.mj_step(m, d)
            self._eps = (d.qvel[self._phi_dof] - W) / h

    def release(self, phi: float, Omega: float = 0.0) -> None:
        """Start a motion at (phi, Omega) on the gear: a launch, or rest where the drive held
        the body between passes."""
        self.set_state(phi, Omega)
        self._eps = 0.0

    @property
    def phi(self) -> float:
        """rad, the engine's true phi."""
        return float(self.data.qpos[self._phi])

    @property
    def speed(self) -> float:
        """rad/s, the engine's true Omega."""
        return float(self.data.qvel[self._phi_dof])

    def holding_torque(self, phi: float) -> float:
        """N m, the motor torque that holds the body at rest at ``phi``: the engine's gravity
        force projected on the gear, g^T qfrc_bias at zero speed."""
        self.set_state(phi, 0.0)
        return float(self.g @ self.data.qfrc_bias)


# --- the engine-made rig ----------------------------------------------------------------------

MAX_BRAKING_TIME = 600.0
"""s: a braking pass that has not stopped by then is a protocol error."""


@dataclass(frozen=True)
class EngineRig:
    """The engine-made rig: what is on the gimbal besides the body, its friction and its
    logger. The drive is exact (the body receives the logged command, but for the noise) and
    so is the encoder (floor(phi / q) q)."""

    fixture: TrueBody
    """The fixture on the shaft (hub and mounting plate), body axes."""
    frame_inertia: float
    """I, kg m^2: the outer frame about the vertical."""
    friction: tuple[float, float, float]
    """(a1, a2, a3): N m, N m s, N m s^2; the same in both directions."""
    torque_noise: float
    """N m, std of the logged torque's noise."""
    release_angle_deg: float
    """deg, where a stage without release_angle_deg in device.toml releases the body."""
    observer_bandwidth: float = 100.0
    """rad/s, the drive's speed observer (rsp_inertia.virtual.drive.SpeedObserver)."""

    def gimbal(self, gear_ratio: float, body: TrueBody | None, gravity: float) -> Gimbal:
        """The engine's gimbal of one stage with ``body`` on it."""
        a1, a2, a3 = self.friction
        return Gimbal(
            gear_ratio, body, self.fixture, frame_inertia=self.frame_inertia, gravity=gravity,
            coulomb=a1, viscous=a2, quadratic=a3,
        )


def _log(t: np.ndarray, phi: np.ndarray, command: np.ndarray, quantum: float,
         noise: float, rng: np.random.Generator):
    """What the logger writes: encoder readings floor(phi / q) q and the command plus noise."""
    from rsp_inertia.plant.logs import Log
    from rsp_inertia.plant.transducers import encoder_reading

    return Log(
        t=t,
        phi=encoder_reading(phi, quantum),
        torque=command + rng.normal(0.0, noise, len(command)),
    )


def braking_pass(engine: GimbalEngine, stage, encoder, rig: EngineRig,
                 rng: np.random.Generator):
    """The braking pass on the engine (docs/method.md §4, docs/files.md Logs): released at
    the stage's release angle with its launch speed (forward), the motor applying the
    constant braking torque against the motion, until the speed first reaches zero.

    The engine runs ENGINE_STEPS steps per encoder sample; the stop is located inside its
    engine step by the speed's linear interpolation (the acceleration is constant to
    O(h) within 0.1 ms). The log holds every sample before the stop.

    Parameters
    ----------
    engine : GimbalEngine
        The stage's gimbal with the body on it.
    stage : rsp_inertia.plant.config.Stage
        The stage: launch speed, braking torque, release angle.
    encoder : rsp_inertia.plant.device_config.Encoder
        The encoder: its step and sample rate.
    rig : EngineRig
        The logger's noise, the default release angle.
    rng : numpy.random.Generator
        The log's noise.

    Returns
    -------
    log : rsp_inertia.plant.logs.Log
        braking.csv.
    rest : float
        rad, the true angle where the body stopped.
    """
    release = stage.release_angle_deg
    release = rig.release_angle_deg if release is None else release
    h = engine.gimbal.timestep
    steps = round(encoder.dt / h)
    command = -stage.braking_torque
    engine.release(math.radians(release), stage.launch_speed)
    phis = []
    rest = None
    while rest is None:
        phis.append(engine.phi)
        if len(phis) * encoder.dt > MAX_BRAKING_TIME:
            raise RuntimeError("the braking pass does not stop")
        for _ in range(steps):
            phi, W = engine.phi, engine.speed
            engine.step(command, 1)
            if engine.speed <= 0.0:
                tau = h * W / (W - engine.speed)
                rest = phi + W * tau / 2
                break
    n = len(phis)
    t = np.arange(n) * encoder.dt
    log = _log(t, np.array(phis), np.full(n, command), encoder.quantum, rig.torque_noise, rng)
    return log, rest


def reverse_pass(engine: GimbalEngine, device, program, rest: float, rig: EngineRig,
                 rng: np.random.Generator):
    """The reverse pass on the engine: ``program`` (program.csv) executed in closed loop by
    the virtual device's drive, from rest at ``rest``.

    At each sample the drive reads the encoder, updates its speed observer
    (rsp_inertia.virtual.drive.SpeedObserver) and computes the command
    (rsp_inertia.virtual.drive.ProgramDrive: feedforward plus feedback, torque and rate
    limits), which the motor holds over the sample while the engine runs ENGINE_STEPS steps.
    Before the program the motor holds the body at rest (the engine's holding torque), so
    the rate limiter starts there.

    Parameters
    ----------
    engine : GimbalEngine
        The stage's gimbal with the body on it.
    device : rsp_inertia.plant.config.Device
        The motor's limits and the encoder.
    program : rsp_inertia.plant.logs.Program
        The program.
    rest : float
        rad, the true angle where the braking stopped.
    rig : EngineRig
        The logger's noise and the observer's bandwidth.
    rng : numpy.random.Generator
        The log's noise.

    Returns
    -------
    rsp_inertia.plant.logs.Log
        reverse.csv, one row per program row.
    """
    from rsp_inertia.plant.transducers import encoder_reading
    from rsp_inertia.virtual.drive import ProgramDrive, SpeedObserver

    enc = device.encoder
    dt, q = enc.dt, enc.quantum
    steps = round(dt / engine.gimbal.timestep)
    held = engine.holding_torque(rest)
    engine.release(rest)
    observer = SpeedObserver(float(encoder_reading(rest, q)), 0.0, rig.observer_bandwidth, dt)
    drive = ProgramDrive(
        program, program.t, device.motor.torque_limit, device.motor.torque_rate_limit, None, held
    )
    n = len(program.t)
    phis = np.empty(n)
    commands = np.empty(n)
    for k in range(n):
        phis[k] = engine.phi
        y = float(encoder_reading(phis[k], q))
        commands[k] = drive.command(k, y, observer.update(y, dt), dt)
        engine.step(commands[k], steps)
    return _log(program.t, phis, commands, q, rig.torque_noise, rng)


# --- the calibrated route on engine-made logs -------------------------------------------------

BODY = TrueBody(
    mass=2.0,
    inertia=np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015]),
    com=np.array([0.003, -0.002, 0.0015]),
)
"""The body under test: the default experiment's (plant/defaults/virtual.toml)."""

REFERENCE = TrueBody(
    mass=3.0, inertia=np.array([0.03, 0.032, 0.02, 0.0, 0.0, 0.0]), com=np.zeros(3)
)
"""The reference body of the calibration (plant/defaults/rig/reference/reference.toml)."""

FIXTURE = TrueBody(
    mass=0.8,
    inertia=np.array([0.006, 0.0065, 0.008, 0.0002, -0.0001, 0.00015]),
    com=np.array([0.001, 0.0005, 0.0]),
)
"""The fixture on the shaft: the demo rig's unbalanced mounting plate
(plant/defaults/rig/virtual.toml) with a hub of 0.002 kg m^2 about every axis (the default
device's I1)."""

FRAME_INERTIA = 0.001
"""kg m^2, the outer frame about the vertical (the default device's I)."""

FRICTION = (1e-4, 1e-4, 1e-3)
"""The paper's friction a = [a1, a2, a3]."""

TORQUE_NOISE = 1e-4
"""N m, the logged torque's noise (the default virtual device's)."""

RELEASE_ANGLE_DEG = -30.0
"""deg, the release angle (the virtual device's default), jittered per seed."""

RELEASE_JITTER_DEG = 0.5
"""Each folder's release angle is drawn uniformly within this of RELEASE_ANGLE_DEG (seeded):
each experiment's encoder counts fall elsewhere, so its quantization errors are its own
(benchmarks.mountings does the same)."""

FOLDERS = (("empty", None), ("reference", REFERENCE), ("body", BODY))
"""The calibration folders and the experiment, each with the body it carries."""


def device_text(folder: str) -> str:
    """device.toml of one folder: the demo rig's (plant/defaults/rig/), forward runs only and
    no pendulum runs (the engine's rig is the same both ways round); every other table as
    it is (the reference folder's ``[mounting]``, which turns the reference)."""
    from importlib import resources

    import tomlkit

    parts = ("rig",) if folder == "body" else ("rig", folder)
    text = resources.files("rsp_inertia.plant").joinpath("defaults", *parts, "device.toml")
    doc = tomlkit.parse(text.read_text())
    doc.pop("pendulum", None)
    for stage in doc["stage"]:
        stage.pop("directions", None)
    return tomlkit.dumps(doc)


def run_folder(root, body: TrueBody | None, rig: EngineRig, seed: tuple) -> None:
    """One experiment folder written by the engine-made rig, as a real rig's: device.toml
    (and reference.toml with a reference body), each stage's braking.csv, program.csv by
    ``rsp-inertia program`` from it, and reverse.csv, the program executed on the engine.

    Parameters
    ----------
    root : pathlib.Path
        The folder (made).
    body : TrueBody or None
        What is on the fixture: None (empty), the reference body or the body under test.
    rig : EngineRig
        The rig.
    seed : tuple
        The folder's random streams (the logs' noise).
    """
    from rsp_inertia.api import program as make_program
    from rsp_inertia.plant.config import load_device, placed_reference
    from rsp_inertia.plant.logs import read_program, write_log

    name = "empty" if body is None else "reference" if body is REFERENCE else "body"
    root.mkdir(parents=True, exist_ok=True)
    (root / "device.toml").write_text(device_text(name))
    if body is REFERENCE:
        inertia = ", ".join(repr(float(v)) for v in body.inertia)
        (root / "reference.toml").write_text(
            f"[body]\nmass = {body.mass!r}\ninertia = [{inertia}]\ncom = [0.0, 0.0, 0.0]\n"
        )
    device = load_device(root / "device.toml")
    # The body as it sits on the rig: its folder's [mounting] places it (the demo rig's
    # reference is mounted turned), exactly as calibrate and identify place it.
    placed = None if body is None else placed_reference(body, device.mounting)
    rests = []
    engines = []
    for k, stage in enumerate(device.stages, start=1):
        engine = GimbalEngine(rig.gimbal(stage.gear_ratio, placed, device.gravity))
        log, rest = braking_pass(engine, stage, device.encoder, rig,
                                 np.random.default_rng([*seed, k, 0]))
        (root / f"stage{k}").mkdir(exist_ok=True)
        write_log(root / f"stage{k}" / "braking.csv", log)
        rests.append(rest)
        engines.append(engine)
    make_program(root)
    for k, (engine, rest) in enumerate(zip(engines, rests, strict=True), start=1):
        program = read_program(root / f"stage{k}" / "program.csv", device.encoder)
        log = reverse_pass(engine, device, program, rest, rig,
                           np.random.default_rng([*seed, k, 1]))
        write_log(root / f"stage{k}" / "reverse.csv", log)


def engine_rig(seed: int) -> EngineRig:
    """The benchmark's rig for one seed: its release angle jittered."""
    jitter = np.random.default_rng([seed, 99]).uniform(-1.0, 1.0) * RELEASE_JITTER_DEG
    return EngineRig(
        fixture=FIXTURE,
        frame_inertia=FRAME_INERTIA,
        friction=FRICTION,
        torque_noise=TORQUE_NOISE,
        release_angle_deg=RELEASE_ANGLE_DEG + jitter,
    )


def calibrated_route(work, seed: int) -> dict:
    """The calibrated route on engine-made logs: the empty-fixture and reference-body
    calibration folders and the body's, ``calibrate``, ``identify``.

    Parameters
    ----------
    work : pathlib.Path
        Where the three folders are made.
    seed : int
        The seed of the logs' noise and of the release angle.

    Returns
    -------
    dict
        ``entries``, ``entries_std`` (kg m^2, identify's), ``truth`` (the body's tensor
        entries), ``seconds`` (wall time).
    """
    import time

    from rsp_inertia.api import calibrate, identify

    start = time.perf_counter()
    rig = engine_rig(seed)
    roots = {}
    for index, (name, body) in enumerate(FOLDERS):
        roots[name] = work / name
        run_folder(roots[name], body, rig, (seed, index))
    calibration = calibrate(roots["body"], roots["empty"], roots["reference"])
    result = identify(roots["body"])
    return {
        "seed": seed,
        "conventions": calibration.conventions,
        "zero_deg": float(np.degrees(calibration.encoder_zero)),
        "zero_std_deg": float(np.degrees(calibration.encoder_zero_std)),
        "entries": np.asarray(result.entries).tolist(),
        "entries_std": np.asarray(result.entries_std).tolist(),
        "truth": BODY.inertia.tolist(),
        "com": np.asarray(result.com).tolist(),
        "com_std": np.asarray(result.com_std).tolist(),
        "com_truth": BODY.com[:2].tolist(),
        "seconds": time.perf_counter() - start,
    }


ENTRIES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")


def model_agreement() -> dict[str, float]:
    """The largest relative difference between the engine and the reduced model over the
    benchmark's body and fixture, the default stages' gear ratios and 12 angles: M(phi), and
    eps at a speed of 5 rad/s and a torque of 0.1 N m (friction off)."""
    from rsp_inertia.plant.model import (
        ModelParameters,
        acceleration,
        inertia_harmonics,
        reduced_inertia,
    )

    worst = {"M": 0.0, "eps": 0.0}
    g = 9.80665
    moment = BODY.mass * BODY.com + FIXTURE.mass * FIXTURE.com
    for lam in (0.0, 0.7639320225, 5.2360679775):
        engine = GimbalEngine(Gimbal(lam, BODY, FIXTURE, frame_inertia=FRAME_INERTIA, gravity=g))
        harmonics = inertia_harmonics(BODY.inertia, lam, lam**2 * FRAME_INERTIA)
        params = ModelParameters(
            harmonics + inertia_harmonics(FIXTURE.inertia, lam, 0.0),
            gravity_sin=g * moment[0], gravity_cos=g * moment[1],
        )
        for phi in np.linspace(0.0, 2 * np.pi, 12, endpoint=False):
            M = engine.reduced_inertia(phi)
            worst["M"] = max(worst["M"], abs(M / reduced_inertia(phi, params) - 1))
            eps = engine.acceleration(phi, 5.0, 0.1)
            worst["eps"] = max(worst["eps"], abs(eps / acceleration(phi, 5.0, 0.1, params) - 1))
    return worst


def report(rows: list[dict], agreement: dict[str, float], command: str) -> str:
    """The Markdown report (engine.md).

    Parameters
    ----------
    rows : list of dict
        One per seed, from :func:`calibrated_route`.
    agreement : dict of str to float
        From :func:`model_agreement`.
    command : str
        The command line that made them.

    Returns
    -------
    str
        The report's text.
    """
    from benchmarks.tables import table_lines

    err = np.array([np.subtract(r["entries"], r["truth"]) for r in rows])
    std = np.array([r["entries_std"] for r in rows])
    largest = max(rows[0]["truth"][:3])
    z = err / std
    lines = [
        "# The calibrated route on engine-made logs (MuJoCo)",
        "",
        f"Command: `{command}`",
        "",
        ("The reduced model against the engine (benchmarks.engine, the benchmark's body and "
         "fixture, gear ratios 0, 0.764, 5.236, 12 angles): largest relative difference "
         f"{agreement['M']:.1e} in M(phi), {agreement['eps']:.1e} in the acceleration."),
        "",
        ("Per seed: an empty-fixture folder, a reference-body folder and the body's, each "
         "stage's braking pass and its reverse (`rsp-inertia program` from the braking log, "
         "executed in closed loop on the engine by the virtual device's drive) made by MuJoCo "
         "(RK4, 10 steps per 1 kHz sample; friction a = [1e-4, 1e-4, 1e-3], torque noise "
         "1e-4 N m, 16-bit encoder, forward runs); then `calibrate` and `identify`. Errors of "
         "the body's tensor entries in its stds and relative to the largest moment "
         f"({largest} kg m^2)."),
        "",
        ("The engine's gimbal is built from physical frames as docs/method.md §1 states its "
         "conventions, and the calibration's reference is mounted turned (the demo rig's "
         "reference folder's `[mounting]`), so calibrate checks those conventions on it: "
         + "; ".join(
             f"seed {r['seed']}: encoder zero {r['zero_deg']:+.4f} +- {r['zero_std_deg']:.4f} "
             "deg (the engine's is 0), "
             + ("verified" if r["conventions"].startswith("conventions verified") else
                f"\"{r['conventions']}\"")
             for r in rows if "conventions" in r
         ) + "."),
        "",
        "## err / std",
        "",
    ]
    head = ["seed", *ENTRIES, "max abs", "seconds"]
    lines += table_lines(head, [
        [str(r["seed"]), *(f"{v:+.2f}" for v in zr), f"{np.abs(zr).max():.2f}",
         f"{r['seconds']:.0f}"]
        for r, zr in zip(rows, z, strict=True)
    ])
    lines += ["", "## err / largest moment", ""]
    lines += table_lines(["seed", *ENTRIES, "max abs"], [
        [str(r["seed"]), *(f"{v:+.1e}" for v in er / largest), f"{np.abs(er).max() / largest:.1e}"]
        for r, er in zip(rows, err, strict=True)
    ])
    com_z = np.array([np.subtract(r["com"], r["com_truth"]) / np.asarray(r["com_std"])
                      for r in rows])
    lines += ["", "## Centre of mass (x_c, y_c): err / std", ""]
    lines += table_lines(["seed", "x_c", "y_c"], [
        [str(r["seed"]), *(f"{v:+.2f}" for v in zc)] for r, zc in zip(rows, com_z, strict=True)
    ])
    within = bool(
        np.all(np.abs(z) <= 3) and np.all(np.abs(err) <= 1e-4 * largest)
        and np.all(np.abs(com_z) <= 3)
    )
    lines += [
        "",
        "## Summary",
        "",
        f"- mean (err/std)^2 over {z.size} entries: {np.mean(z**2):.2f} (target 0.5 to 2)",
        "- per entry: " + ", ".join(
            f"{name} {np.mean(z[:, k] ** 2):.2f}" for k, name in enumerate(ENTRIES)
        ),
        (f"- largest |err|/std: {np.abs(z).max():.2f}; largest |err| / largest moment: "
         f"{np.abs(err).max() / largest:.1e}"),
        f"- centre of mass: largest |err|/std {np.abs(com_z).max():.2f}",
        (f"- every entry within 3 stds and within 1e-4 of the largest moment, and the centre "
         f"of mass within 3 stds: {within}"),
        "",
    ]
    return "\n".join(lines)


def _seed(seed: int, work: str) -> dict:
    from pathlib import Path

    return calibrated_route(Path(work) / f"seed{seed}", seed)


def main(argv: list[str] | None = None) -> int:
    import argparse
    import json
    import tempfile
    from concurrent.futures import ProcessPoolExecutor
    from pathlib import Path

    from benchmarks import RESULTS
    from benchmarks.tables import command_line

    parser = argparse.ArgumentParser(prog="python -m benchmarks.engine")
    parser.add_argument("--seeds", type=int, default=5, help="seeds (5)")
    parser.add_argument("--jobs", type=int, default=5, help="processes (5)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    with (
        tempfile.TemporaryDirectory(prefix="rsp-engine-") as work,
        ProcessPoolExecutor(args.jobs) as pool,
    ):
        rows = list(pool.map(_seed, range(args.seeds), [work] * args.seeds))
    text = report(rows, model_agreement(), command_line("engine", argv))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "engine.md").write_text(text)
    (args.out / "engine.json").write_text(json.dumps({"rows": rows}, indent=2) + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
