"""Identification of an experiment: every stage's logs in, tensor and centre of mass out.

Reads only what a rig produces (device.toml and the logs), never virtual.toml. Steps, each in
its own function elsewhere: smoothing and motor work (estimation.energy), balances and the node
formula (estimation.balance), least squares and the tensor (estimation.tensor).

Two estimates of the tensor are reported:

- **least squares** (the headline): every stage's balance angles over all covered turns in
  one weighted least-squares problem (METHOD.md §5), tensor and gravity terms together;
- **node formula**: M at each node from its whole-turn pairs, J_k = (M - M_tare)/(1+lam^2),
  and the tensor from the J_k through V (the paper's six-axis solve, (8)).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from estimation.balance import node_formula, stage_balance
from estimation.energy import check_braking_monotone, estimate_pass
from estimation.tensor import (
    axis_values,
    fit_tensor,
    physical_warnings,
    principal,
    tensor_from_axes,
)
from plant.errors import InputError
from plant.experiment import Experiment
from plant.geometry import axis_direction, design_matrix
from plant.logs import read_log

__all__ = ["MAX_CONDITION", "AxisResult", "Identification", "identify"]

ENTRY_NAMES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")

MAX_CONDITION = 1e3
"""cond(V) above which the axis design is refused: the tensor would be noise."""

WARN_CONDITION = 10.0
"""cond(V) above which the design is accepted with a warning."""


@dataclass(frozen=True)
class AxisResult:
    """The moment of inertia about one node's axis."""

    stage: int
    """Stage number, from 1."""
    phi_deg: float
    """Node, deg."""
    direction: np.ndarray
    """Unit axis in the body frame (METHOD.md §1)."""
    J: float
    """kg m^2, from the least-squares tensor (headline)."""
    J_std: float
    """kg m^2."""
    J_node: float
    """kg m^2, from the node formula with the measured reverse speeds."""
    J_node_std: float
    """kg m^2."""
    J_plain: float
    """kg m^2, the paper's plain formula (6)/(7)."""
    J_plain_std: float
    """kg m^2."""
    pairs: int
    """One-turn pairs behind the node formula."""


@dataclass(frozen=True)
class Identification:
    """Everything ``identify`` finds; :meth:`to_json` gives result.json (INTERFACES.md)."""

    entries: np.ndarray
    """[Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2, least squares (headline)."""
    entries_cov: np.ndarray
    """(6, 6), kg^2 m^4."""
    node_entries: np.ndarray
    """Same entries from the node formula's J_k through V."""
    node_entries_cov: np.ndarray
    """(6, 6)."""
    axes: list[AxisResult]
    """One per node of every stage."""
    com: np.ndarray | None
    """[x_c, y_c], m, when device.toml gives the mass."""
    com_std: np.ndarray | None
    """m."""
    gravity: np.ndarray
    """[m g x_c, m g y_c], N m."""
    gravity_std: np.ndarray
    """N m."""
    condition_number: float
    """cond(V) of the node axes."""
    chi2_dof: float
    """Least squares: residual chi^2 per degree of freedom."""
    n_equations: int
    """Least squares: balance angles used."""
    warnings: list[str] = field(default_factory=list)
    """Physical-sense and design warnings."""

    @property
    def entries_std(self) -> np.ndarray:
        """Standard deviations of ``entries``."""
        return np.sqrt(np.diag(self.entries_cov))

    def to_json(self) -> dict:
        """The result.json document (INTERFACES.md), with extensions."""
        moments, vectors = principal(self.entries)
        node_std = np.sqrt(np.diag(self.node_entries_cov))
        return {
            "tensor": dict(zip(ENTRY_NAMES, map(float, self.entries))),
            "tensor_std": dict(zip(ENTRY_NAMES, map(float, self.entries_std))),
            "principal_moments": [float(m) for m in moments],
            "principal_axes": [[float(c) for c in v] for v in vectors],
            "axes": [
                {
                    "stage": a.stage,
                    "phi_deg": a.phi_deg,
                    "direction": [float(c) for c in a.direction],
                    "J": a.J,
                    "J_std": a.J_std,
                    "J_node": a.J_node,
                    "J_node_std": a.J_node_std,
                    "J_plain": a.J_plain,
                    "J_plain_std": a.J_plain_std,
                    "pairs": a.pairs,
                }
                for a in self.axes
            ],
            "com": None
            if self.com is None
            else {"x": float(self.com[0]), "y": float(self.com[1])},
            "com_std": None
            if self.com_std is None
            else {"x": float(self.com_std[0]), "y": float(self.com_std[1])},
            "condition_number": self.condition_number,
            "headline": "least_squares",
            "node_formula": {
                "tensor": dict(zip(ENTRY_NAMES, map(float, self.node_entries))),
                "tensor_std": dict(zip(ENTRY_NAMES, map(float, node_std))),
            },
            "gravity_torque": {
                "m_g_xc": float(self.gravity[0]),
                "m_g_yc": float(self.gravity[1]),
                "std": [float(s) for s in self.gravity_std],
            },
            "least_squares": {"equations": self.n_equations, "chi2_dof": self.chi2_dof},
            "warnings": list(self.warnings),
        }


