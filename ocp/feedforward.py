"""The reverse pass's feedforward torque: an optimal-control problem in CasADi (docs/method.md §4).

States x = (phi, Omega, u): the body's angle and speed and the motor torque, which is a state
so that its rate v = du/dt can be bounded (the motor's torque-rate limit). On a grid of step
h (a multiple of the encoder's sample period), with v constant over each interval:

    minimise   sum_k h [ (Omega_k - Omega'_k)^2 + W_PHI^2 (phi_k - phi'_k)^2 ] + RHO sum_k h v_k^2
    subject to x_{k+1} = F(x_k, v_k)                (RK4 of the nominal model, rsp_inertia.plant.model)
               x_0 = (phi7, 0, S(phi7))             (at rest where the braking stopped, held)
               |u_k| <= torque_limit,  |v_k| <= torque_rate_limit

with (phi', Omega') the mirror of the braking (rsp_inertia.ocp.reference). The model is the nominal one
fitted to the braking log (rsp_inertia.ocp.nominal), in the reverse direction (Omega < 0, friction
opposing). Solved by IPOPT through ``nlpsol``, warm-started from the nominal inverse dynamics
along the mirror.

Derivatives. The constraints are N copies of one RK4 step, each touching only its own
interval's (x_k, v_k, x_{k+1}); the cost is a sum of squares. So the constraint Jacobian and
the Lagrangian's Hessian are assembled from per-interval blocks: the step's 3x4 Jacobian and
the 4x4 Hessian of lam_k . F(x_k, v_k), both SX functions (built once per step length h and
cached) mapped over the N intervals, plus the cost's own constant Hessian. The same numbers
as CasADi's automatic MX derivatives of the whole NLP (to rounding; tests/ocp/
test_feedforward_derivatives.py), at less than half the time: those colour the NLP's sparsity
and sweep the mapped step several times per evaluation, while an expanded SX graph of the
whole NLP takes seconds to differentiate.

Before the OCP, the mirror's torque is checked against the motor (:func:`check_mirror`):
subtracting the braking's equation of motion from the reverse's at the same angle, inertia,
spring and gravity cancel and friction doubles, so the mirror needs u' = u_b + 2 D(Omega')
(:func:`mirror_torque`), from the braking's mean logged torque (a two-level braking's:
each level's, on its side of the switch) and the nominal friction
alone, with the friction fit's uncertainty; no acceleration enters, whose encoder noise on a
coarse encoder had made the nominal inverse dynamics (:func:`required_torque`) ask for twice
the torque a feasible mirror needs. If it needs more than ``torque_limit`` beyond two of its
stds, the mirror is impossible and nothing is written; within 80% of the limit
(THIN_MARGIN), the program is made and a warning says how little is left for the regulator.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.ndimage import uniform_filter1d

from rsp_inertia.infra.errors import InputError
from rsp_inertia.ocp.reference import Mirror
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.model import (
    MODEL,
    PARAMETER_NAMES,
    ModelParameters,
    dissipation,
    dissipation_regressor,
    motor_torque,
    rk4_step,
    static_torque,
)

__all__ = [
    "GRID_STEP",
    "REFUSE_STDS",
    "RHO",
    "THIN_MARGIN",
    "W_PHI",
    "OcpSolution",
    "check_mirror",
    "mirror_torque",
    "required_torque",
    "solve_program_ocp",
]

W_PHI = 2.0
"""1/s: weight of the angle error against the speed error (an angle error of 1 rad costs
as much as a speed error of 2 rad/s)."""

RHO = 1e-4
"""s^2 ... weight of the torque rate (N m/s)^2 against speed errors (rad/s)^2: a smoothness
term small enough not to bend the tracking (a 1 N m/s rate costs as a 0.01 rad/s error)."""

GRID_STEP = 0.02
"""s, the OCP's interval (rounded to whole encoder samples): 50 intervals per second resolve
the torque's variation within a turn (at 12 rad/s a turn lasts ~0.5 s)."""

FEASIBILITY_WINDOW = 0.1
"""s over which the needed torque rate is averaged before it is compared with the motor's
limit: the mirror's speed carries the encoder's noise through the smoother, whose derivative
is not a rate the motor must deliver; 100 ms still follows the fastest physical change, the
2 Omega harmonic of stage 1 (period 0.26 s at 12 rad/s, kept to 77%)."""

