"""Predicted uncertainty of a run before it is made: identify's noise model on planned passes.

A planned run is a braking pass computed from a nominal model of the stage (no noise) and
its exact time mirror. From it this module builds the balance equations exactly as
``identify`` does (rsp_inertia.estimation.balance, rsp_inertia.estimation.tensor_fit), with the same noise model:

- the torque log's white noise of std sigma: the braking's constant torque estimated as the
  mean of the log (rsp_inertia.estimation.passes), the reverse's work as the sample-by-sample sum;
- the encoder's quantization through the smoother: the derived speed-error autocovariance
  R(tau) = r w_c^3 g(w_c tau) (rsp_inertia.estimation.smoothing), with w_c from the pass's top speed by
  the smoother's own rule (``smoother_bandwidth``) and r = (q^2/12) dt.

The generalised least squares then gives the covariance the noise model alone implies
(``predict_tensor``: speed-noise scale 1, no inflation by residuals). That
is an ideal reverse's std, a closed loop's best case: it cannot foresee the closed-loop
reverse's tracking mismatch (its friction slopes cost information; an exact mirror has
none) nor the regulator's speed noise, which together put identify's std above it. The planner uses it to rank protocols; the closed-loop
rehearsal of the chosen one (rsp_inertia.design.rehearsal) gives the std it promises. Neither foresees a
rig's imperfections beyond the noise model.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from rsp_inertia.estimation.balance import StageBalance, stage_balance
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.layout import SHARED_LAYOUT
from rsp_inertia.estimation.passes import PassEstimate, two_level_work
from rsp_inertia.estimation.smoothing import Smoothed, noise_density, smoother_bandwidth
from rsp_inertia.estimation.tensor_fit import tensor_block
from rsp_inertia.estimation.whitening import Noise, information, scaled_band
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.geometry import design_matrix, device_design
from rsp_inertia.plant.logs import Log, motor_work

__all__ = [
    "SHARED",
    "PlannedPass",
    "axis_stds",
    "combine_information",
    "planned_estimate",
    "predicted_balance",
    "run_information",
]

SHARED = tuple(SHARED_LAYOUT.names())
"""Unknowns shared by every run: the tensor's entries and the gravity terms."""
ENTRIES = SHARED_LAYOUT.slice("entries")
"""The tensor's entries among :data:`SHARED`."""


@dataclass(frozen=True)
class PlannedPass:
    """Exact states of a pass at the encoder's samples, with the motor torque applied."""

    t: np.ndarray
    """s, from 0."""
    phi: np.ndarray
    """rad."""
    omega: np.ndarray
    """rad/s (signed)."""
    eps: np.ndarray
    """rad/s^2."""
    torque: np.ndarray
    """N m, the motor torque held over [t_k, t_k+1)."""

    def mirrored(self, torque: np.ndarray) -> PlannedPass:
        """The time mirror (docs/method.md §4) on the same samples, with its motor torque."""
        return PlannedPass(
            t=self.t,
            phi=self.phi[::-1].copy(),
            omega=-self.omega[::-1],
            eps=self.eps[::-1].copy(),
            torque=np.asarray(torque, dtype=float),
        )


def planned_estimate(
    planned: PlannedPass,
    quantum: float,
    sigma_torque: float,
    constant_torque: bool,
    source: str,
    switch: int | None = None,
) -> PassEstimate:
    """A PassEstimate of a planned pass carrying identify's noise model (module docstring).

    The states are exact; ``omega_std`` is the smoother's steady value sqrt(r w_c^3 / 6)
    everywhere (its start-up ramp at the ends is left out: the balances keep off the ends).
    A planned pass has every sample: no dropped ones.

    Parameters
    ----------
    planned : PlannedPass
        The pass's exact states and torque.
    quantum : float
        rad, the encoder's q (the smoother's noise density).
    sigma_torque : float
        N m, the std of the torque log's noise.
    constant_torque : bool
        The work is the mean torque times the angle (a braking), else the sample-by-sample
        sum (rsp_inertia.plant.logs.motor_work).
    source : str
        The pass's name in messages.
    switch : int, optional
        With ``constant_torque``: a two-level braking's first sample at its second level,
        each level held at its mean (rsp_inertia.estimation.passes.estimate_pass).

    Returns
    -------
    PassEstimate
        The pass, ready for the balances.
    """
    dt = float(planned.t[1] - planned.t[0])
    bandwidth = smoother_bandwidth(float(np.max(np.abs(planned.omega))))
    r = noise_density(quantum, dt)
    smoothed = Smoothed(
        t=planned.t,
        phi=planned.phi,
        omega=planned.omega,
        eps=planned.eps,
        omega_std=np.full(planned.t.size, np.sqrt(r * bandwidth**3 / 6)),
        jerk_density=r * bandwidth**6,
        bandwidth=bandwidth,
        noise_density=r,
    )
    log = Log(t=planned.t, phi=planned.phi, torque=planned.torque)
    mean_2 = None
    if constant_torque and switch is not None:
        work, work_back, steps, mean, mean_2 = two_level_work(
            planned.torque, planned.phi, switch, None
        )
    else:
        work, work_back, steps, mean = motor_work(planned.torque, planned.phi, constant_torque)
        switch = None
    return PassEstimate(
        log=log,
        smoothed=smoothed,
        work=work,
        work_back=work_back,
        work_var_steps=steps,
        sigma_torque=sigma_torque,
        source=source,
        dropped=np.zeros(planned.t.size - 1, dtype=np.int64),  # planned at every sample
        torque_mean=mean,
        constancy_p=None,
        torque_mean_2=mean_2,
        switch=switch,
    )


