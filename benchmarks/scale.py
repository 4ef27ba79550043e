"""Scale: wall time and peak memory of simulate, program, identify and calibrate against the
logs' length (issue 22).

Two series on the virtual device, each point a fresh experiment folder in which the installed
command line (``rsp-inertia`` beside this Python) runs ``simulate --part braking``,
``program``, ``simulate --part reverse``, ``identify`` and ``calibrate`` (the point's logs
taken as an empty fixture's), each in its own process:

- braking length: the default experiment with its friction (a1, a2 and a3) scaled down and
  stage 1's braking torque lowered so that stage 1's braking lasts 10 s to 590 s, up to
  several hundred turns, at 1 kHz. A tenth of the paper's friction stops the braking within
  about 195 s even with no braking torque (the quadratic drag does), so the longer brakings
  take three hundredths. The torques (BRAKINGS in benchmarks/scale.py) were found by a
  bisection on the simulated braking alone (``--find-torques`` repeats it);
- sample rate: the default experiment logged at 1, 2, 5 and 10 kHz (device.toml [encoder]
  sample_rate);
- logger's format (issue 35): the default experiment at 10 kHz logged as NI TDMS and as
  Parquet (device.toml [log] format), against the CSV point of the sample-rate series.

Per command: its wall time and its peak resident memory (the child's ``ru_maxrss`` from
``os.wait4``, taken by a small launcher process so that the benchmark's own memory does not
count). Per point: the logs' physical duration (every braking and reverse pass), turns and
rows, and the balance equations of identify (result.json ``least_squares.equations``).
Each series' growth exponents are the slopes of log cost against log turns and log rows over
the larger half of its points, where the fixed start-up costs weigh least. Deterministic:
the default virtual.toml's seed.

Targets (issue 22): identify's and calibrate's exponents <= 1.1 in turns and rows; a 590 s
stage-1 braking at 1 kHz identified within 0.1 of the logs' duration and under 1.5 GB; the
default experiment at 10 kHz within 0.3 of its duration and under 1.5 GB; with
``--long-fast``, the 590 s braking at 10 kHz under 1.5 GB.

    python -m benchmarks.scale [--quick] [--max-braking S] [--long-fast] [--out MD]

Writes benchmarks/results/scale.md, and beside it scale.json (the raw numbers, the command,
its duration; ``--from-json`` rewrites the report from it) and scale.png (log-log).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks import RESULTS
from benchmarks.experiments import default_experiment, load, with_stage
from benchmarks.tables import command_line, fmt, table_lines
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.virtual.config import Virtual

BRAKINGS = (
    (10.0, 0.1, 0.04323),
    (20.0, 0.1, 0.01663),
    (30.0, 0.1, 0.009951),
    (60.0, 0.1, 0.003291),
    (120.0, 0.1, 0.0007071),
    (170.0, 0.1, 0.0001238),
    (300.0, 0.03, 0.0004345),
    (590.0, 0.03, 2.4e-05),
)
"""(stage 1's braking s, friction factor, stage 1's braking torque N m): the braking series,
the torques found by :func:`find_torque` (``python -m benchmarks.scale --find-torques``:
brakings of 10.0, 20.1, 29.9, 59.8, 119.8, 170.5, 298.5 and 588.9 s)."""

RATES = (1000.0, 2000.0, 5000.0, 10000.0)
"""Hz: the sample-rate series, on the default experiment."""

FORMATS = ("tdms", "parquet")
"""device.toml ``[log] format`` of the format series, at ``FORMAT_RATE``."""

FORMAT_RATE = 10000.0
"""Hz: the format series' sample rate (the sample-rate series' last point is its CSV)."""

QUICK_BRAKING = 30.0
"""s: ``--quick`` keeps the brakings up to this long and the rates up to 2 kHz."""

LONG_FAST_RATE = 10000.0
"""Hz: ``--long-fast``'s longest braking logged at this rate."""

DURATION_TOLERANCE = 0.01
"""Relative: find_torque stops when the braking lasts the target within this."""