THIN_MARGIN = 0.8
"""Fraction of the motor's torque and rate limits above which the mirror's need (plus two of
its stds) leaves the regulator too little: ``program`` still programs, and says so."""

REFUSE_STDS = 2.0
"""The mirror is refused only when its need minus this many stds exceeds the motor's limit."""

_DIRECTION = -1.0
"""The reverse pass runs backwards: friction's sign term is that of a negative speed."""


@dataclass(frozen=True)
class OcpSolution:
    """The optimal torque on the OCP grid, and how the solve went."""

    t: np.ndarray
    """s, OCP grid from 0."""
    phi: np.ndarray
    """rad, the nominal model's angle under the optimal torque."""
    omega: np.ndarray
    """rad/s."""
    torque: np.ndarray
    """N m, u at the grid points (linear in between)."""
    iterations: int
    """IPOPT iterations."""
    success: bool
    """IPOPT's verdict."""
    solve_time: float
    """s, build plus solve."""


def required_torque(mirror: Mirror, nominal: ModelParameters) -> np.ndarray:
    """Motor torque that the nominal model needs to follow the mirror exactly (inverse dynamics)."""
    return motor_torque(
        mirror.phi, mirror.omega, mirror.eps, nominal, direction=np.full(mirror.t.size, _DIRECTION)
    )


