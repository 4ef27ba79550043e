"""The columns of a run's balance equations that every least squares over the runs shares.

The body's tensor (rsp_inertia.estimation.tensor_fit) and the rig's calibration
(rsp_inertia.estimation.calibration) ask different questions of the same balances
(rsp_inertia.estimation.balance, docs/method.md §5): both give each run its constant, the
tracking mismatch's friction slopes and, for a stage run in both directions, its friction
asymmetry (:func:`run_columns`, :func:`run_priors`); both write the gravity potential's
share (:func:`gravity_rows`) and an encoder error's (:func:`encoder_columns`) alike; and
both offer the model tests the probes of a drive's loss, a warming motor and an encoder's error
(:func:`cause_probes`, rsp_inertia.estimation.model_tests). The runs' names in messages:
:func:`run_label`.
"""

from __future__ import annotations

import numpy as np

from rsp_inertia.estimation.balance import StageBalance
from rsp_inertia.estimation.gls import Prior
from rsp_inertia.estimation.layout import encoder_names
from rsp_inertia.estimation.model_tests import (
    DRIVE_PROBE,
    ENCODER_PROBE,
    PROBE_ORDERS,
    WARMING_PROBE,
)
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.model import gravity_basis, gravity_basis_slope
from rsp_inertia.plant.transducers import error_slope_basis

__all__ = [
    "WARMING_UNKNOWN",
    "both_directions",
    "cause_probes",
    "encoder_columns",
    "encoder_unknowns",
    "format_run",
    "gravity_row_slopes",
    "gravity_rows",
    "probe_bounds",
    "run_columns",
    "run_key",
    "run_label",
    "run_priors",
]


def encoder_unknowns(bal: StageBalance, orders: int) -> dict[str, np.ndarray]:
    """The encoder coefficients' columns on the unknowns' side, per unit of M(phi), by name
    (:func:`encoder_columns` negated: an error left in the readings raises the kinetic
    energy's share)."""
    return dict(zip(encoder_names(orders), -encoder_columns(bal, orders).T))


WARMING_UNKNOWN = "warming"
"""The warming motor's coefficient c among the unknowns, one for the experiment (one motor):
the body receives the logged torque times 1 + c m(t), m the magnets' modelled rise
(rsp_inertia.estimation.balance.warming_work), its column -(h_d, h_b) . the run's
StageBalance.warming_parts."""


def cause_probes(bal: StageBalance, hottest: float | None = None) -> tuple[dict, dict]:
    """(probes, probes_per_inertia) of one run's block (rsp_inertia.estimation.gls Block):
    the drive loss's column (the driving work's gain freed), a warming motor's (both passes'
    work weighted by the heat dissipated so far, rsp_inertia.estimation.balance.heat_work,
    over ``hottest``) and the encoder error's (orders 1 to PROBE_ORDERS, per unit of M).

    Parameters
    ----------
    bal : StageBalance
        The run's balance.
    hottest : float, optional
        N^2 m^2 s, the largest StageBalance.heat_gap of the fit's runs: the warming probe's
        coefficient is then the torque scale's difference between the passes of that run.
        Default: this run's.

    Returns
    -------
    tuple of dict
        Cause -> {name: column}, for Block.probes and Block.probes_per_inertia.
    """
    probes = {DRIVE_PROBE: {"dh_d": -bal.motor_work_parts[:, 0]}}
    hottest = bal.heat_gap if hottest is None else hottest
    # Where the fit models the warming (StageBalance.warming_parts), it is no probe.
    if bal.heat_work is not None and hottest > 0.0 and bal.warming_parts is None:
        probes[WARMING_PROBE] = {"c_heat": -bal.heat_work / hottest}
    return probes, {ENCODER_PROBE: encoder_unknowns(bal, PROBE_ORDERS)}


def probe_bounds(gains: tuple[float, float]) -> dict[str, float]:
    """Cause -> the largest value the physics allows its probe's coefficient
    (rsp_inertia.estimation.gls Block.probe_bounds): the drive-loss probe's dh_d at most
    h_b - h_d, a round-trip efficiency (h_d + dh_d) / h_b of at most 1 (a transmission loses
    power in both directions of flow: h_d <= 1 <= h_b, docs/method.md §3).

    Parameters
    ----------
    gains : (float, float)
        The drive's gains (h_d, h_b) the fit applies.

    Returns
    -------
    dict of str to float
        The bounds.
    """
    h_d, h_b = gains
    return {DRIVE_PROBE: float(h_b - h_d)}


