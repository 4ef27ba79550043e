"""The sweep's tables: accuracy per friction x bits x offset, tensor errors, per case, speed.

Each takes the rows of :func:`benchmarks.scheduling.run_sweep` (errors against the truth as
in :mod:`benchmarks.truth`, inputs and timings as in :func:`benchmarks.cases.run_case`) and
returns Markdown text.
"""

from __future__ import annotations

import numpy as np

from benchmarks.cases import DEFAULT_COM_MM
from benchmarks.tables import fmt, fmt_z, table_lines
from benchmarks.truth import METHODS
from rsp_inertia.checking import MIN_TURNS_PAST_LAST_NODE

__all__ = [
    "COMPARED",
    "accuracy_table",
    "case_table",
    "group_rows",
    "headline",
    "speed_table",
    "stat",
    "tensor_table",
]


def group_rows(rows: list[dict]) -> dict[tuple[float, int, float], list[dict]]:
    """Rows by (friction, bits, com mm), in case order."""
    groups: dict[tuple[float, int, float], list[dict]] = {}
    for row in sorted(rows, key=lambda r: (r["friction_factor"], r["encoder_bits"],
                                           r.get("com_mm", DEFAULT_COM_MM), r["seed"])):
        key = (row["friction_factor"], row["encoder_bits"], row.get("com_mm", DEFAULT_COM_MM))
        groups.setdefault(key, []).append(row)
    return groups


def stat(rows: list[dict], key: str) -> tuple[float | None, float | None]:
    """Mean and worst of ``key`` over the rows that have it."""
    values = [row[key] for row in rows if row.get(key) is not None]
    if not values:
        return None, None
    return float(np.mean(values)), float(np.max(values))


def _partial_pendulum(row: dict, suffix: str = "", best: bool = False) -> bool:
    """Whether the row's pendulum errors (``best``: the best practice's) cover fewer axes
    than the RSP ones."""
    key = f"pendulum_best_axes{suffix}" if best else f"pendulum_axes{suffix}"
    return row["error"] is None and row.get(key, 0) < row["axes"]


COMPARED = {
    "pendulum": "naive pendulum",
    "pendulum_best": "best-practice pendulum",
    "pendulum_best_equal": "best-practice pendulum at RSP's time",
    "node": "RSP node formula",
    "ls": "RSP least squares",
}
"""The comparison table's methods, in its column order."""


