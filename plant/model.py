"""The reduced one-degree-of-freedom gimbal model (docs/method.md §2-3), built once in CasADi.

Every equation of the model lives here exactly once, as a CasADi ``SX`` expression in the
generalised coordinate phi, the speed Omega = dphi/dt, the motor torque u and a parameter
vector p. The simulator, the optimal-control problem and the estimators all use these
expressions (symbolically through :data:`MODEL`, numerically through the functions below,
e.g. the least squares' rows :func:`tensor_basis` and :func:`gravity_basis`, and one RK4
step builder :func:`rk4_step`), so nobody restates the physics.

Parameter vector p (12 entries, :data:`PARAMETER_NAMES`), all reduced to phi:

====  ==========  ========  =========================================================
 i    name        unit      meaning
====  ==========  ========  =========================================================
 0    M0          kg m^2    constant part of M(phi) (tare included)
 1    Mc2         kg m^2    coefficient of cos 2phi in M(phi)
 2    Ms2         kg m^2    coefficient of sin 2phi
 3    Ms1         kg m^2    coefficient of sin phi
 4    Mc1         kg m^2    coefficient of cos phi
 5    c           N m/rad   torsion stiffness
 6    phi0        rad       zero angle of the spring
 7    Gs          N m       m g x_c (gravity, sine part of the potential)
 8    Gc          N m       m g y_c (gravity, cosine part)
 9    a1          N m       Coulomb friction
 10   a2          N m s     viscous friction
 11   a3          N m s^2   quadratic friction
====  ==========  ========  =========================================================
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.geometry import GRAVITY_NAMES, HARMONIC_NAMES

__all__ = [
    "MODEL",
    "PARAMETER_NAMES",
    "GimbalModel",
    "ModelParameters",
    "acceleration",
    "dissipation",
    "dissipation_regressor",
    "energy_regressor",
    "force_curvature_regressor",
    "force_regressor",
    "gravity_basis",
    "gravity_basis_slope",
    "harmonics_matrix",
    "inertia_basis",
    "inertia_basis_slope",
    "inertia_harmonics",
    "mechanical_energy",
    "momentum_regressor",
    "motor_torque",
    "potential",
    "reduced_inertia",
    "reduced_inertia_slope",
    "rk4_step",
    "spring_parameters",
    "static_torque",
    "tensor_basis",
    "tensor_basis_slope",
]



PARAMETER_NAMES = (*HARMONIC_NAMES, "c", "phi0", *GRAVITY_NAMES, *FRICTION.names)


def inertia_harmonics(inertia: np.ndarray, gear_ratio: float, tare_inertia: float) -> np.ndarray:
    """Harmonic coefficients of the reduced inertia M(phi) of one stage (docs/method.md §2).

    ``(1+lam^2) J_e(phi) = Jz + lam^2 (Jx+Jy)/2 + lam^2 (Jy-Jx)/2 cos 2phi + lam^2 Jxy sin 2phi
    + 2 lam Jxz sin phi + 2 lam Jyz cos phi`` and ``M = (1+lam^2) J_e + M_tare``.

    Parameters
    ----------
    inertia : array_like, shape (6,)
        Body tensor entries [Jx, Jy, Jz, Jxy, Jyz, Jxz] in kg m^2 (products as tensor entries).
    gear_ratio : float
        lam = tan(beta) of the stage.
    tare_inertia : float
        M_tare(lam) in kg m^2, reduced to phi.

    Returns
    -------
    numpy.ndarray, shape (5,)
        [M0, Mc2, Ms2, Ms1, Mc1] in kg m^2.
    """
    jx, jy, jz, jxy, jyz, jxz = np.asarray(inertia, dtype=float)
    lam = float(gear_ratio)
    lam2 = lam * lam
    return np.array(
        [
            jz + lam2 * (jx + jy) / 2 + tare_inertia,
            lam2 * (jy - jx) / 2,
            lam2 * jxy,
            2 * lam * jxz,
            2 * lam * jyz,
        ]
    )


def harmonics_matrix(gear_ratio: float) -> np.ndarray:
    """(5, 6) d[M0, Mc2, Ms2, Ms1, Mc1] / d[Jx, Jy, Jz, Jxy, Jyz, Jxz] of one stage.

    The harmonics are linear in the body's tensor: :func:`inertia_harmonics` (J, lam, M_tare)
    is this matrix times J, plus M_tare in M0. Its columns are :func:`inertia_harmonics` of
    the unit tensors, so the two agree exactly.
    """
    return np.column_stack([inertia_harmonics(e, gear_ratio, 0.0) for e in np.eye(6)])


@dataclass(frozen=True)
class ModelParameters:
    """Numerical values of the reduced model of one stage (the vector p of this module)."""

    inertia_harmonics: np.ndarray
    """[M0, Mc2, Ms2, Ms1, Mc1], kg m^2: M(phi) in harmonic form, tare included."""
    stiffness: float = 0.0
    """c, N m/rad: torsion stiffness reduced to phi."""
    zero_angle: float = 0.0
    """phi0, rad: angle where the spring is relaxed."""
    gravity_sin: float = 0.0
    """Gs = m g x_c, N m."""
    gravity_cos: float = 0.0
    """Gc = m g y_c, N m."""
    coulomb: float = 0.0
    """a1, N m."""
    viscous: float = 0.0
    """a2, N m s."""
    quadratic: float = 0.0
    """a3, N m s^2."""
    vector: np.ndarray = field(init=False, repr=False, compare=False)
    """The 12-vector p in the order of PARAMETER_NAMES."""

    def __post_init__(self) -> None:
        harmonics = np.array(self.inertia_harmonics, dtype=float).reshape(5)
        harmonics.flags.writeable = False
        object.__setattr__(self, "inertia_harmonics", harmonics)
        vector = np.concatenate(
            [
                harmonics,
                [
                    self.stiffness,
                    self.zero_angle,
                    self.gravity_sin,
                    self.gravity_cos,
                    *FRICTION.coefficients(self),
                ],
            ]
        ).astype(float)
        vector.flags.writeable = False
        object.__setattr__(self, "vector", vector)



def spring_parameters(stiffness: float, zero_angle: float) -> ModelParameters:
    """A model with only the spring (c, phi0) non-zero: its potential is the spring's part of
    Pi, its inverse dynamics and energy the spring's terms (used where the rest is unknown)."""
    return ModelParameters(inertia_harmonics=np.zeros(5), stiffness=stiffness, zero_angle=zero_angle)