def encoder_columns(bal: StageBalance, orders: int) -> np.ndarray:
    """(n, 2 orders) how an error of the encoder's coefficients moves one run's balance, per
    unit of M(phi) (docs/method.md §5 Calibration).

    A reading error e left in the logs scales both passes' speeds at an angle by 1 + e'(phi),
    so 1/2 M S reads 1/2 M S (1 + 2 e'): the balance gains M S e'_theta(phi) per unit of each
    coefficient (rsp_inertia.plant.transducers.error_slope_basis, at the body's angle). The
    error's smaller effects (the angle's own shift in M, the potential and the work: a few
    percent of this at order 1) are left out: calibrate iterates on the corrected logs.
    """
    return bal.speed_sq[:, None] * error_slope_basis(bal.phi, orders)


def gravity_rows(phi: np.ndarray) -> np.ndarray:
    """(n, 2) 2 dPi/d[Gs, Gc]: the gravity potential's share of the balance, twice for the
    two passes (docs/method.md §3, rsp_inertia.plant.model.gravity_basis)."""
    return 2 * gravity_basis(phi)


def gravity_row_slopes(phi: np.ndarray) -> np.ndarray:
    """(n, 2) d/dphi of :func:`gravity_rows` (rsp_inertia.plant.model.gravity_basis_slope)."""
    return 2 * gravity_basis_slope(phi)


def run_key(bal: StageBalance) -> tuple[int, Direction]:
    """(stage, direction) of a run."""
    return bal.stage, Direction.of_sign(bal.direction)


def format_run(key: tuple[int, str]) -> str:
    """"stage N forward" or "stage N backward" from (stage, direction)."""
    stage, direction = key
    return f"stage {stage} {direction}"


def run_label(bal: StageBalance) -> str:
    """"stage N forward" or "stage N backward"."""
    return format_run(run_key(bal))


def run_columns(
    bal: StageBalance, key: str, both_directions: bool, group: str | None = None
) -> dict[str, np.ndarray]:
    """The columns every run has whatever the question: its constant, the tracking mismatch's
    friction slopes (rsp_inertia.estimation.balance; left out when the mismatch is exactly zero, exact
    data), and the friction asymmetry of a stage run in both directions.

    Parameters
    ----------
    bal : StageBalance
        The run's balance.
    key : str
        Names the run's own unknowns (``C[key]``, ``d1[key]``, ``d2[key]``).
    both_directions : bool
        The run's stage is run in both directions: the friction asymmetry's columns join.
    group : str, optional
        Names the friction asymmetry's unknowns, shared by the runs of ``group``; by default
        the stage.

    Returns
    -------
    dict of str to numpy.ndarray
        Name -> column, one entry per balance angle.
    """
    group = str(bal.stage) if group is None else group
    n = len(bal.phi)
    cols = {f"C[{key}]": -np.ones(n)}
    if np.any(bal.mismatch != 0.0):
        for j, name in enumerate(slope_unknowns(key)):
            cols[name] = -bal.mismatch[:, j]
    if both_directions:
        for k, name in enumerate(asymmetry_unknowns(group)):
            cols[name] = -bal.direction * bal.friction_shape[:, k]
    return cols


def slope_unknowns(key: str) -> tuple[str, ...]:
    """The names of a run's friction slopes among the unknowns, ``d1[key]``, ``d2[key]``, ...:
    one per slope of the friction law (rsp_inertia.plant.friction.FRICTION.slope_names)."""
    return tuple(f"{name}[{key}]" for name in FRICTION.slope_names)


def asymmetry_unknowns(group: str) -> tuple[str, ...]:
    """The names of a group's friction asymmetry among the unknowns, ``e1[group]``, ...: one
    per coefficient of the friction law (D_backward - D_forward has its terms)."""
    return tuple(f"e{k + 1}[{group}]" for k in range(len(FRICTION.names)))


def run_priors(bal: StageBalance, columns: dict[str, np.ndarray], key: str) -> tuple[Prior, ...]:
    """The run's priors on its own unknowns: its friction slopes' from its passes' dynamics
    (rsp_inertia.estimation.balance.friction_slope_prior), when it has slope columns and the
    prior was made.

    Parameters
    ----------
    bal : StageBalance
        The run's balance (its ``slope_prior``).
    columns : dict of str to numpy.ndarray
        The run's columns (:func:`run_columns`).
    key : str
        Names the run's own unknowns.

    Returns
    -------
    tuple of Prior
        The friction slopes' prior, or none.
    """
    names = slope_unknowns(key)
    if bal.slope_prior is None or not all(name in columns for name in names):
        return ()
    return (Prior(names, *bal.slope_prior),)


def both_directions(balances: list[StageBalance]) -> set[int]:
    """Stages with runs in both directions."""
    seen: dict[int, set[int]] = {}
    for bal in balances:
        seen.setdefault(bal.stage, set()).add(bal.direction)
    return {stage for stage, dirs in seen.items() if len(dirs) == 2}