def accuracy_table(rows: list[dict]) -> str:
    """Markdown: the comparison, one row per friction x bits x com offset.

    Per method, worst over the seeds of: the worst relative J_k error over the axes, the
    worst relative std the method reports, and the worst |error| / std. A pendulum cell
    marked * is over fewer axes than six (runs friction stopped too early, said in the
    per-case notes).
    """
    head = ["friction x", "bits", "com mm", "cases ok", "experiment s RSP / pendulum"]
    head += [f"{name}: J_k err (std) worst err/std" for name in COMPARED.values()]
    lines = table_lines(head, [])
    for (factor, bits, com), group in group_rows(rows).items():
        ok = [row for row in group if row["error"] is None]
        rsp_time = stat(ok, "experiment_time_rsp")[0]
        pend_time = stat(ok, "experiment_time_pendulum")[0]
        cells = [f"{factor:g}", f"{bits}", f"{com:g}", f"{len(ok)}/{len(group)}",
                 f"{fmt(rsp_time, '.0f')} / {fmt(pend_time, '.0f')}"]
        for key in COMPARED:
            err, std, z = (stat(ok, f"{kind}_Jk_{key}")[1] for kind in ("err", "std", "z"))
            suffix = "_equal" if key.endswith("_equal") else ""
            mark = "*" if key.startswith("pendulum") and any(
                _partial_pendulum(row, suffix, best="best" in key) for row in ok) else ""
            cells.append(f"{fmt(err)} ({fmt(std)}) {fmt_z(z)}{mark}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def tensor_table(rows: list[dict]) -> str:
    """Markdown: worst over the seeds of each method's worst tensor-entry error over the
    largest principal moment, and the centre of mass's error."""
    head = ["friction x", "bits", "com mm"] + [f"{name} tensor" for name in COMPARED.values()]
    head += ["RSP com mm"]
    lines = table_lines(head, [])
    for (factor, bits, com), group in group_rows(rows).items():
        ok = [row for row in group if row["error"] is None]
        cells = [f"{factor:g}", f"{bits}", f"{com:g}"]
        cells += [fmt(stat(ok, f"err_tensor_{key}")[1]) for key in COMPARED]
        cells.append(fmt(stat(ok, "com_error_mm")[1]))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def headline(rows: list[dict]) -> str:
    """One paragraph: RSP least squares' worst J_k error against the best-practice pendulum's,
    at the default protocols and at equal time, over the cases where both have all six axes;
    and where the pendulum is as good or better."""
    ok = [r for r in rows if r["error"] is None and r.get("err_Jk_pendulum_best") is not None
          and not _partial_pendulum(r, best=True)]
    if not ok:
        return "No case has both methods on all six axes."
    ratio = np.array([r["err_Jk_pendulum_best"] / r["err_Jk_ls"] for r in ok])
    both = [r for r in ok if r.get("err_Jk_pendulum_best_equal") is not None
            and not _partial_pendulum(r, "_equal", best=True)]
    equal = np.array([r["err_Jk_pendulum_best_equal"] / r["err_Jk_ls"] for r in both])
    at_least = [r["case"] for r in ok if r["err_Jk_pendulum_best"] <= r["err_Jk_ls"]]
    at_least += [f"{r['case']} (at RSP's time)" for r in both
                 if r["err_Jk_pendulum_best_equal"] <= r["err_Jk_ls"]]
    text = (
        f"Over the {len(ok)} cases where both have all six axes, the best-practice pendulum's "
        f"worst J_k error is {np.median(ratio):.0f}x RSP least squares' (median; "
        f"{ratio.min():.1f}x to {ratio.max():.0f}x) with each method's default protocol "
    )
    rsp_time = np.median([r["experiment_time_rsp"] for r in ok])
    pend_time = np.median([r["experiment_time_pendulum"] for r in ok])
    text += f"(RSP {rsp_time:.0f} s of runs, the pendulum {pend_time:.0f} s)"
    if equal.size:
        text += (
            f", and {np.median(equal):.0f}x ({equal.min():.1f}x to {equal.max():.0f}x) with the "
            f"pendulum's runs cut to RSP's time ({equal.size} cases with all six axes)"
        )
    text += ". "
    if at_least:
        text += "The pendulum is as good or better in: " + ", ".join(at_least) + "."
    else:
        text += "In no case is the pendulum as good as RSP's least squares."
    return text


def case_table(rows: list[dict]) -> str:
    """Markdown: every case, its protocol and errors; then the notes (failures, short runs)."""
    head = ["case", "launch speeds rad/s", "braking torques N m", "turns past last node"]
    head += [f"{name} J_k" for name in METHODS.values()]
    head += [f"{name} tensor" for name in METHODS.values()]
    head += ["best practice at RSP's time J_k", "experiment s RSP / pendulum / cut"]
    head += ["com mm", "pendulum axes", "RSP LS worst |err|/std", "pendulum best worst |err|/std",
             "warnings"]
    lines = table_lines(head, [])
    notes = []
    for row in rows:
        if row["error"] is not None:
            lines.append(f"| {row['case']} | failed |" + " |" * (len(head) - 2))
            notes.append(f"- {row['case']}: failed: {row['error']}")
            continue
        stages = sorted(int(k.rsplit("_", 1)[1]) for k in row if k.startswith("launch_speed_"))
        cells = [
            row["case"],
            ", ".join(f"{row[f'launch_speed_{s}']:g}" for s in stages),
            ", ".join(f"{row[f'braking_torque_{s}']:g}" for s in stages),
            ", ".join(f"{row[f'turns_past_last_node_{s}']:.2f}" for s in stages),
        ]
        cells += [fmt(row[f"err_Jk_{k}"]) for k in METHODS]
        cells += [fmt(row[f"err_tensor_{k}"]) for k in METHODS]
        cells.append(fmt(row.get("err_Jk_pendulum_best_equal")))
        cells.append(" / ".join(
            fmt(row.get(f"experiment_time_{k}"), ".0f")
            for k in ("rsp", "pendulum", "pendulum_equal")
        ))
        cells += [fmt(row["com_error_mm"]), f"{row['pendulum_axes']}/{row['axes']}"]
        z = row.get("z_Jk_ls")
        warned = len(row["warnings"].split("; ")) if row["warnings"] else 0
        zb = row.get("z_Jk_pendulum_best")
        cells += ["" if z is None else f"{z:.1f}", "" if zb is None else f"{zb:.1f}", str(warned)]
        lines.append("| " + " | ".join(cells) + " |")
        short = [s for s in stages if row[f"short_protocol_{s}"]]
        if short:
            notes.append(
                f"- {row['case']}: stage(s) {', '.join(map(str, short))}: fewer than "
                f"{MIN_TURNS_PAST_LAST_NODE:g} braking turns past the last node within the "
                "torque margin; the longest braking found was used"
            )
        if row["pendulum_failures"]:
            notes.append(f"- {row['case']}: pendulum runs left out: {row['pendulum_failures']}")
        if row.get("pendulum_failures_equal"):
            notes.append(
                f"- {row['case']}: at RSP's time, pendulum runs left out or not reduced by the "
                f"best practice: {row['pendulum_failures_equal'][:400]}"
            )
        if row["warnings"]:
            notes.append(f"- {row['case']}: warnings: {row['warnings'][:300]}")
    if notes:
        lines += ["", "Notes:", "", *notes]
    return "\n".join(lines)


def speed_table(rows: list[dict]) -> str:
    """Markdown: every successful case's wall-clock times and their ratios to the physical
    duration, then their means."""
    ok = [row for row in rows if row["error"] is None]
    if not ok:
        return "(no successful case)"
    stages = sorted(int(k.rsplit("_", 1)[1]) for k in ok[0] if k.startswith("time_program_"))
    columns = [("physical s", "physical_duration", ".1f")]
    for label, key in (("smoothing", "smoothing"), ("program", "program"),
                       ("closed loop", "closed_loop")):
        columns += [(f"{label} {s} s", f"time_{key}_{s}", ".2f") for s in stages]
    columns += [
        ("pendulum runs s", "time_pendulum_runs", ".2f"),
        ("identification s", "time_identify", ".2f"),
        ("processing s", "time_processing", ".2f"),
        ("whole case s", "time_case", ".1f"),
        ("processing / physical", "ratio_processing", ".3f"),
        ("case / physical", "ratio_case", ".3f"),
    ]
    lines = [
        "| case | " + " | ".join(c[0] for c in columns) + " |",
        "|" + "---|" * (len(columns) + 1),
    ]
    for row in ok:
        lines.append(
            f"| {row['case']} | " + " | ".join(format(row[k], f) for _, k, f in columns) + " |"
        )
    means = [format(float(np.mean([row[k] for row in ok])), f) for _, k, f in columns]
    lines.append("| **mean** | " + " | ".join(means) + " |")
    return "\n".join(lines)