class GimbalModel:
    """Symbolic reduced model (docs/method.md §2-3): one set of CasADi expressions.

    Attributes
    ----------
    phi, Omega, u, direction : casadi.SX
        Scalar symbols: angle (rad), speed (rad/s), motor torque (N m), and the sign of the
        motion used by the Coulomb and quadratic friction terms (+1 or -1).
    p : casadi.SX, shape (12,)
        Parameter vector (module docstring).
    M, dM : casadi.SX
        Reduced inertia M(phi) and its derivative dM/dphi.
    Pi : casadi.SX
        Potential energy c/2 (phi-phi0)^2 + m g (x_c sin phi + y_c cos phi).
    S : casadi.SX
        Static torque dPi/dphi = c (phi-phi0) + m g (x_c cos phi - y_c sin phi).
    D : casadi.SX
        Dissipative torque (rsp_inertia.plant.friction.FRICTION): (a1 + a3 Omega^2) direction
        + a2 Omega.
    acc : casadi.SX
        Scalar symbol for an acceleration eps (rad/s^2), input of the inverse dynamics.
    tau : casadi.SX
        Inverse dynamics: the motor torque M acc + 1/2 M' Omega^2 + D + S that produces
        the acceleration ``acc`` (Lagrange's equation, docs/method.md §3).
    eps : casadi.SX
        Forward dynamics: the acceleration that torque u produces (the same equation solved).
    E : casadi.SX
        Mechanical energy M Omega^2 / 2 + Pi.
    F : casadi.SX
        Generalised force of the momentum form of Lagrange's equation,
        d(M Omega)/dt = u + F, F = 1/2 M' Omega^2 - D - S (docs/method.md §3).
    """

    def __init__(self) -> None:
        self.phi = ca.SX.sym("phi")
        self.Omega = ca.SX.sym("Omega")
        self.u = ca.SX.sym("u")
        self.direction = ca.SX.sym("direction")
        self.p = ca.SX.sym("p", len(PARAMETER_NAMES))
        m0, mc2, ms2, ms1, mc1, c, phi0, gs, gc, *friction = ca.vertsplit(self.p)
        phi, Omega = self.phi, self.Omega

        # docs/method.md §2, harmonic form of M(phi).
        self.M = (
            m0 + mc2 * ca.cos(2 * phi) + ms2 * ca.sin(2 * phi) + ms1 * ca.sin(phi) + mc1 * ca.cos(phi)
        )
        self.dM = ca.jacobian(self.M, phi)
        # docs/method.md §3, spring and gravity potential; the static torque is its gradient.
        self.Pi = c / 2 * (phi - phi0) ** 2 + gs * ca.sin(phi) + gc * ca.cos(phi)
        self.S = ca.jacobian(self.Pi, phi)
        # docs/method.md §3, the paper's dissipation model with sign(Omega) made an explicit input
        # so that an integrator can hold it fixed between stops (no chattering at Omega = 0).
        self.D = FRICTION.torque(Omega, self.direction, friction)
        # docs/method.md §3, Lagrange's equation, written once as the torque a motor must apply for
        # a given acceleration (inverse dynamics); the forward dynamics solve the same line.
        self.acc = ca.SX.sym("eps")
        self.tau = self.M * self.acc + self.dM * Omega**2 / 2 + self.D + self.S
        residual = self.tau - self.u
        self.eps = -ca.substitute(residual, self.acc, 0) / ca.jacobian(residual, self.acc)
        self.E = self.M * Omega**2 / 2 + self.Pi
        # The same equation in momentum form: d(M Omega)/dt = M eps + M' Omega^2 = u + F.
        self.F = self.dM * Omega**2 / 2 - self.D - self.S

        self.functions = {
            "reduced_inertia": ca.Function("reduced_inertia", [phi, self.p], [self.M]),
            "reduced_inertia_slope": ca.Function("reduced_inertia_slope", [phi, self.p], [self.dM]),
            # M is linear in its harmonic coefficients p[0:5]: dM/dp[0:5] is their basis.
            "inertia_basis": ca.Function(
                "inertia_basis", [phi, self.p], [ca.jacobian(self.M, self.p)[:, :5]]
            ),
            # Their angle slopes d/dphi: how the balance moves when the angle's zero does
            # (an encoder's zero offset, rsp_inertia.estimation.columns.zero_columns).
            "inertia_basis_slope": ca.Function(
                "inertia_basis_slope", [phi, self.p], [ca.jacobian(self.dM, self.p)[:, :5]]
            ),
            "potential": ca.Function("potential", [phi, self.p], [self.Pi]),
            # Pi is linear in the gravity terms p[7:9]: dPi/d[Gs, Gc] is their basis.
            "gravity_basis": ca.Function(
                "gravity_basis", [phi, self.p], [ca.jacobian(self.Pi, self.p)[:, 7:9]]
            ),
            "gravity_basis_slope": ca.Function(
                "gravity_basis_slope", [phi, self.p], [ca.jacobian(self.S, self.p)[:, 7:9]]
            ),
            "static_torque": ca.Function("static_torque", [phi, self.p], [self.S]),
            "dissipation": ca.Function(
                "dissipation", [Omega, self.direction, self.p], [self.D]
            ),
            "acceleration": ca.Function(
                "acceleration", [phi, Omega, self.u, self.direction, self.p], [self.eps]
            ),
            "mechanical_energy": ca.Function("mechanical_energy", [phi, Omega, self.p], [self.E]),
            "motor_torque": ca.Function(
                "motor_torque", [phi, Omega, self.acc, self.direction, self.p], [self.tau]
            ),
            # The mechanical energy (but for the spring's part) and the dissipative torque are
            # linear in p: their Jacobians in p are the regressors of the energy balance
            # E_b - E_a + integral of D dphi = motor work (docs/method.md §3).
            "energy_regressor": ca.Function(
                "energy_regressor", [phi, Omega, self.p], [ca.jacobian(self.E, self.p)]
            ),
            "dissipation_regressor": ca.Function(
                "dissipation_regressor",
                [Omega, self.direction, self.p],
                [ca.jacobian(self.D, self.p)],
            ),
            # The momentum form d(M Omega)/dt = u + F is linear in p too (but for the
            # spring's part of F): the regressors of its modulated integral
            # (rsp_inertia.estimation.modulated).
            "momentum_regressor": ca.Function(
                "momentum_regressor", [phi, Omega, self.p], [ca.jacobian(self.M * Omega, self.p)]
            ),
            "force_regressor": ca.Function(
                "force_regressor",
                [phi, Omega, self.direction, self.p],
                [ca.jacobian(self.F, self.p)],
            ),
            # d^2 F / d Omega^2 per parameter: the mean a speed error of variance var adds to
            # F is var / 2 times it (to second order; exactly for the paper's friction, with
            # which F is quadratic in Omega and this does not depend on Omega).
            "force_curvature_regressor": ca.Function(
                "force_curvature_regressor",
                [phi, Omega, self.direction, self.p],
                [ca.jacobian(ca.hessian(self.F, Omega)[0], self.p)],
            ),
        }

    def state_derivative(self) -> ca.Function:
        """``f(x, u, direction, p) -> dx/dt`` with x = (phi, Omega): the equation of motion."""
        x = ca.vertcat(self.phi, self.Omega)
        return ca.Function(
            "state_derivative", [x, self.u, self.direction, self.p], [ca.vertcat(self.Omega, self.eps)]
        )