COMMANDS = {
    "simulate braking": ["simulate", "{exp}", "--part", "braking"],
    "program": ["program", "{exp}"],
    "simulate reverse": ["simulate", "{exp}", "--part", "reverse"],
    "identify": ["identify", "{exp}"],
    "calibrate": ["calibrate", "{scratch}", "--empty", "{exp}"],
}
"""The command lines timed, in the order an experiment runs them. ``calibrate`` takes the
point's own logs as an empty-fixture calibration (into a scratch folder that holds only
device.toml, so that identify's result stays the uncalibrated one): the numbers it writes
mean nothing, but its work is a calibration's on logs of this length."""

EXPONENT_TARGET = 1.1
"""identify's growth exponents in turns and rows (issue 22)."""

MEMORY_TARGET = 1.5
"""GB of peak memory for identify (issue 22)."""

SPEED_TARGETS = {"braking": 0.1, "rate": 0.3}
"""identify's wall time over the logs' duration: the longest braking at 1 kHz, the default
experiment at 10 kHz (issue 22)."""


# --- the experiments --------------------------------------------------------------------------


def scaled_friction(virtual: Virtual, factor: float) -> Virtual:
    """Every friction coefficient (Coulomb a1, viscous a2, quadratic a3) times ``factor``."""
    f = virtual.friction
    scaled = {k: v * factor for k, v in FRICTION.fields_of(f).items()}
    return replace(virtual, friction=replace(f, **scaled))


def at_rate(device: Device, rate: float) -> Device:
    """The encoder logging at ``rate`` Hz."""
    return replace(device, encoder=replace(device.encoder, sample_rate=rate))


def in_format(device: Device, log_format: str) -> Device:
    """The rig's logger writing ``log_format`` (device.toml ``[log] format``)."""
    return replace(device, log=replace(device.log, format=log_format))


def braking_experiment(root: Path, friction: float, torque: float, rate: float = 1000.0) -> Path:
    """The default experiment with its friction times ``friction``, stage 1's braking torque
    ``torque`` N m, logged at ``rate`` Hz."""
    return default_experiment(
        root,
        lambda d: at_rate(with_stage(d, 1, braking_torque=torque), rate),
        lambda v: scaled_friction(v, friction),
    )


def braking_duration(device: Device, virtual: Virtual, torque: float) -> float:
    """s: stage 1's simulated braking under ``torque`` (inf if it does not stop in time)."""
    from rsp_inertia.virtual.device import simulate_braking

    try:
        log = simulate_braking(with_stage(device, 1, braking_torque=torque), 1, virtual).log
    except InputError:
        return math.inf
    return float(log.t[-1] - log.t[0])


def find_torque(device: Device, virtual: Virtual, target: float) -> tuple[float, float]:
    """(torque N m, duration s): stage 1's braking torque, to four significant digits, under
    which its braking lasts ``target`` s within DURATION_TOLERANCE, by bisection on log torque
    (the duration falls as the torque rises).

    Raises
    ------
    ValueError
        No torque in [1e-6, 0.5] N m gives the target: the friction alone stops it sooner,
        or even the largest torque leaves it longer.
    """
    lo, hi = 1e-6, 0.5
    if not braking_duration(device, virtual, hi) <= target <= braking_duration(device, virtual, lo):
        raise ValueError(f"no braking torque in [{lo}, {hi}] N m gives a {target} s braking")
    torque = math.sqrt(lo * hi)
    duration = braking_duration(device, virtual, torque)
    while abs(duration / target - 1) > DURATION_TOLERANCE / 2:
        lo, hi = (torque, hi) if duration > target else (lo, torque)
        torque = math.sqrt(lo * hi)
        duration = braking_duration(device, virtual, torque)
    torque = float(f"{torque:.4g}")
    return torque, braking_duration(device, virtual, torque)


def find_torques() -> list[tuple[float, float, float, float]]:
    """(target s, friction factor, torque N m, duration s) of every braking of BRAKINGS,
    found again."""
    with tempfile.TemporaryDirectory() as tmp:
        device, virtual = load(default_experiment(Path(tmp) / "exp"))
    found = []
    for target, friction, _ in BRAKINGS:
        torque, duration = find_torque(device, scaled_friction(virtual, friction), target)
        found.append((target, friction, torque, duration))
        print(f"    ({target}, {friction}, {torque:.4g}),  # {duration:.1f} s", flush=True)
    return found


# --- measuring ----------------------------------------------------------------------------------