def mirror_torque(
    mirror: Mirror,
    nominal: ModelParameters,
    braking_torque: float | np.ndarray,
    friction_cov: np.ndarray | None = None,
    braking_torque_var: float | np.ndarray = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The torque the mirror needs, N m, at its samples, and its standard deviation.

    u' = u_b + 2 D(Omega') (module docstring; docs/method.md §4), u_b the braking's applied
    torque, D the nominal dissipation (rsp_inertia.plant.model.dissipation) at the mirror's
    speed. The std carries the friction slopes' covariance and the mean torque's variance.
    Coulomb friction a1 is not in it: a braking pass cannot tell it from the braking
    torque, so the nominal model puts it to 0 and its friction slopes come out scaled by
    u_b / (u_b + a1) (rsp_inertia.ocp.nominal), which leaves the need short by
    2 a1 (1 + D / (u_b + a1)) ~ a1 (u' + u_b) / u_b: 7.5e-3 N m (1.7%) at 15 rad/s on the default
    stage 1, whose braking torque is 0.005 N m (:func:`check_mirror` says so).

    Parameters
    ----------
    mirror : Mirror
        The reverse pass's reference (its speed Omega').
    nominal : ModelParameters
        The nominal model (its dissipation D).
    braking_torque : float or numpy.ndarray
        u_b, N m, the braking's applied torque (its log's mean); or one per mirror sample,
        the braking's at the same angle (a two-level braking: each level's mean).
    friction_cov : numpy.ndarray, shape (2, 2), optional
        The covariance of the friction slopes [a2, a3]
        (rsp_inertia.ocp.nominal.fit_nominal_with_covariance); none: not in the std.
    braking_torque_var : float or numpy.ndarray, optional
        (N m)^2, the variance of the mean braking torque (per mirror sample, as
        ``braking_torque``).

    Returns
    -------
    need : numpy.ndarray
        N m, u' at the mirror's samples.
    std : numpy.ndarray
        N m, its standard deviation.
    """
    omega = mirror.omega
    need = braking_torque + 2 * dissipation(omega, nominal)
    var = np.broadcast_to(np.asarray(braking_torque_var, dtype=float), omega.shape).copy()
    if friction_cov is not None:
        slopes = [PARAMETER_NAMES.index(name) for name in FRICTION.sloped]
        g = 2 * dissipation_regressor(omega, nominal)[:, slopes]
        var = var + np.einsum("ij,jk,ik->i", g, friction_cov, g)
    return need, np.sqrt(np.maximum(var, 0.0))


def check_mirror(
    device: Device,
    stage: int,
    mirror: Mirror,
    need: np.ndarray,
    std: np.ndarray,
    braking_torque: float | np.ndarray | None = None,
) -> list[str]:
    """The mirror's need against the motor's limits (module docstring).

    Parameters
    ----------
    device : Device
        The gimbal: its motor's ``torque_limit`` and ``torque_rate_limit``.
    stage : int
        The stage number, from 1 (for messages).
    mirror : Mirror
        The reverse pass's reference (its time grid).
    need, std : numpy.ndarray
        N m, the mirror's torque and its standard deviation (:func:`mirror_torque`).
    braking_torque : float or numpy.ndarray, optional
        u_b, N m (one per mirror sample for a two-level braking). Given, the messages say how
        much Coulomb friction a1, which a braking cannot see, adds to the need: a1 times
        (|u'| + |u_b|) / |u_b| (:func:`mirror_torque`).

    Returns
    -------
    list of str
        The warnings of a thin margin (empty when there is room).

    Raises
    ------
    InputError
        When the need exceeds ``torque_limit`` beyond REFUSE_STDS of its stds, with the need,
        its std and when.
    """
    motor = device.motor
    low = np.abs(need) - REFUSE_STDS * std
    high = np.abs(need) + REFUSE_STDS * std

    def coulomb(k: int) -> str:
        if braking_torque is None:
            return ""
        u_b = float(np.broadcast_to(braking_torque, need.shape)[k])
        if not u_b:
            return ""
        factor = (abs(need[k]) + abs(u_b)) / abs(u_b)
        return (
            f", plus {factor:.3g} times the Coulomb friction a1, which the braking cannot tell "
            "from its torque"
        )

    k = int(np.argmax(low))
    if low[k] > motor.torque_limit:
        raise InputError(
            f"stage {stage}: the mirror of the braking needs {abs(need[k]):.4g} +- "
            f"{std[k]:.2g} N m{coulomb(k)} at t = {mirror.t[k]:.2f} s of the reverse, the "
            f"motor has {motor.torque_limit:g} N m (device.toml motor.torque_limit): lower "
            "launch_speed or braking_torque"
        )
    warnings = []
    k = int(np.argmax(high))
    if high[k] > THIN_MARGIN * motor.torque_limit:
        warnings.append(
            f"stage {stage}: the mirror of the braking needs up to {abs(need[k]):.4g} +- "
            f"{std[k]:.2g} N m{coulomb(k)} (at t = {mirror.t[k]:.2f} s of the reverse), "
            f"{100 * high[k] / motor.torque_limit:.0f}% of the motor's {motor.torque_limit:g} "
            "N m with two stds: little is left for the regulator, which corrects the nominal "
            "model's errors (a lower launch_speed or braking_torque leaves more)"
        )
    dt = mirror.t[1] - mirror.t[0]
    width = max(round(FEASIBILITY_WINDOW / dt), 1)
    rate = uniform_filter1d(np.gradient(need, mirror.t), width, mode="nearest")
    k = int(np.argmax(np.abs(rate)))
    if abs(rate[k]) > THIN_MARGIN * motor.torque_rate_limit:
        warnings.append(
            f"stage {stage}: the mirror of the braking changes its torque at up to "
            f"{abs(rate[k]):.3g} N m/s (t = {mirror.t[k]:.2f} s), "
            f"{100 * abs(rate[k]) / motor.torque_rate_limit:.0f}% of the motor's "
            f"{motor.torque_rate_limit:g} N m/s: little is left for the regulator"
        )
    return warnings


def _step_function(h: float) -> ca.Function:
    """F(x, v, p): one RK4 step of length h of (phi, Omega, u) with du/dt = v."""
    x = ca.SX.sym("x", 3)
    v = ca.SX.sym("v")
    f = MODEL.state_derivative()

    def rhs(z):
        return ca.vertcat(f(z[:2], z[2], _DIRECTION, MODEL.p), v)

    return ca.Function("F", [x, v, MODEL.p], [rk4_step(rhs, x, h)])


@dataclass(frozen=True)
class _StepDerivatives:
    """One RK4 step and its per-interval derivative blocks (see the module docstring)."""

    F: ca.Function
    """F(x, v, p) -> x+."""
    jacobian: ca.Function
    """(x, v, p) -> the structural nonzeros of dF/d(x, v), 3x4, column by column."""
    jacobian_nz: tuple[np.ndarray, np.ndarray]
    """(row, column) of each of those nonzeros; columns 0-2 are x, column 3 is v."""
    hessian: ca.Function
    """(x, v, p, lam) -> the nonzeros of the upper triangle of d^2(-lam . F)/d(x, v)^2."""
    hessian_nz: tuple[np.ndarray, np.ndarray]
    """(row, column) of each of those nonzeros, in (x, v) as above."""


@functools.lru_cache(maxsize=4)
def _step_derivatives(h: float) -> _StepDerivatives:
    """The step of length h and its derivative blocks, built once per h (~20 ms)."""
    F = _step_function(h)
    x = ca.SX.sym("x", 3)
    v = ca.SX.sym("v")
    lam = ca.SX.sym("lam", 3)
    z = ca.vertcat(x, v)
    step = F(x, v, MODEL.p)
    jac = ca.jacobian(step, z)
    # The constraint is x_{k+1} - F(x_k, v_k): its second derivatives are those of -F.
    hess = ca.triu(ca.hessian(-ca.dot(lam, step), z)[0])
    opts = {"cse": True}
    return _StepDerivatives(
        F=F,
        jacobian=ca.Function("F_jac", [x, v, MODEL.p], [ca.vertcat(*jac.nonzeros())], opts),
        jacobian_nz=tuple(np.array(a, dtype=int) for a in jac.sparsity().get_triplet()),
        hessian=ca.Function(
            "F_hess", [x, v, MODEL.p, lam], [ca.vertcat(*hess.nonzeros())], opts
        ),
        hessian_nz=tuple(np.array(a, dtype=int) for a in hess.sparsity().get_triplet()),
    )


def _block_matrix(rows, cols, shape, values: ca.MX) -> ca.MX:
    """The sparse MX with ``values[i]`` at (rows[i], cols[i]) (no position twice)."""
    order = np.lexsort((rows, cols))  # CasADi stores nonzeros column by column
    sparsity = ca.Sparsity.triplet(*shape, rows[order].tolist(), cols[order].tolist())
    if sparsity.nnz() != len(rows):
        raise ValueError("a position of the block matrix is given twice")
    return ca.sparsity_cast(values[order.tolist()], sparsity)


def _nlp_derivatives(
    blocks: _StepDerivatives, X: ca.MX, V: ca.MX, p: np.ndarray, cost: ca.MX, w: ca.MX, g: ca.MX
) -> dict[str, ca.Function]:
    """nlpsol's "jac_g" and "hess_lag" for g = vec(X[:, 1:] - F(X[:, :-1], V)), from blocks.

    Variables w = (vec X, V): x_k is w[3k:3k+3], v_k is w[3(N+1)+k]. Row 3k+i of g is the
    step of interval k.
    """
    N = V.numel()
    k = np.arange(N)[:, None]

    def position(z):  # index in (x, v) of the step -> index in w, per interval
        return np.where(z < 3, 3 * k + z, 3 * (N + 1) + k)

    # dg/dw: -dF/d(x_k, v_k), and the identity on x_{k+1}.
    jr, jc = blocks.jacobian_nz
    eye = np.arange(3)
    rows = np.concatenate([(3 * k + jr).ravel(), (3 * k + eye).ravel()])
    cols = np.concatenate([position(jc).ravel(), (3 * (k + 1) + eye).ravel()])
    jac_values = ca.vertcat(-ca.vec(blocks.jacobian.map(N)(X[:, :-1], V, p)), ca.DM.ones(3 * N))
    jac = _block_matrix(rows, cols, (3 * N, w.numel()), jac_values)
    # Hessian of lam_f f + lam_g . g: the steps' blocks plus the cost's.
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", 3, N)
    hr, hc = blocks.hessian_nz
    hess_values = ca.vec(blocks.hessian.map(N)(X[:, :-1], V, p, lam_g))
    steps = _block_matrix(position(hr).ravel(), position(hc).ravel(), (w.numel(),) * 2, hess_values)
    hess = steps + lam_f * ca.triu(ca.hessian(cost, w)[0])
    none = ca.MX.sym("p", 0, 1)  # the NLP has no parameters
    return {
        "jac_g": ca.Function("jac_g", [w, none], [g, jac], ["x", "p"], ["g", "jac_g_x"]),
        "hess_lag": ca.Function(
            "hess_lag",
            [w, none, lam_f, ca.vec(lam_g)],
            [hess],
            ["x", "p", "lam_f", "lam_g"],
            ["triu_hess_gamma_x_x"],
        ),
    }


def solve_program_ocp(
    device: Device, stage: int, mirror: Mirror, nominal: ModelParameters
) -> OcpSolution:
    """Solve the reverse pass's OCP (module docstring).

    The mirror's feasibility is :func:`check_mirror`'s (rsp_inertia.ocp.program calls it
    first); here the motor's limits are the OCP's bounds.

    Parameters
    ----------
    device : Device
        The gimbal: its motor's limits bound the torque and its rate.
    stage : int
        The stage number, from 1.
    mirror : Mirror
        The reverse pass's reference, on the encoder's sample grid.
    nominal : ModelParameters
        The nominal model of the stage (rsp_inertia.ocp.nominal).

    Returns
    -------
    OcpSolution
        The optimal torque on the OCP grid and how the solve went.
    """
    start = time.perf_counter()
    motor = device.motor
    dt = mirror.t[1] - mirror.t[0]
    m = max(round(GRID_STEP / dt), 1)
    idx = np.arange(0, mirror.t.size, m)
    N = idx.size - 1
    h = m * dt
    blocks = _step_derivatives(h)
    p = nominal.vector

    # MX around a mapped SX step: one symbolic call, N evaluations; derivatives from the
    # step's blocks (module docstring).
    X = ca.MX.sym("X", 3, N + 1)
    V = ca.MX.sym("V", 1, N)
    ref_phi = mirror.phi[idx]
    ref_omega = mirror.omega[idx]
    shoot = blocks.F.map(N)(X[:, :-1], V, p)
    err = ca.vertcat(X[1, :] - ref_omega[None, :], W_PHI * (X[0, :] - ref_phi[None, :]))
    cost = h * ca.sumsqr(err) + RHO * h * ca.sumsqr(V)
    w = ca.vertcat(ca.vec(X), ca.vec(V))
    g = ca.vec(X[:, 1:] - shoot)
    nlp = {"x": w, "f": cost, "g": g}
    solver = ca.nlpsol(
        "ocp",
        "ipopt",
        nlp,
        {
            "ipopt.print_level": 0,
            "print_time": False,
            "ipopt.sb": "yes",
            "ipopt.max_iter": 300,
            **_nlp_derivatives(blocks, X, V, p, cost, w, g),
        },
    )

    # Bounds: the start is fixed (at rest, held); torque and rate within the motor's limits.
    hold = float(static_torque(mirror.rest_angle, nominal))
    lbx = np.tile([-np.inf, -np.inf, -motor.torque_limit], N + 1)
    ubx = np.tile([np.inf, np.inf, motor.torque_limit], N + 1)
    lbx[:3] = ubx[:3] = [mirror.rest_angle, 0.0, hold]
    lbv = np.full(N, -motor.torque_rate_limit)
    ubv = np.full(N, motor.torque_rate_limit)
    # Warm start: the mirror and the nominal model's inverse dynamics along it, rate-limited.
    needed = required_torque(mirror, nominal)
    u0 = np.clip(needed[idx], -motor.torque_limit, motor.torque_limit)
    u0[0] = hold
    v0 = np.clip(np.diff(u0) / h, lbv, ubv)
    u0 = np.concatenate([[hold], hold + np.cumsum(v0) * h])
    x0 = np.column_stack([ref_phi, ref_omega, u0]).ravel()
    sol = solver(
        x0=np.concatenate([x0, v0]),
        lbx=np.concatenate([lbx, lbv]),
        ubx=np.concatenate([ubx, ubv]),
        lbg=0,
        ubg=0,
    )
    stats = solver.stats()
    z = np.asarray(sol["x"]).ravel()
    states = z[: 3 * (N + 1)].reshape(N + 1, 3)
    return OcpSolution(
        t=mirror.t[idx],
        phi=states[:, 0],
        omega=states[:, 1],
        torque=states[:, 2],
        iterations=int(stats.get("iter_count", -1)),
        success=bool(stats.get("success", False)),
        solve_time=time.perf_counter() - start,
    )