MODEL = GimbalModel()
"""The one symbolic model instance every package uses."""


def rk4_step(
    derivative: Callable[[ca.SX], ca.SX], x: ca.SX, h: ca.SX | float, substeps: int = 1
) -> ca.SX:
    """x advanced by h: ``substeps`` classical fourth-order Runge-Kutta steps of h / substeps.

    The simulator (rsp_inertia.virtual.device) and the optimal-control problem
    (rsp_inertia.ocp.feedforward) make the result into their step functions.

    Parameters
    ----------
    derivative : callable
        ``derivative(x)`` is dx/dt as a CasADi expression of the state (the model's equation
        of motion with its inputs held over the step, :meth:`GimbalModel.state_derivative`).
    x : casadi.SX
        The state at the start of the step.
    h : casadi.SX or float
        s, the step length.
    substeps : int, optional
        How many RK4 steps of h / substeps.

    Returns
    -------
    casadi.SX
        The state after h, an expression in x and h.
    """
    dt = h / substeps
    for _ in range(substeps):
        k1 = derivative(x)
        k2 = derivative(x + dt / 2 * k1)
        k3 = derivative(x + dt / 2 * k2)
        k4 = derivative(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def _evaluate(name: str, args: tuple, p: np.ndarray) -> np.ndarray | float:
    """Evaluate a model function element-wise on broadcast numpy arrays."""
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    shape = arrays[0].shape
    rows = [a.reshape(1, -1) for a in arrays]
    if rows[0].shape[1] == 0:
        return np.zeros(shape)
    out = np.asarray(MODEL.functions[name](*rows, np.asarray(p, dtype=float))).reshape(shape)
    return float(out) if out.ndim == 0 else out


def _p(params: ModelParameters | np.ndarray) -> np.ndarray:
    return params.vector if isinstance(params, ModelParameters) else np.asarray(params, float)


def reduced_inertia(phi, params: ModelParameters | np.ndarray):
    """M(phi), kg m^2 (docs/method.md §2), element-wise over ``phi`` (rad)."""
    return _evaluate("reduced_inertia", (phi,), _p(params))


def inertia_basis(phi) -> np.ndarray:
    """dM/d[M0, Mc2, Ms2, Ms1, Mc1] at each angle, shape phi.shape + (5,) (docs/method.md §2).

    M(phi) = inertia_basis(phi) @ harmonics: the functions 1, cos 2phi, sin 2phi, sin phi,
    cos phi of the harmonic form, taken from the model's own M.
    """
    phi = np.asarray(phi, dtype=float)
    row = phi.reshape(1, -1)
    out = np.asarray(MODEL.functions["inertia_basis"](row, np.zeros(len(PARAMETER_NAMES))))
    return out.reshape(phi.shape + (5,))


def tensor_basis(phi, gear_ratio: float) -> np.ndarray:
    """dM/d[Jx, Jy, Jz, Jxy, Jyz, Jxz] of one stage at each angle, shape phi.shape + (6,).

    M(phi) - M_tare = tensor_basis(phi, lam) @ J = (1 + lam^2) J_e(phi) (docs/method.md §2): the
    rows v(phi) of the least squares over the tensor's entries (docs/method.md §5), the model's
    basis (:func:`inertia_basis`) times :func:`harmonics_matrix`.
    """
    return inertia_basis(phi) @ harmonics_matrix(gear_ratio)


def gravity_basis(phi) -> np.ndarray:
    """dPi/d[Gs, Gc] at each angle, shape phi.shape + (2,) (docs/method.md §3): the functions
    sin phi, cos phi of the gravity potential, taken from the model's own Pi."""
    phi = np.asarray(phi, dtype=float)
    row = phi.reshape(1, -1)
    out = np.asarray(MODEL.functions["gravity_basis"](row, np.zeros(len(PARAMETER_NAMES))))
    return out.reshape(phi.shape + (2,))


def inertia_basis_slope(phi) -> np.ndarray:
    """d/dphi of :func:`inertia_basis`, shape phi.shape + (5,): dM'/d[M0, Mc2, Ms2, Ms1, Mc1],
    the functions 0, -2 sin 2phi, 2 cos 2phi, cos phi, -sin phi, from the model's own M'."""
    return _basis("inertia_basis_slope", phi, 5)


def tensor_basis_slope(phi, gear_ratio: float) -> np.ndarray:
    """d/dphi of :func:`tensor_basis`, shape phi.shape + (6,)."""
    return inertia_basis_slope(phi) @ harmonics_matrix(gear_ratio)


def gravity_basis_slope(phi) -> np.ndarray:
    """d/dphi of :func:`gravity_basis`, shape phi.shape + (2,): cos phi, -sin phi, from the
    model's own static torque."""
    return _basis("gravity_basis_slope", phi, 2)


def _basis(name: str, phi, width: int) -> np.ndarray:
    """The model's function ``name`` of phi alone (a basis), element-wise, phi.shape + (width,)."""
    phi = np.asarray(phi, dtype=float)
    row = phi.reshape(1, -1)
    out = np.asarray(MODEL.functions[name](row, np.zeros(len(PARAMETER_NAMES))))
    return out.reshape(phi.shape + (width,))


def reduced_inertia_slope(phi, params: ModelParameters | np.ndarray):
    """dM/dphi, kg m^2/rad (docs/method.md §3), element-wise over ``phi`` (rad)."""
    return _evaluate("reduced_inertia_slope", (phi,), _p(params))


def potential(phi, params: ModelParameters | np.ndarray):
    """Pi(phi), J: spring plus gravity potential (docs/method.md §3)."""
    return _evaluate("potential", (phi,), _p(params))


def static_torque(phi, params: ModelParameters | np.ndarray):
    """dPi/dphi, N m: the torque a motor must apply to hold the body still at phi."""
    return _evaluate("static_torque", (phi,), _p(params))


def dissipation(Omega, params: ModelParameters | np.ndarray, direction=None):
    """D(Omega), N m (docs/method.md §3).

    Parameters
    ----------
    Omega : array_like
        rad/s, the speed.
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).
    direction : array_like, optional
        The sign used by the Coulomb and quadratic friction; defaults to sign(Omega).

    Returns
    -------
    float or numpy.ndarray
        N m, element-wise over the broadcast inputs.
    """
    if direction is None:
        direction = np.sign(Omega)
    return _evaluate("dissipation", (Omega, direction), _p(params))


def acceleration(phi, Omega, u, params: ModelParameters | np.ndarray, direction=None):
    """eps = dOmega/dt, rad/s^2, from Lagrange's equation (docs/method.md §3).

    Parameters
    ----------
    phi : array_like
        rad, the angle.
    Omega : array_like
        rad/s, the speed.
    u : array_like
        N m, the motor torque.
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).
    direction : array_like, optional
        The sign used by the Coulomb and quadratic friction; defaults to sign(Omega); pass
        it explicitly at rest.

    Returns
    -------
    float or numpy.ndarray
        rad/s^2, element-wise over the broadcast inputs.
    """
    if direction is None:
        direction = np.sign(Omega)
    return _evaluate("acceleration", (phi, Omega, u, direction), _p(params))


def motor_torque(phi, Omega, eps, params: ModelParameters | np.ndarray, direction=None):
    """Inverse dynamics: the motor torque u, N m, that gives acceleration ``eps`` (docs/method.md §3).

    Parameters
    ----------
    phi : array_like
        rad, the angle.
    Omega : array_like
        rad/s, the speed.
    eps : array_like
        rad/s^2, the acceleration.
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).
    direction : array_like, optional
        Sign used by the Coulomb and quadratic friction; defaults to sign(Omega).

    Returns
    -------
    float or numpy.ndarray
        N m, element-wise over the broadcast inputs.
    """
    if direction is None:
        direction = np.sign(Omega)
    return _evaluate("motor_torque", (phi, Omega, eps, direction), _p(params))


def _regressor(name: str, args: tuple, p: np.ndarray) -> np.ndarray:
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    rows = [a.reshape(1, -1) for a in arrays]
    out = np.asarray(MODEL.functions[name](*rows, p))  # (1, 12 n)
    return out.reshape(arrays[0].shape + (len(PARAMETER_NAMES),))


def energy_regressor(phi, Omega, params: ModelParameters | np.ndarray):
    """dE/dp at each sample, rows of shape (12,): E = regressor . p up to the spring's term.

    Parameters
    ----------
    phi : array_like
        rad, the angles.
    Omega : array_like
        rad/s, the speeds.
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).

    Returns
    -------
    numpy.ndarray
        Shape of the broadcast inputs + (12,).
    """
    return _regressor("energy_regressor", (phi, Omega), _p(params))


def dissipation_regressor(Omega, params: ModelParameters | np.ndarray, direction=None):
    """dD/dp at each sample, rows of shape (12,): D = regressor . p exactly.

    Parameters
    ----------
    Omega : array_like
        rad/s, the speeds.
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).
    direction : array_like, optional
        The sign of the Coulomb and quadratic friction; defaults to sign(Omega).

    Returns
    -------
    numpy.ndarray
        Shape of the broadcast inputs + (12,).
    """
    if direction is None:
        direction = np.sign(Omega)
    return _regressor("dissipation_regressor", (Omega, direction), _p(params))


def momentum_regressor(phi, Omega, params: ModelParameters | np.ndarray):
    """d(M Omega)/dp at each sample, rows of shape (12,): M(phi) Omega = regressor . p
    exactly (docs/method.md §3, the momentum form).

    Parameters
    ----------
    phi : array_like
        rad, the angles.
    Omega : array_like
        rad/s, the speeds.
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).

    Returns
    -------
    numpy.ndarray
        Shape of the broadcast inputs + (12,).
    """
    return _regressor("momentum_regressor", (phi, Omega), _p(params))


def force_regressor(phi, Omega, params: ModelParameters | np.ndarray, direction=None):
    """dF/dp at each sample, rows of shape (12,), F = 1/2 M' Omega^2 - D - S the generalised
    force of the momentum form d(M Omega)/dt = u + F (docs/method.md §3): F = regressor . p
    up to the spring's part of S, which is not linear in (c, phi0).

    Parameters
    ----------
    phi : array_like
        rad, the angles.
    Omega : array_like
        rad/s, the speeds.
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).
    direction : array_like, optional
        The sign of the Coulomb and quadratic friction; defaults to sign(Omega).

    Returns
    -------
    numpy.ndarray
        Shape of the broadcast inputs + (12,).
    """
    if direction is None:
        direction = np.sign(Omega)
    return _regressor("force_regressor", (phi, Omega, direction), _p(params))


def force_curvature_regressor(phi, Omega, params: ModelParameters | np.ndarray, direction=1.0):
    """d^3 F / dOmega^2 dp at each sample, rows of shape (12,): a speed error e of variance var
    moves F's mean by var / 2 times regressor . p (E[F(Omega + e)] = F(Omega) + F'' var / 2,
    exact while F is quadratic in Omega, as with the paper's friction).

    Parameters
    ----------
    phi : array_like
        rad, the angles.
    Omega : array_like
        rad/s, the speeds (F'' depends on them unless the friction law is quadratic).
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).
    direction : array_like, optional
        The sign of the motion (+1.0 by default).

    Returns
    -------
    numpy.ndarray
        Shape of the broadcast inputs + (12,).
    """
    return _regressor("force_curvature_regressor", (phi, Omega, direction), _p(params))


def mechanical_energy(phi, Omega, params: ModelParameters | np.ndarray):
    """E = M(phi) Omega^2 / 2 + Pi(phi), J (docs/method.md §3).

    Parameters
    ----------
    phi : array_like
        rad, the angle.
    Omega : array_like
        rad/s, the speed.
    params : ModelParameters or numpy.ndarray
        The model's parameters (or the vector p).

    Returns
    -------
    float or numpy.ndarray
        J, element-wise over the broadcast inputs.
    """
    return _evaluate("mechanical_energy", (phi, Omega), _p(params))