def cli() -> Path:
    """The installed command line beside this Python (the project's virtualenv)."""
    return Path(sys.executable).parent / "rsp-inertia"


LAUNCHER = """
import json, os, subprocess, sys, time
with open(sys.argv[1], "ab") as out:
    t0 = time.perf_counter()
    child = subprocess.Popen(sys.argv[2:], stdout=out, stderr=subprocess.STDOUT)
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - t0
child.returncode = os.waitstatus_to_exitcode(status)
cpu = usage.ru_utime + usage.ru_stime
print(json.dumps([wall, cpu, usage.ru_maxrss, child.returncode]))
"""
"""A bare Python that runs one command line and prints [wall s, its CPU s, its ru_maxrss kB,
exit status]. A process started by exec inherits in its ru_maxrss the peak resident memory of the
process it was forked from (Linux records the old address space's peak at exec), so the
commands are not started from this benchmark's own process, whose peak grows as it reads
the logs, but from this small one (12 MB)."""


def run_command(argv: list[str], log: Path) -> dict:
    """{"wall": s, "cpu": s (user + system), "memory": GB of peak resident memory, "error":
    last output line or None} of one command line run in its own process (through LAUNCHER),
    its output appended to ``log``."""
    done = subprocess.run(
        [sys.executable, "-I", "-c", LAUNCHER, str(log), *argv],
        capture_output=True, text=True, check=True,
    )
    wall, cpu, maxrss, status = json.loads(done.stdout)
    error = None
    if status != 0:
        lines = log.read_text(errors="replace").strip().splitlines()
        error = f"exit {status}: " + (lines[-1] if lines else "")
    # ru_maxrss is in kB on Linux.
    return {"wall": wall, "cpu": cpu, "memory": maxrss * 1024 / 1e9, "error": error}


def log_sizes(root: Path) -> dict:
    """The experiment's logs: physical duration s, turns and rows of every braking and
    reverse pass, and stage 1's braking alone."""
    from rsp_inertia.estimation.runs import runs
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.plant.logs import read_device_log

    exp = open_experiment(root)
    sizes = {"duration": 0.0, "turns": 0.0, "rows": 0}
    for stage, direction in runs(exp.device):
        for kind, path in (("braking", exp.braking_path(stage, direction)),
                           ("reverse", exp.reverse_path(stage, direction))):
            log = read_device_log(path, exp.device, kind, direction)
            duration = float(log.t[-1] - log.t[0])
            turns = float(abs(log.phi[-1] - log.phi[0]) / (2 * math.pi))
            sizes["duration"] += duration
            sizes["turns"] += turns
            sizes["rows"] += len(log.t)
            if (stage, direction, kind) == (1, Direction.FORWARD, "braking"):
                sizes["braking1"], sizes["turns1"] = duration, turns
    return sizes


def measure(root: Path) -> dict:
    """Every command of COMMANDS on the experiment ``root``, then its logs' sizes and the
    balance equations; a failed command ends the point (its error recorded)."""
    row: dict = {"commands": {}}
    log = root / "commands.log"
    scratch = root.parent / "calibration-scratch"
    scratch.mkdir(exist_ok=True)
    shutil.copy(root / "device.toml", scratch / "device.toml")
    for name, args in COMMANDS.items():
        argv = [str(cli()), *(a.format(exp=root, scratch=scratch) for a in args)]
        result = run_command(argv, log)
        row["commands"][name] = result
        print(f"  {name}: {result['wall']:.1f} s (cpu {result['cpu']:.1f} s), "
              f"{result['memory']:.2f} GB"
              + (f" ({result['error']})" if result["error"] else ""), flush=True)
        if result["error"]:
            row["error"] = f"{name}: {result['error']}"
            break
        if name == "simulate reverse":
            row |= log_sizes(root)
    if "error" not in row:
        result = json.loads((root / "result.json").read_text())
        row["equations"] = result["least_squares"]["equations"]
    return row


