"""Sensitivity study: each method's error against the errors of the constants it takes as known.

Every method leans on constants a rig knows only to some accuracy, and the sweep
(rsp_inertia.bench) gives both methods exact ones. Here the default experiment (paper's
friction, 16-bit encoder, 3 mm centre-of-mass offset, seed 0) is run with one constant off
at a time:

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
relative J_k error and worst |err|/std; :func:`sensitivity_report` the Markdown section and the
PNG.
"""

from __future__ import annotations

import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import tomlkit
from threadpoolctl import threadpool_limits

from rsp_inertia.pipeline import create_default_experiment, identify, program, simulate
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import write_atomic

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
"""The methods compared (row-key suffixes of rsp_inertia.bench)."""


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


def _edit(path: Path, edit) -> None:
    doc = tomlkit.parse(path.read_text())
    edit(doc)
    write_atomic(path, tomlkit.dumps(doc))


def run_perturbation(p: Perturbation) -> dict:
    """The default experiment with one constant off (module docstring), identified with the
    constants stated exact (keys ``<kind>_Jk_<method>``) and with their errors stated as stds
    (``<kind>_Jk_<method>_stated``), kinds err, std, z as in rsp_inertia.bench."""
    # Imported here: rsp_inertia.bench imports this module for its report.
    from rsp_inertia.bench import code_fingerprint

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
    from rsp_inertia.bench import Case, _configure, _fit_protocol, _relative_errors

    with threadpool_limits(limits=1), tempfile.TemporaryDirectory(prefix="rsp-sens-") as tmp:
        root = Path(tmp) / p.name
        create_default_experiment(root)
        _configure(root, Case(1.0, 16, 0))
        if p.source == "torque_gain":
            _edit(root / "virtual.toml",
                  lambda doc: doc.add("rig", tomlkit.table().add("torque_gain", 1.0 + p.size)))
        stages = open_experiment(root).stages()
        for stage in stages:
            _fit_protocol(root, stage)
            program(root, stage)
            simulate(root, stage, "reverse")
        simulate(root, part="pendulum")
        if p.source == "stiffness":
            _edit(root / "device.toml",
                  lambda doc: doc["pendulum"].__setitem__(
                      "stiffness", doc["pendulum"]["stiffness"] * (1.0 + p.size)))
        if p.source == "tare":
            def scale_tares(doc):
                for table in doc["stage"]:
                    table["tare_inertia"] = table["tare_inertia"] * (1.0 + p.size)
            _edit(root / "device.toml", scale_tares)
        for suffix in ("", "_stated"):
            if suffix:
                _edit(root / "device.toml", lambda doc: _state_stds(doc, p))
            exp = open_experiment(root)
            result = identify(root)
            errors = _relative_errors(result, exp.load_virtual(), exp.device)
            row.update({f"{k}{suffix}": v for k, v in errors.items()
                        if k.endswith(tuple(SENSITIVITY_METHODS))})
            row[f"warnings{suffix}"] = "; ".join(result.warnings)


def _state_stds(doc, p: Perturbation) -> None:
    """device.toml's std keys set to the perturbation's size (0 for the other constants)."""
    size = {source: (p.size if source == p.source else 0.0) for source in SIZES}
    doc["pendulum"]["stiffness_std"] = size["stiffness"] * doc["pendulum"]["stiffness"]
    doc["motor"]["torque_gain_std"] = size["torque_gain"]
    for table in doc["stage"]:
        # The true tare is the stated one over (1 + e): its error is e / (1 + e) of the stated.
        table["tare_inertia_std"] = size["tare"] / (1.0 + size["tare"]) * table["tare_inertia"]


def _fmt(value, spec=".1e") -> str:
    return "-" if value is None else format(value, spec)


def sensitivity_table(rows: list[dict]) -> str:
    """Markdown: per perturbation, each method's worst J_k error and worst |err|/std with the
    constants stated exact, then with the error stated as their std."""
    head = ["constant off", "by"]
    head += [f"{name} J_k err" for name in SENSITIVITY_METHODS.values()]
    head += [f"{name} err/std (exact / std stated)" for name in SENSITIVITY_METHODS.values()]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in sorted(rows, key=lambda r: (r["source"] != "none", r["source"], r["size"])):
        if row.get("error"):
            lines.append(f"| {row['source']} | {row['size']:.1%} | failed: {row['error']} |")
            continue
        cells = [row["source"], f"{row['size']:.1%}"]
        cells += [_fmt(row.get(f"err_Jk_{k}")) for k in SENSITIVITY_METHODS]
        cells += [
            f"{_fmt(row.get(f'z_Jk_{k}'), '.1f')} / {_fmt(row.get(f'z_Jk_{k}_stated'), '.1f')}"
            for k in SENSITIVITY_METHODS
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def sensitivity_figure(rows: list[dict], path: Path, command: str) -> None:
    """PNG: per constant, each method's worst J_k error against the constant's error."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from rsp_inertia.plots import save_figure

    ok = [r for r in rows if not r.get("error")]
    base = next((r for r in ok if r["source"] == "none"), None)
    fig = Figure(figsize=(4.2 * len(SIZES) + 1.0, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(SIZES), sharey=True, squeeze=False)[0]
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
