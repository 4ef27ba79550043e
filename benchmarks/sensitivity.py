"""Sensitivity study: each method's error against the errors of the constants it takes as known.

Every method leans on constants a rig knows only to some accuracy, and the sweep's cases
give both methods exact ones. Here the default case (paper's friction, 16-bit encoder, 3 mm
centre-of-mass offset, seed 0) is run with one constant off at a time:

- ``stiffness``: device.toml's ``[pendulum] stiffness`` (1 + e) times the true one. Only the
  pendulum uses it (M = c / w^2: an error e gives e in M).
- ``torque_gain``: the rig logs (1 + e) times the torque it applies (virtual.toml ``[rig]
  torque_gain``); device.toml says 1. Only RSP uses the torque (the pendulum's motor is off).
- ``tare``: device.toml's ``tare_inertia`` (1 + e) times the true tare of every stage. Both
  subtract it: J = (M - M_tare) / (1 + lam^2).

Each perturbed experiment is identified twice: with the constants stated as exact (std 0,
the user's belief) and with the error's size stated as their std (``stiffness_std``,
``torque_gain_std``, ``tare_inertia_std``), which the best-practice pendulum and RSP carry
into their stds (the naive pendulum has no such term). The rows give each method's worst
relative J_k error and worst |err|/std; :func:`sensitivity_table` and
:func:`sensitivity_figure` show them.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from benchmarks.cases import Case, code_fingerprint, configure
from benchmarks.experiments import vary, with_stages
from benchmarks.protocol import fit_protocol
from benchmarks.scratch import scratch_folder
from benchmarks.tables import fmt, new_figure, table_lines
from benchmarks.truth import identification_errors
from rsp_inertia.identifying import identify
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.programming import program
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import experiment_virtual, placed_body

__all__ = [
    "SENSITIVITY_METHODS",
    "SIZES",
    "Perturbation",
    "default_perturbations",
    "run_perturbation",
    "sensitivity_figure",
    "sensitivity_table",
]

SIZES = {
    "stiffness": (0.001, 0.003, 0.01),
    "torque_gain": (0.001, 0.003, 0.01),
    "tare": (0.01, 0.03, 0.05),
}
"""Relative errors of each constant: stiffness and torque gain 0.1-1%, tares 1-5%."""

SENSITIVITY_METHODS = {
    "pendulum": "naive pendulum",
    "pendulum_best": "best-practice pendulum",
    "node": "RSP node formula",
    "ls": "RSP least squares",
}
"""The methods compared (row-key suffixes of benchmarks.truth.METHODS)."""

BASE_CASE = Case(1.0, 16, 0)
"""The case every perturbation starts from."""


@dataclass(frozen=True, order=True)
class Perturbation:
    """One constant off by a relative ``size`` (0: the unperturbed experiment)."""

    source: str
    size: float

    @property
    def name(self) -> str:
        """File-name stem, e.g. ``sensitivity_tare_0.03``."""
        return f"sensitivity_{self.source}_{self.size:g}"


def default_perturbations() -> list[Perturbation]:
    """The unperturbed experiment and every (source, size) of SIZES."""
    return [Perturbation("none", 0.0)] + [
        Perturbation(source, size) for source, sizes in SIZES.items() for size in sizes
    ]


def run_perturbation(p: Perturbation) -> dict:
    """The default case with one constant off (module docstring), identified with the
    constants stated exact (keys ``<kind>_Jk_<method>``) and with their errors stated as stds
    (``<kind>_Jk_<method>_stated``), kinds err, std, z as in benchmarks.truth."""
    if p.source not in ("none", *SIZES):
        raise InputError(f"sensitivity: unknown source {p.source!r}")
    row: dict = {"case": p.name, **asdict(p), "code": code_fingerprint(), "error": None}
    try:
        _run(p, row)
    except InputError as error:
        row["error"] = str(error)
    return row


def _run(p: Perturbation, row: dict) -> None:
    """:func:`run_perturbation`'s work, into ``row``."""
    with threadpool_limits(limits=1), scratch_folder() as tmp:
        root = Path(tmp) / p.name
        create_default_experiment(root)
        configure(root, BASE_CASE)
        if p.source == "torque_gain":
            vary(root, virtual=lambda v: replace(v, rig=replace(v.rig, torque_gain=1.0 + p.size)))
        stages = open_experiment(root).stages()
        for stage in stages:
            fit_protocol(root, stage)
            program(root, stage)
            simulate(root, stage, "reverse")
        simulate(root, part="pendulum")
        if p.source in ("stiffness", "tare"):
            vary(root, device=lambda d: _stated_off(d, p))
        for suffix in ("", "_stated"):
            if suffix:
                vary(root, device=lambda d: _stated_stds(d, p))
            exp = open_experiment(root)
            result = identify(root)
            body = placed_body(exp.device, experiment_virtual(exp))
            errors = identification_errors(result, body, exp.device)
            row.update({f"{k}{suffix}": v for k, v in errors.items()
                        if k.endswith(tuple(SENSITIVITY_METHODS))})
            row[f"warnings{suffix}"] = "; ".join(result.warnings)