def run_series(brakings, rates, long_fast: bool, formats=FORMATS) -> dict[str, list[dict]]:
    """The measured points: {"braking": [...], "rate": [...], "long": [...], "format": [...]}."""
    points: dict[str, list[dict]] = {"braking": [], "rate": [], "long": [], "format": []}
    todo = [("braking", {"target": t, "friction": f, "torque": q, "rate": 1000.0})
            for t, f, q in brakings]
    todo += [("rate", {"rate": r}) for r in rates]
    todo += [("format", {"rate": FORMAT_RATE, "format": f}) for f in formats]
    if long_fast:
        target, friction, torque = BRAKINGS[-1]
        todo.append(("long", {"target": target, "friction": friction, "torque": torque,
                              "rate": LONG_FAST_RATE}))
    for series, spec in todo:
        print(f"{series}: {spec}", flush=True)
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp) / "exp"
            if series == "rate":
                default_experiment(root, lambda d, r=spec["rate"]: at_rate(d, r))
            elif series == "format":
                default_experiment(
                    root, lambda d, r=spec["rate"], f=spec["format"]: in_format(at_rate(d, r), f)
                )
            else:
                braking_experiment(root, spec["friction"], spec["torque"], spec["rate"])
            points[series].append(spec | measure(root))
    return points


# --- report -------------------------------------------------------------------------------------


