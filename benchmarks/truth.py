"""Errors of an identification against the virtual device's truth.

The truth is virtual.toml's body placed on the rig by its mounting, in rig axes as identify
reports (:func:`rsp_inertia.virtual.device.placed_body`, a
:class:`rsp_inertia.plant.config.TrueBody`; the callers place it). Moments of
inertia J_k about identified axes are compared relatively (J / J_true - 1); tensor entries
relative to the largest principal moment (products of inertia may be near zero; the
package's :func:`rsp_inertia.plant.geometry.relative_errors`);
``|error| / std`` says whether a method's reported std explains its error.
:func:`method_errors` reduces one method's estimates to the worst of each over the axes, the
row keys the sweep and the sensitivity study tabulate.
"""

from __future__ import annotations

import numpy as np

from rsp_inertia.plant.geometry import relative_errors

__all__ = [
    "METHODS",
    "best_axes_count",
    "identification_errors",
    "method_errors",
    "pendulum_estimates",
    "principal_scale",
    "tensor_error",
    "true_moments",
]

METHODS = {
    "ls": "RSP least squares",
    "node": "RSP node formula",
    "pendulum": "pendulum classic",
    "pendulum_damped": "pendulum damped fit",
    "pendulum_best": "pendulum best practice",
}
"""Row-key suffixes of the methods (``err_Jk_<key>``, ``std_Jk_<key>``, ``z_Jk_<key>``,
``err_tensor_<key>``) and their names."""


def true_moments(directions, tensor) -> np.ndarray:
    """J_true = e^T J e about each unit axis e, a row of ``directions`` (shape (n, 3))."""
    e = np.asarray(directions, dtype=float)
    return np.einsum("ij,jk,ik->i", e, np.asarray(tensor, dtype=float), e)


def principal_scale(tensor) -> float:
    """The largest principal moment of ``tensor``, kg m^2: the scale of entry errors."""
    return float(np.linalg.eigvalsh(np.asarray(tensor, dtype=float)).max())


def tensor_error(entries, body) -> float:
    """Worst |entry - true entry| of [Jx, Jy, Jz, Jxy, Jyz, Jxz] over ``body``'s largest
    principal moment (:func:`rsp_inertia.plant.geometry.relative_errors`)."""
    return float(np.max(np.abs(relative_errors(entries, body.inertia))))


def identification_errors(result, body, device) -> dict:
    """An identification's errors, per method of METHODS (:func:`method_errors`), plus
    ``com_error_mm`` (in the xy-plane), ``pendulum_axes`` and ``pendulum_best_axes``.

    ``result`` is identify's result; the pendulum's J_k are over the axes whose run could be
    reduced (``pendulum_axes``), its tensor needs all of them; the best practice measures
    about each run's equilibrium axis.
    """
    axes = np.array([a.direction for a in result.axes])
    J_true = true_moments(axes, body.tensor)
    estimates = {
        "ls": (np.array([a.J for a in result.axes]), np.array([a.J_std for a in result.axes]),
               J_true, result.entries),
        "node": (np.array([a.J_node for a in result.axes]),
                 np.array([a.J_node_std for a in result.axes]), J_true, result.node_entries),
    }
    pend = result.pendulum
    row: dict = {"pendulum_axes": 0 if pend is None else len(pend.runs)}
    row["pendulum_best_axes"] = best_axes_count(pend)
    if pend is not None:
        estimates.update(pendulum_estimates(pend, result, body, device, ""))
    for key in METHODS:
        row.update(method_errors(estimates.get(key), key, body))
    row["com_error_mm"] = (
        None if result.com is None else float(np.hypot(*(result.com - body.com[:2])) * 1e3)
    )
    return row


def best_axes_count(pend) -> int:
    """Axes the best-practice pendulum reduced (its runs with enough half cycles)."""
    if pend is None or pend.J_best is None:
        return 0
    return int(np.sum(np.isfinite(pend.J_best)))


def pendulum_estimates(pend, result, body, device, suffix: str) -> dict:
    """The pendulum methods' (J, J_std, J_true, entries), keyed ``pendulum<...>`` + suffix;
    ``result`` gives the axes of the runs' nodes."""
    where = [(a.stage, a.phi_deg) for a in result.axes]
    index = [where.index((r.stage, r.node_deg)) for r in pend.runs]
    J_true = true_moments([result.axes[i].direction for i in index], body.tensor)
    out = {
        "pendulum" + suffix: (pend.J_classic, pend.J_classic_std, J_true, pend.entries_classic),
        "pendulum_damped" + suffix: (pend.J_damped, pend.J_damped_std, J_true,
                                     pend.entries_damped),
    }
    if pend.J_best is not None and np.any(np.isfinite(pend.J_best)):
        J_true_best = true_moments(pend.best_axes(device), body.tensor)
        out["pendulum_best" + suffix] = (pend.J_best, pend.J_best_std, J_true_best,
                                         pend.entries_best)
    return out


def method_errors(estimate, key: str, body) -> dict:
    """``err_Jk_``, ``std_Jk_``, ``z_Jk_`` and ``err_tensor_`` + key of one method's
    (J, J_std, J_true, entries): the worst relative J_k error, the worst relative std it
    reports, the worst |J_k error| / std, and :func:`tensor_error`; None where it has
    nothing (NaN J: a failed run)."""
    names = [f"{name}_{key}" for name in ("err_Jk", "std_Jk", "z_Jk", "err_tensor")]
    if estimate is None:
        return dict.fromkeys(names)
    J, J_std, J_true, entries = estimate
    J, J_std = np.asarray(J, dtype=float), np.asarray(J_std, dtype=float)

    def worst(values):
        return float(np.nanmax(values)) if np.any(np.isfinite(values)) else None

    return dict(zip(names, (
        worst(np.abs(J / J_true - 1.0)),
        worst(J_std / J_true),
        worst(np.abs(J - J_true) / J_std),
        None if entries is None else tensor_error(entries, body),
    )))