def predicted_balance(
    device: Device,
    stage: int,
    braking: PlannedPass,
    reverse: PlannedPass,
    sigma_torque: float,
    switch: int | None = None,
) -> StageBalance:
    """The balance equations identify would form from these passes (forward run).

    Parameters
    ----------
    device : Device
        The device.
    stage : int
        Stage number, from 1.
    braking, reverse : PlannedPass
        The planned braking and its reverse.
    sigma_torque : float
        N m, the std of the torque log's noise.
    switch : int, optional
        A two-level braking's first sample at its second level (:func:`planned_estimate`):
        the balances then fit the run's pass gain.

    Returns
    -------
    StageBalance
        The run's balance equations, without a tracking mismatch.

    Raises
    ------
    InputError
        The passes share fewer than the turns the balances need
        (rsp_inertia.estimation.balance.usable_range).
    """
    q = device.encoder.quantum
    b = planned_estimate(braking, q, sigma_torque, True, f"stage {stage} planned braking", switch)
    r = planned_estimate(reverse, q, sigma_torque, False, f"stage {stage} planned reverse")
    balance = stage_balance(device, stage, b, r, slope_prior=False)
    # An exact mirror has no tracking mismatch; what rounding leaves of it (1e-15 rad/s)
    # would enter the least squares as two friction slopes of arbitrary shape.
    return dataclasses.replace(
        balance, mismatch=np.zeros_like(balance.mismatch), pass_gain=switch is not None
    )


def run_information(device: Device, balance: StageBalance, inertia: np.ndarray) -> np.ndarray:
    """(8, 8) information of one planned run on :data:`SHARED`, its own unknowns marginalised.

    The runs' noises are independent, so the joint least squares' information is the sum of
    the runs' (:func:`combine_information`); each run's is A^T C^-1 A of its equations
    (rsp_inertia.estimation.tensor_fit.tensor_block) with C its work covariance plus the speed noise's
    1/4 M_i M_j cov(S_i, S_j) (rsp_inertia.estimation.gls), and its own unknowns (the run's constant,
    its friction slopes) taken out by the Schur complement. Equal to the least squares' own
    covariance of the planned balances (rsp_inertia.estimation.tensor_fit.predict_tensor,
    tests/design/test_plan.py), at a fraction of its cost, so that a planner can try each
    stage's protocols once and combine them freely.

    Parameters
    ----------
    device : Device
        The device (its stages' tare inertias).
    balance : StageBalance
        The planned run's balance equations (:func:`predicted_balance`).
    inertia : np.ndarray, shape (n,), kg m^2
        M at the balance's angles (the nominal model's), which the least squares takes from
        a first unweighted fit.

    Returns
    -------
    np.ndarray, shape (8, 8)
        The information on :data:`SHARED`.
    """
    known = KnownTerms.from_tares([st.tare_inertia for st in device.stages])
    block = tensor_block(balance, "0", known, False)
    # Every shared unknown keeps its column (a lambda = 0 stage has zeros for the entries it
    # does not see); the run's own ones only where the data define them.
    names = [n for n, c in block.columns.items() if n in SHARED or np.any(c != 0.0)]
    A = np.column_stack([block.columns[n] for n in names])
    F = _information(A, balance, inertia)
    shared = [names.index(n) for n in SHARED]
    own = [k for k in range(len(names)) if k not in shared]
    F_ss = F[np.ix_(shared, shared)]
    if not own:
        return F_ss
    F_so = F[np.ix_(shared, own)]
    return F_ss - F_so @ np.linalg.pinv(F[np.ix_(own, own)]) @ F_so.T


def combine_information(device: Device, infos: list[np.ndarray]) -> np.ndarray:
    """kg m^2: the std of J_k at every node of the device from the runs' information matrices."""
    return axis_stds(device, sum(infos)[None])[0]


def axis_stds(device: Device, informations: np.ndarray) -> np.ndarray:
    """kg m^2, (k, axes): J_k stds of k summed information matrices (k, 8, 8) at once.

    Each matrix is scaled to unit diagonal before its (pseudo-)inverse, as the least squares
    scales its columns (rsp_inertia.estimation.gls); J_k = v_k . J through V (docs/method.md §5).
    """
    scale = np.sqrt(np.abs(np.einsum("kii->ki", informations)))
    scale[scale == 0.0] = 1.0
    outer = scale[:, :, None] * scale[:, None, :]
    cov = np.linalg.pinv(informations / outer, hermitian=True) / outer
    V = design_matrix(device_design(device).directions)
    return np.sqrt(np.abs(np.einsum("ij,kjl,il->ki", V, cov[:, ENTRIES, ENTRIES], V)))


def _information(A: np.ndarray, balance: StageBalance, inertia: np.ndarray) -> np.ndarray:
    """A^T C^-1 A for one planned run, C its work noise plus the speed noise's
    1/4 M_i M_j cov(S_i, S_j), whitened by structure as the least squares whitens
    (rsp_inertia.estimation.whitening: the run's constant, whose column is then zero, is
    profiled out with its last equation)."""
    speed = Noise(len(inertia), band=scaled_band(balance.speed_sq_band, 0.5 * inertia))
    return information(A, balance.work_noise + speed)
