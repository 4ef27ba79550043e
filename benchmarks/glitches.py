"""Glitches in the logs (issue 35): one corrupted row, found, named and left out.

    python -m benchmarks.glitches [--seeds N] [--run-seed S] [--jobs N] [--out DIR]

The default experiment (plant/defaults/: two stages, braking and ideal reverse logs) is
simulated once (with ``--run-seed``: its noise seed S and release angle,
benchmarks.experiments.seeded). Per seed, ``numpy.random.default_rng(seed)`` picks one of its four logs
(stage 1 or 2, braking or reverse), a row among those the detector tests (all but the
first and last rsp_inertia.plant.log_glitches.ANGLE_NEIGHBOURS), and the corruption: the
row's torque x 20, or its angle 40 counts up or down; a copy of the experiment gets that
one row changed, and identify runs on it twice: as it is, and with the detector switched
off (the row then taken as logged, as before issue 35). Targets, every seed: identify warns
naming the file and the row's line (no other glitch), and its tensor is the clean copy's
within 1 std in every entry (the row left out is one dropped sample). Reported too: each
entry's error against the truth (rsp_inertia.virtual.config.placed_body) over its std,
which the issue asks within 3 stds; the clean copy (no corruption, which must have no
glitch) sets what the simulation's own noise gives there (the default seed's Jxy is 3.0
stds off).

Writes DIR/glitches.md and DIR/glitches.json (default benchmarks/results).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from benchmarks import RESULTS
from benchmarks.tables import command_line

LOGS = ("stage1/braking.csv", "stage1/reverse.csv", "stage2/braking.csv", "stage2/reverse.csv")
"""The logs a seed may corrupt."""

ANGLE_COUNTS = 40
"""Counts by which a corrupted angle is off (up or down)."""

TORQUE_FACTOR = 20.0
"""Factor on a corrupted torque."""

MAX_SHIFT_STD = 1.0
"""The target: every entry of the tensor within this many of its stds of the clean copy's."""


def simulate_once(root: Path, run_seed: int | None = None) -> Path:
    """The default experiment with its braking and ideal reverse logs at ``root``
    (``run_seed``: its virtual device's seed, benchmarks.experiments.seeded)."""
    from benchmarks.experiments import seeded, vary
    from rsp_inertia.infra.progress import drop, lines_to
    from rsp_inertia.scenarios import create_default_experiment
    from rsp_inertia.simulating import simulate

    root = create_default_experiment(root)
    if run_seed is not None:
        vary(root, virtual=lambda v: seeded(v, run_seed))
    with lines_to(drop):
        simulate(root, part="braking")
        simulate(root, part="reverse", ideal=True)
    return root


def corruption(seed: int, source: Path) -> dict:
    """The log, row and change of ``seed`` (module docstring)."""
    from rsp_inertia.plant.log_glitches import ANGLE_NEIGHBOURS

    rng = np.random.default_rng(seed)
    log = LOGS[int(rng.integers(len(LOGS)))]
    with open(source / log) as file:
        rows = sum(1 for _ in file) - 1
    row = int(rng.integers(ANGLE_NEIGHBOURS, rows - ANGLE_NEIGHBOURS))
    column = "torque" if rng.uniform() < 0.5 else "phi"
    sign = 1 if rng.uniform() < 0.5 else -1
    return {"seed": seed, "log": log, "row": row, "line": row + 2, "column": column,
            "sign": sign}


def _corrupt(path: Path, row: int, column: str, sign: int, quantum: float) -> tuple[str, str]:
    """Data row ``row`` of the log changed; its value before and after."""
    lines = path.read_text().splitlines(keepends=True)
    t, phi, torque = lines[row + 1].rstrip("\n").split(",")
    if column == "torque":
        before, torque = torque, repr(TORQUE_FACTOR * float(torque))
        after = torque
    else:
        before, phi = phi, repr(float(phi) + sign * ANGLE_COUNTS * quantum)
        after = phi
    lines[row + 1] = f"{t},{phi},{torque}\n"
    path.write_text("".join(lines))
    return before, after