def identify(
    exp: Experiment, progress: Callable[[str], None] | None = None
) -> Identification:
    """Identify the tensor (and centre of mass) from every stage's braking and reverse logs.

    Raises
    ------
    InputError
        Missing or malformed logs, logs that do not overlap, too few turns for a node,
        a braking whose speed reverses, an ill-conditioned axis design.
    """
    say = progress or (lambda _text: None)
    device = exp.device
    q = device.encoder.quantum
    balances, nodes = [], []
    for stage in exp.stages():
        b_path, r_path = exp.braking_path(stage), exp.reverse_path(stage)
        braking = read_log(b_path, device.encoder, "braking")
        check_braking_monotone(braking, str(b_path))
        reverse = read_log(r_path, device.encoder, "reverse")
        b_est = estimate_pass(braking, q, str(b_path))
        r_est = estimate_pass(reverse, q, str(r_path))
        balances.append(stage_balance(device, stage, b_est, r_est))
        nodes.extend(node_formula(device, stage, b_est, r_est))
        say(f"stage {stage}: {len(braking)} + {len(reverse)} rows smoothed and balanced")

    directions = np.array(
        [
            axis_direction(math.radians(n.node_deg), device.stages[n.stage - 1].gear_ratio)
            for n in nodes
        ]
    )
    cond = float(np.linalg.cond(design_matrix(directions)))
    warnings = []
    if not cond < MAX_CONDITION:
        raise InputError(
            f"{exp.root / 'device.toml'}: stage: the node axes are ill-conditioned "
            f"(cond(V) = {cond:.3g} > {MAX_CONDITION:g}); choose gear ratios and nodes that "
            "spread the axes (see rsp-inertia design)"
        )
    if cond > WARN_CONDITION:
        warnings.append(f"the axis design is poorly conditioned: cond(V) = {cond:.3g}")

    fit = fit_tensor(balances)
    J_ls, J_ls_std = axis_values(fit.entries, fit.entries_cov, directions)
    J_node, J_node_std, J_plain, J_plain_std = [], [], [], []
    for n in nodes:
        st = device.stages[n.stage - 1]
        scale = 1.0 + st.gear_ratio**2
        J_node.append((n.M - st.tare_inertia) / scale)
        J_node_std.append(n.M_std / scale)
        J_plain.append((n.M_plain - st.tare_inertia) / scale)
        J_plain_std.append(n.M_plain_std / scale)
    node_entries, node_cov, _ = tensor_from_axes(
        np.array(J_node), np.array(J_node_std), directions
    )
    axes = [
        AxisResult(
            stage=n.stage,
            phi_deg=n.node_deg,
            direction=d,
            J=float(J_ls[i]),
            J_std=float(J_ls_std[i]),
            J_node=float(J_node[i]),
            J_node_std=float(J_node_std[i]),
            J_plain=float(J_plain[i]),
            J_plain_std=float(J_plain_std[i]),
            pairs=n.pairs,
        )
        for i, (n, d) in enumerate(zip(nodes, directions))
    ]
    gravity_std = np.sqrt(np.diag(fit.gravity_cov))
    com = com_std = None
    if device.body is not None:
        weight = device.body.mass * device.gravity
        com = fit.gravity / weight
        com_std = gravity_std / weight
    warnings += physical_warnings(fit.entries, fit.entries_cov)
    return Identification(
        entries=fit.entries,
        entries_cov=fit.entries_cov,
        node_entries=node_entries,
        node_entries_cov=node_cov,
        axes=axes,
        com=com,
        com_std=com_std,
        gravity=fit.gravity,
        gravity_std=gravity_std,
        condition_number=cond,
        chi2_dof=fit.chi2_dof,
        n_equations=fit.n_equations,
        warnings=warnings,
    )