def exponent(points: list[dict], x: str, command: str, cost: str) -> float | None:
    """Slope of log ``cost`` of ``command`` against log ``x`` over the larger half of the
    points (at least two); None with fewer than two measured points."""
    done = sorted((p for p in points if command in p["commands"]
                   and not p["commands"][command]["error"] and x in p), key=lambda p: p[x])
    done = done[min(len(done) // 2, len(done) - 2):]
    if len(done) < 2 or done[0][x] == done[-1][x]:
        return None
    xs = np.log([p[x] for p in done])
    ys = np.log([p["commands"][command][cost] for p in done])
    return float(np.polyfit(xs, ys, 1)[0])


def _cost(point: dict, command: str) -> str:
    result = point["commands"].get(command)
    if result is None:
        return "-"
    if result["error"]:
        return f"failed after {result['wall']:.0f} s, {result['memory']:.2f} GB"
    return f"{result['wall']:.1f} s ({result['cpu']:.1f}), {result['memory']:.2f} GB"


def _ratio(point: dict) -> float | None:
    identify = point["commands"].get("identify")
    if identify is None or identify["error"] or "duration" not in point:
        return None
    return identify["wall"] / point["duration"]


def series_table(points: list[dict], first: list[str], cells) -> list[str]:
    head = [*first, "log s", "turns", "rows", "balance equations", *COMMANDS,
            "identify / log duration"]
    rows = []
    for p in points:
        rows.append([
            *cells(p),
            fmt(p.get("duration"), ".1f"), fmt(p.get("turns"), ".0f"),
            f"{p['rows']:,}" if "rows" in p else "-",
            f"{p['equations']:,}" if "equations" in p else "-",
            *(_cost(p, c) for c in COMMANDS), fmt(_ratio(p), ".3f"),
        ])
    return table_lines(head, rows)


COSTS = ("wall", "cpu", "memory")
"""What the exponents are fitted to: wall time, CPU time, peak memory."""

SIZES = {
    "in turns (braking series)": ("braking", "turns"),
    "in rows (braking series)": ("braking", "rows"),
    "in rows (sample-rate series)": ("rate", "rows"),
}
"""The exponents' columns: (series, size)."""


def exponents(points: dict[str, list[dict]]) -> dict[tuple[str, str], dict[str, float | None]]:
    """{(command, cost): {column of SIZES: exponent}}."""
    return {
        (c, cost): {k: exponent(points[series], x, c, cost) for k, (series, x) in SIZES.items()}
        for c in COMMANDS for cost in COSTS
    }


def targets(points: dict[str, list[dict]], slopes: dict) -> list[tuple[str, bool | None]]:
    """(text, met; None: not measured) of each target of issue 22."""
    out: list[tuple[str, bool | None]] = []
    for command in ("identify", "calibrate"):
        for key in ("in turns (braking series)", "in rows (sample-rate series)"):
            for cost, name in (("wall", "wall time"), ("memory", "memory")):
                value = slopes[command, cost][key]
                cpu = slopes[command, "cpu"][key]
                cpu = f" (CPU time {fmt(cpu, '.2f')})" if cost == "wall" else ""
                out.append(((f"{command}'s {name} exponent {key} {fmt(value, '.2f')}{cpu} <= "
                            f"{EXPONENT_TARGET}"),
                            None if value is None else value <= EXPONENT_TARGET))
    cases = (
        ("braking", max(points["braking"], key=lambda p: p["target"], default=None),
         "the longest stage-1 braking at 1 kHz"),
        ("rate", next((p for p in points["rate"] if p["rate"] == RATES[-1]), None),
         f"the default experiment at {RATES[-1] / 1000:g} kHz"),
    )
    for series, point, text in cases:
        limit = SPEED_TARGETS[series]
        if point is None:
            out.append(((f"{text}: identify within {limit} of the logs' duration and under "
                        f"{MEMORY_TARGET} GB"), None))
            continue
        ratio, memory = _ratio(point), point["commands"].get("identify", {}).get("memory")
        where = f" ({point['target']:g} s)" if series == "braking" else ""
        out.append((f"{text}{where}: identify / duration {fmt(ratio, '.3f')} <= {limit}",
                    ratio is not None and ratio <= limit))
        out.append(((f"{text}{where}: identify's peak memory {fmt(memory, '.2f')} GB < "
                    f"{MEMORY_TARGET} GB"), ratio is not None and memory < MEMORY_TARGET))
    long = points.get("long") or []
    for point in long:
        memory = point["commands"].get("identify", {}).get("memory")
        ok = "identify" in point["commands"] and not point["commands"]["identify"]["error"]
        out.append(((f"{point['target']:g} s stage-1 braking at {point['rate'] / 1000:g} kHz: "
                    f"identify's peak memory {fmt(memory, '.2f')} GB < {MEMORY_TARGET} GB"),
                    ok and memory < MEMORY_TARGET))
    if not long:
        out.append(((f"{BRAKINGS[-1][0]:g} s stage-1 braking at {LONG_FAST_RATE / 1000:g} kHz "
                    f"under {MEMORY_TARGET} GB (--long-fast)"), None))
    return out


def _mark(ok: bool | None) -> str:
    return {True: "PASS", False: "FAIL", None: "not measured"}[ok]


def _braking_cells(point: dict) -> list[str]:
    return [f"{point['torque']:.4g}", f"{point['friction']:g}",
            fmt(point.get("braking1"), ".1f"), fmt(point.get("turns1"), ".0f")]


def write_report(points: dict[str, list[dict]], command: str, seconds: float, out: Path) -> None:
    """scale.md and scale.png from the measured points."""
    slopes = exponents(points)
    lines = [
        "# Scale: time and memory against the logs' length",
        "",
        (f"Command: `{command}` ({seconds / 60:.0f} min on this machine, {os.cpu_count()} "
        "cores)."),
        "",
        __doc__.split("\n\n", 1)[1].split("    python")[0].strip(),
        "",
        ("Log s, turns and rows: every braking and reverse pass of the experiment together. "
         "Each command's cell: its wall time (its CPU time, user and system), its process's "
         "peak resident memory. Wall times depend on what else the machine runs; the CPU "
         "times less so."),
        "",
        "## Braking length (1 kHz)",
        "",
        *series_table(points["braking"],
                      ["stage-1 torque N m", "friction x", "stage-1 braking s",
                       "stage-1 turns"], _braking_cells),
        "",
        "## Sample rate (the default experiment)",
        "",
        *series_table(points["rate"], ["sample rate kHz"],
                      lambda p: [f"{p['rate'] / 1000:g}"]),
        "",
    ]
    if points.get("format"):
        csv = [p for p in points["rate"] if p["rate"] == FORMAT_RATE]
        lines += [
            f"## The logger's format (the default experiment at {FORMAT_RATE / 1000:g} kHz)",
            "",
            *series_table([{**p, "format": "csv"} for p in csv] + points["format"],
                          ["[log] format"], lambda p: [p["format"]]),
            "",
        ]
    if points.get("long"):
        lines += [
            f"## The longest braking at {LONG_FAST_RATE / 1000:g} kHz",
            "",
            *series_table(points["long"],
                          ["stage-1 torque N m", "friction x", "stage-1 braking s",
                           "stage-1 turns"], _braking_cells),
            "",
        ]
    lines += [
        "## Growth exponents",
        "",
        ("Slopes of log cost against log size over the larger half of each series' points; "
         f"identify's and calibrate's target is <= {EXPONENT_TARGET} in turns and rows "
         "(issue 22; program "
         "and simulate stay linear)."),
        "",
        *table_lines(["command", "cost", *SIZES],
                     [[c, cost, *(fmt(s[k], ".2f") for k in SIZES)]
                      for (c, cost), s in slopes.items()]),
        "",
        "## Targets",
        "",
        *[f"- {_mark(ok)}: {text}" for text, ok in targets(points, slopes)],
        "",
    ]
    failures = [(s, p) for s, ps in points.items() for p in ps if "error" in p]
    if failures:
        lines += ["## Failures", ""]
        lines += [f"- {s} {p.get('target', p.get('format', p['rate']))}: `{p['error']}`"
                  for s, p in failures]
        lines.append("")
    out.write_text("\n".join(lines))
    plot(points, out.with_suffix(".png"))


def plot(points: dict[str, list[dict]], path: Path) -> None:
    """Log-log: time and memory of each command against turns (braking series) and rows
    (sample-rate series), with a slope-1 line for reference."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    from rsp_inertia.plots import save_figure

    fig = Figure(figsize=(10, 8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 2)
    panels = (
        ("braking", "turns", "wall", "wall time s", "turns (braking series, 1 kHz)"),
        ("braking", "turns", "memory", "peak memory GB", "turns (braking series, 1 kHz)"),
        ("rate", "rows", "wall", "wall time s", "log rows (sample-rate series)"),
        ("rate", "rows", "memory", "peak memory GB", "log rows (sample-rate series)"),
    )
    for ax, (series, x, cost, ylabel, xlabel) in zip(axes.flat, panels):
        for command in COMMANDS:
            done = sorted((p for p in points[series] if x in p and command in p["commands"]
                           and not p["commands"][command]["error"]), key=lambda p: p[x])
            if done:
                ax.plot([p[x] for p in done], [p["commands"][command][cost] for p in done],
                        "o-", label=command)
        xs = [p[x] for p in points[series] if x in p]
        if len(xs) > 1:
            lo, hi = min(xs), max(xs)
            top = max(max(r[cost] for r in p["commands"].values()) for p in points[series])
            ax.plot([lo, hi], [top * lo / hi, top], "k:", label="slope 1")
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):  # labels at the decades only: the minor ones overlap
            axis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize="small")
    save_figure(fig, path)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.scale", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--quick", action="store_true",
        help=f"brakings up to {QUICK_BRAKING:g} s and rates up to 2 kHz (a few minutes)",
    )
    parser.add_argument(
        "--max-braking", type=float, default=None, metavar="S",
        help="only the brakings up to S seconds (default: all, up to 590 s)",
    )
    parser.add_argument(
        "--long-fast", action="store_true",
        help=f"also the longest braking at {LONG_FAST_RATE / 1000:g} kHz (slow to simulate)",
    )
    parser.add_argument(
        "--out", type=Path, default=RESULTS / "scale.md", metavar="MD",
        help="the report (default: benchmarks/results/scale.md); .json and .png beside it",
    )
    parser.add_argument(
        "--from-json", type=Path, metavar="JSON",
        help="rewrite the report from a run's saved numbers (the .json beside its report)",
    )
    parser.add_argument(
        "--find-torques", action="store_true",
        help="find stage 1's braking torques of BRAKINGS again (bisection) and print them",
    )
    args = parser.parse_args(argv)
    if args.find_torques:
        find_torques()
        return
    if args.from_json is not None:
        saved = json.loads(args.from_json.read_text())
        write_report(saved["points"], saved["command"], saved["seconds"], args.out)
        print(args.out.read_text())
        return
    longest = QUICK_BRAKING if args.quick else math.inf
    if args.max_braking is not None:
        longest = min(longest, args.max_braking)
    brakings = [b for b in BRAKINGS if b[0] <= longest]
    rates = [r for r in RATES if not args.quick or r <= 2000.0]
    t0 = time.perf_counter()
    points = run_series(brakings, rates, args.long_fast, () if args.quick else FORMATS)
    seconds = time.perf_counter() - t0
    command = command_line("scale", argv)
    saved = {"command": command, "seconds": seconds, "points": points}
    args.out.with_suffix(".json").write_text(json.dumps(saved, indent=1))
    write_report(points, command, seconds, args.out)
    print(args.out.read_text())


if __name__ == "__main__":
    main()