def _identify(root: Path, detector: bool) -> dict:
    """identify on ``root`` with the glitch detector on or off: the entries' errors over
    their stds and the warnings."""
    from rsp_inertia import api
    from rsp_inertia.infra.errors import InputError
    from rsp_inertia.plant import logs
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.plant.log_glitches import Glitches, find_glitches
    from rsp_inertia.virtual.config import experiment_virtual, placed_body

    def off(*args):
        return Glitches(rows=np.zeros(0, dtype=np.int64), warnings=())

    logs.find_glitches = find_glitches if detector else off
    try:
        result = api.identify(root)
    except InputError as error:
        return {"refused": str(error)}
    finally:
        logs.find_glitches = find_glitches
    exp = open_experiment(root)
    truth = placed_body(exp.device, experiment_virtual(exp)).inertia
    entries, std = np.asarray(result.entries), np.asarray(result.entries_std)
    return {
        "refused": None, "entries": entries.tolist(), "std": std.tolist(),
        "err_std": ((entries - truth) / std).tolist(), "warnings": list(result.warnings),
    }


def run_seed(seed: int | None, source: str, work: str) -> dict:
    """One seed (None: the clean copy) end to end in ``work``."""
    from rsp_inertia.plant.config import load_device

    start = time.perf_counter()
    source = Path(source)
    root = Path(shutil.copytree(source, Path(work) / f"seed-{seed}"))
    if seed is None:
        out = {"seed": None, "log": None, "line": None}
    else:
        out = corruption(seed, source)
        quantum = load_device(root / "device.toml").encoder.quantum
        out["before"], out["after"] = _corrupt(
            root / out["log"], out["row"], out["column"], out["sign"], quantum
        )
        out["undetected"] = _identify(root, detector=False)
    out["detected"] = _identify(root, detector=True)
    out["seconds"] = time.perf_counter() - start
    shutil.rmtree(root)
    return out


def named(row: dict) -> bool:
    """identify warned of exactly the corrupted row, naming its file and line."""
    warnings = row["detected"].get("warnings") or []
    glitches = [w for w in warnings if ": a glitch, " in w]
    if row["seed"] is None:
        return not glitches
    where = f"{row['log']}, line {row['line']}: a glitch, {row['column']} "
    return len(glitches) == 1 and where in glitches[0]


def shift(result: dict, clean: dict) -> float:
    """The largest change of an entry from the clean copy's, over its std (inf: refused)."""
    if result.get("refused") or clean.get("refused"):
        return float("inf")
    a, b = np.asarray(result["entries"]), np.asarray(clean["entries"])
    return float(np.max(np.abs(a - b) / np.asarray(result["std"])))


def verdict(row: dict, clean: dict) -> str:
    """pass: named, and the tensor the ``clean`` copy's result within MAX_SHIFT_STD stds."""
    if row["detected"]["refused"] or not named(row):
        return "FAIL"
    return "pass" if shift(row["detected"], clean) <= MAX_SHIFT_STD else "FAIL"


def _worst(result: dict) -> str:
    if result.get("refused"):
        return "refused"
    return f"{max(abs(e) for e in result['err_std']):.2f}"


def _shift(result: dict, clean: dict) -> str:
    value = shift(result, clean)
    return "refused" if value == float("inf") else f"{value:.2f}"


