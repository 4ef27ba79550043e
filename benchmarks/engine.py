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