def _stated_off(device: Device, p: Perturbation) -> Device:
    """device.toml's pendulum stiffness or tares (1 + size) times the true ones (the runs are
    made: only what identify reads changes)."""
    if p.source == "stiffness":
        pendulum = device.pendulum
        return replace(device, pendulum=replace(
            pendulum, stiffness=pendulum.stiffness * (1.0 + p.size)
        ))
    return with_stages(device, lambda st: replace(
        st, tare_inertia=st.tare_inertia * (1.0 + p.size)
    ))


def _stated_stds(device: Device, p: Perturbation) -> Device:
    """device.toml's std keys set to the perturbation's size (0 for the other constants)."""
    size = {source: (p.size if source == p.source else 0.0) for source in SIZES}
    pendulum = device.pendulum
    device = replace(
        device,
        pendulum=replace(pendulum, stiffness_std=size["stiffness"] * pendulum.stiffness),
        motor=replace(device.motor, torque_gain_std=size["torque_gain"]),
    )
    # The true tare is the stated one over (1 + e): its error is e / (1 + e) of the stated.
    return with_stages(device, lambda st: replace(
        st, tare_inertia_std=size["tare"] / (1.0 + size["tare"]) * st.tare_inertia
    ))


def sensitivity_table(rows: list[dict]) -> str:
    """Markdown: per perturbation, each method's worst J_k error and worst |err|/std with the
    constants stated exact, then with the error stated as their std."""
    head = ["constant off", "by"]
    head += [f"{name} J_k err" for name in SENSITIVITY_METHODS.values()]
    head += [f"{name} err/std (exact / std stated)" for name in SENSITIVITY_METHODS.values()]
    lines = table_lines(head, [])
    for row in sorted(rows, key=lambda r: (r["source"] != "none", r["source"], r["size"])):
        if row.get("error"):
            lines.append(f"| {row['source']} | {row['size']:.1%} | failed: {row['error']} |")
            continue
        cells = [row["source"], f"{row['size']:.1%}"]
        cells += [fmt(row.get(f"err_Jk_{k}")) for k in SENSITIVITY_METHODS]
        cells += [
            f"{fmt(row.get(f'z_Jk_{k}'), '.1f')} / {fmt(row.get(f'z_Jk_{k}_stated'), '.1f')}"
            for k in SENSITIVITY_METHODS
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def sensitivity_figure(rows: list[dict], path: Path, command: str) -> None:
    """PNG: per constant, each method's worst J_k error against the constant's error."""
    from rsp_inertia.plots import save_figure

    ok = [r for r in rows if not r.get("error")]
    base = next((r for r in ok if r["source"] == "none"), None)
    fig, axes = new_figure(len(SIZES), 4.2)
    labels = {"stiffness": "pendulum stiffness", "torque_gain": "torque gain", "tare": "tare"}
    for ax, source in zip(axes, SIZES, strict=True):
        mine = sorted((r for r in ok if r["source"] == source), key=lambda r: r["size"])
        x = [r["size"] for r in mine]
        for i, (key, name) in enumerate(SENSITIVITY_METHODS.items()):
            y = [np.nan if r.get(f"err_Jk_{key}") is None else r[f"err_Jk_{key}"] for r in mine]
            ax.plot(x, y, "o-", color=f"C{i}", label=name)
            if base is not None and base.get(f"err_Jk_{key}") is not None:
                ax.axhline(base[f"err_Jk_{key}"], color=f"C{i}", lw=0.8, ls=":")
        ax.plot(x, x, color="grey", lw=0.8, ls="--", label="error = constant's error")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"relative error of the {labels[source]}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("worst relative error of J_k over the 6 axes")
    axes[-1].legend(fontsize=7, loc="best")
    fig.suptitle(
        "Sensitivity to calibration errors (dotted: the method's error with exact constants)"
        f"\n$ {command}", fontsize=9,
    )
    save_figure(fig, path)