def report(rows: list[dict], command: str, seconds: float) -> str:
    """glitches.md."""
    lines = [
        "# Glitches: one corrupted row found, named and left out",
        "",
        (f"Made by `{command}` in {seconds:.0f} s (benchmarks/glitches.py; its docstring says "
         "how a seed corrupts a row). The default experiment, simulated once (braking and "
         f"ideal reverse logs); per seed one row of one log: its torque x {TORQUE_FACTOR:g} or "
         f"its angle {ANGLE_COUNTS} counts up or down. Target: identify names the file and "
         f"the line, and every tensor entry is the clean copy's within {MAX_SHIFT_STD:g} std "
         "(*shift*: the largest |change| / std). *err/std*: the largest |error| / std against "
         "the truth (the issue asks 3). *Without the detector*: the same file read as before "
         "issue 35 (the row taken as logged)."),
        "",
        ("| seed | log | line | corruption | named | shift | err/std | without the detector: "
         "shift | err/std | verdict | s |"),
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    clean = rows[0]["detected"]
    for row in rows:
        if row["seed"] is None:
            what, without = "none (the clean copy)", " | "
        else:
            what = f"{row['column']} {row['before']} -> {row['after']}"
            without = f"{_shift(row['undetected'], clean)} | {_worst(row['undetected'])}"
        lines.append(
            f"| {row['seed'] if row['seed'] is not None else 'clean'} | {row['log'] or 'all'} "
            f"| {row['line'] or ''} | {what} | {'yes' if named(row) else 'NO'} | "
            f"{_shift(row['detected'], clean)} | {_worst(row['detected'])} | {without} | "
            f"{verdict(row, clean)} | {row['seconds']:.0f} |"
        )
    seeded = rows[1:]
    passed = sum(verdict(r, clean) == "pass" for r in seeded)
    found = sum(named(r) for r in seeded)
    shifts = [shift(r["detected"], clean) for r in seeded]
    worst = max(float(_worst(r["detected"])) for r in seeded if not r["detected"]["refused"])
    within = sum(
        not r["detected"]["refused"] and float(_worst(r["detected"])) <= 3.0 for r in seeded
    )
    undetected = [shift(r["undetected"], clean) for r in seeded]
    taken = [s for s in undetected if s != float("inf")]
    lines += [
        "",
        f"{passed} of {len(seeded)} seeds met the target; {found} of {len(seeded)} named the "
        f"corrupted row's file and line (and no other); largest shift with the detector "
        f"{max(shifts):.2f} std. Without it, {len(undetected) - len(taken)} seeds refused "
        "(an angle glitch in a braking: refused as a speed that reverses) "
        f"and the others shifted by up to {max(taken, default=0.0):.1f} std (median "
        f"{float(np.median(taken)) if taken else 0.0:.2f}). Against the truth: largest |err|/std with the "
        f"detector {worst:.2f}, {within} of {len(seeded)} seeds within 3; the clean copy "
        f"{_worst(clean)}. The clean copy: "
        + ("no glitch." if named(rows[0]) else "GLITCHES FOUND (false alarm)."),
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.glitches", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--seeds", type=int, default=20, help="seeds (20)")
    parser.add_argument(
        "--run-seed", type=int, default=None,
        help="the simulation's noise seed (default: virtual.toml's, 0, and its release angle)",
    )
    parser.add_argument("--jobs", type=int, default=2, help="processes (2)")
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder (benchmarks/results)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as work, ProcessPoolExecutor(args.jobs) as pool:
        source = simulate_once(Path(work) / "default", args.run_seed)
        seeds = [None, *range(args.seeds)]
        futures = [pool.submit(run_seed, seed, str(source), work) for seed in seeds]
        rows = []
        for future in futures:
            # Messages name the scratch folder: WORK in the files, which do not depend on it.
            text = json.dumps(future.result()).replace(str(Path(work)) + "/", "WORK/")
            rows.append(json.loads(text))
            row = rows[-1]
            print(f"seed {row['seed']}: {verdict(row, rows[0]['detected'])}", file=sys.stderr)
    seconds = time.perf_counter() - start
    args.out.mkdir(parents=True, exist_ok=True)
    command = command_line("glitches", argv if argv is not None else sys.argv[1:])
    (args.out / "glitches.md").write_text(report(rows, command, seconds))
    (args.out / "glitches.json").write_text(json.dumps(rows, indent=1) + "\n")
    print(f"-> {args.out / 'glitches.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
