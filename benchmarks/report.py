"""The sweep's files: accuracy.md, accuracy.png, speed.md and, with the sensitivity study,
sensitivity.png (each with the command that made it)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks.accuracy import (
    accuracy_table,
    case_table,
    group_rows,
    headline,
    speed_table,
    stat,
    tensor_table,
)
from benchmarks.cases import COM_FRICTION_FACTORS, COM_OFFSETS_MM, DEFAULT_COM_MM
from benchmarks.protocol import TORQUE_MARGIN
from benchmarks.sensitivity import sensitivity_figure, sensitivity_table
from benchmarks.tables import new_figure
from benchmarks.truth import METHODS
from rsp_inertia.checking import MIN_TURNS_PAST_LAST_NODE
from rsp_inertia.infra.files import write_atomic

__all__ = ["SweepReport", "accuracy_figure", "write_report"]


@dataclass(frozen=True)
class SweepReport:
    """What a sweep wrote."""

    rows: list[dict]
    """One row per case of the accuracy sweep, sorted by case."""
    sensitivity: list[dict]
    """One row per perturbation of the sensitivity study (none for a quick sweep)."""
    table: str
    """The accuracy table (Markdown), as in accuracy.md."""
    paths: tuple[Path, ...]
    """accuracy.md, accuracy.png, speed.md (and sensitivity.png)."""

    @property
    def crashed(self) -> list[str]:
        """Names of the cases that crashed (bugs; their rows are flagged ``bug``)."""
        return [row["case"] for row in self.rows + self.sensitivity if row.get("bug")]


def accuracy_figure(rows: list[dict], path: Path, command: str) -> None:
    """PNG: per encoder, each method's worst J_k error (mean and worst over the seeds)
    against the friction, at the default centre-of-mass offset."""
    from matplotlib.lines import Line2D

    from rsp_inertia.plots import save_figure

    # Over friction x bits at the default offset (the other offsets: the tables).
    groups = {(f, b): g for (f, b, c), g in group_rows(rows).items() if c == DEFAULT_COM_MM}
    factors = sorted({f for f, _ in groups})
    bits_all = sorted({b for _, b in groups})
    fig, axes = new_figure(len(bits_all), 4.4)
    x = np.arange(len(factors))  # friction 0 has no place on a log axis: categories
    for ax, bits in zip(axes, bits_all, strict=True):
        for i, (key, name) in enumerate(METHODS.items()):
            mean, worst = [], []
            for factor in factors:
                ok = [r for r in groups.get((factor, bits), []) if r["error"] is None]
                m, w = stat(ok, f"err_Jk_{key}")
                mean.append(np.nan if m is None else m)
                worst.append(np.nan if w is None else w)
            color = f"C{i}"
            ax.plot(x, mean, "o-", color=color, label=name)
            ax.plot(x, worst, "v--", color=color, alpha=0.6, lw=1)
        if not any(r["error"] is None for f in factors for r in groups.get((f, bits), [])):
            ax.text(0.5, 0.5, "no case succeeded\n(see accuracy.md)", ha="center",
                    va="center", transform=ax.transAxes, color="grey")
        ax.axhline(1e-4, color="k", lw=0.8, ls=":", label="target 1e-4")
        ax.set_yscale("log")
        ax.set_xticks(x, [f"x{f:g}" for f in factors])
        ax.set_xlabel("bearing friction (Coulomb and viscous) / paper's")
        ax.set_title(f"{bits}-bit encoder")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("worst relative error of J_k over the 6 axes")
    handles, _ = axes[-1].get_legend_handles_labels()
    handles += [
        Line2D([], [], color="grey", marker="o", ls="-", label="mean over seeds"),
        Line2D([], [], color="grey", marker="v", ls="--", alpha=0.6, label="worst over seeds"),
    ]
    axes[-1].legend(handles=handles, fontsize=7, loc="best")
    fig.suptitle(
        f"RSP and torsion-pendulum accuracy over seeds (com {DEFAULT_COM_MM:g} mm)\n$ {command}",
        fontsize=9,
    )
    save_figure(fig, path)


def write_report(rows: list[dict], out_dir: str | os.PathLike, command: str) -> SweepReport:
    """Write accuracy.md, accuracy.png and speed.md into ``out_dir`` (atomically), and
    sensitivity.png with a section of accuracy.md when the rows hold perturbations.

    Parameters
    ----------
    rows : list of dict
        :func:`benchmarks.scheduling.run_sweep`'s rows.
    out_dir : path
        The results folder (it must exist).
    command : str
        The command line that produced the rows, written into each file.
    """
    out = Path(out_dir)
    sensitivity = [row for row in rows if "source" in row]
    rows = [row for row in rows if "source" not in row]
    table = accuracy_table(rows)
    failed = [row for row in rows if row["error"] is not None]
    seeds = sorted({row["seed"] for row in rows})
    accuracy = [
        "# Accuracy: RSP against the torsion pendulum",
        "",
        f"Command: `{command}`",
        "",
        (
            "Each case is the default experiment (paper scenario, icosahedron stages) on the "
            "virtual device, end to end: braking, torque program, closed-loop reverse, "
            "torsion-pendulum runs at every node, identification. 'friction x' scales the "
            "Coulomb (a1) and viscous (a2) coefficients of the paper's a = [1e-4, 1e-4, 1e-3]; "
            "the quadratic a3 keeps the paper's value (at 10x it would take 95% of stage 1's "
            "energy every turn). counts_per_rev = 2^bits. 'com mm': the body's centre of mass "
            "this far from the fixed point, along the default body's offset direction "
            f"({', '.join(f'{c:g}' for c in COM_OFFSETS_MM)} mm; the offsets other than "
            f"{DEFAULT_COM_MM:g} mm at friction x"
            f"{' and x'.join(f'{f:g}' for f in COM_FRICTION_FACTORS)}, first seed). Seeds "
            f"{', '.join(map(str, seeds))} set the noise and move the release angle by "
            "U(-1, 1) deg. Protocol: where the default launch speed would make the reverse "
            f"pass need more than {TORQUE_MARGIN:g} of the motor's torque limit "
            "(b + 2 D(Omega), with the virtual device's true friction), the launch speed is "
            "lowered to fit; where the braking then covers fewer than "
            f"{MIN_TURNS_PAST_LAST_NODE:g} turns past the last node, the braking torque is "
            "halved (up to 7 times) and the longest braking kept (per-case table)."
        ),
        "",
        (
            "Methods: the naive pendulum (period from the zero crossings, M = c tau^2 / 4 pi^2, "
            "the spring's stiffness and the tare as stated); the best-practice pendulum "
            "(estimation/pendulum.py: every half cycle fitted on the encoder's edges, Coulomb "
            "and viscous damping, amplitude extrapolation, the gravity stiffness from the RSP "
            "least squares' Gs, Gc; its std from its own budget); the same at RSP's time; "
            "RSP's node formula and its least squares. At RSP's time, the RSP passes' total duration is "
            "shared by the six pendulum runs in proportion to their periods (each log cut to "
            "its share). Experiment time: the physical duration of the runs "
            "each method needs, RSP's braking and reverse passes, the pendulum's six logged "
            "runs of [pendulum] duration; neither counts setting up, spin-up or deflection, and "
            "neither calibrates here: the virtual device's tares and stiffness are exactly "
            "device.toml's (errors in them: Sensitivity to calibration errors, below)."
        ),
        "",
        (
            "Cells: worst over the seeds of the worst relative J_k error over the axes, "
            "(the worst relative std the method reports), and the worst |error| / std. "
            "Pendulum cells marked * are over fewer axes: the runs friction stops within 3 "
            "oscillations (or, cut to RSP's time, with too few half cycles) are left out and "
            "named in the per-case notes."
        ),
        "",
        table,
        "",
        (
            "Tensor: worst entry error over the largest principal moment (worst over the "
            "seeds); a pendulum tensor needs all six runs."
        ),
        "",
        tensor_table(rows),
        "",
        "**Headline.** " + headline(rows),
        "",
        "Chart: accuracy.png. Timings: speed.md.",
        "",
        "## Per case",
        "",
        case_table(rows),
    ]
    if failed:
        accuracy += ["", f"{len(failed)} of {len(rows)} case(s) failed; the notes say why."]
    speed = [
        "# Speed: processing time against the experiment's physical duration",
        "",
        f"Command: `{command}`",
        "",
        (
            f"Wall-clock seconds on this machine ({os.cpu_count()} cores, shared by the cases "
            "that run in parallel and by whatever else runs). Per stage: smoothing "
            "(identification's UKF + RTS of the braking and reverse logs, and their balances), "
            "program generation (smoothing, mirror, nominal fit, OCP, LQR), closed loop (the "
            "virtual device running the program sample by sample, after regenerating the "
            "braking's end state). Identification: the whole identify step (smoothing "
            "included, then least squares, node formula and pendulum reduction). Processing = "
            "programs + identification: what a rig's computer does. Physical: the braking and "
            "reverse passes of all stages (pendulum runs not counted). Whole case: everything, "
            "the virtual device's simulation included (the demo's work)."
        ),
        "",
        speed_table(rows),
    ]
    paths = (out / "accuracy.md", out / "accuracy.png", out / "speed.md")
    if sensitivity:
        accuracy += [
            "",
            "## Sensitivity to calibration errors",
            "",
            (
                "The default case (friction x1, 16 bits, 3 mm, seed 0) with one constant off "
                "at a time (benchmarks/sensitivity.py): the pendulum's torsion stiffness in "
                "device.toml, the rig's torque gain (the logged torque over the applied one, "
                "device.toml says 1), the tares in device.toml; each identified with the "
                "constants stated exact (std 0) and with the error's size stated as their "
                "std. Chart: sensitivity.png."
            ),
            "",
            sensitivity_table(sensitivity),
        ]
        paths += (out / "sensitivity.png",)
        sensitivity_figure(sensitivity, paths[-1], command)
    write_atomic(paths[0], "\n".join(accuracy) + "\n")
    accuracy_figure(rows, paths[1], command)
    write_atomic(paths[2], "\n".join(speed) + "\n")
    return SweepReport(rows=rows, sensitivity=sensitivity, table=table, paths=paths)
