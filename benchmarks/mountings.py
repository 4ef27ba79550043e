"""Combining mountings on the virtual device: accuracy, honesty and the misalignment test.

    python -m benchmarks.mountings [--seeds N] [--misaligned N] [--jobs N] [--out DIR]

The body of the default experiment with its centre of mass at (3, -2, 4) mm in body axes;
each mounting is the default experiment (both stages forward, ideal reverse: the
combination's own behaviour, not the closed loop's; its release angle jittered by up to
RELEASE_JITTER_DEG) identified as usual, its device.toml's
``[mounting]`` stating how the body sits: the first as drawn (identity), the second turned
90 deg about x, so that body z lies along rig y and the gravity terms see it. Per seed
(the virtual device's noise seed):

- **accuracy**: the two mountings combined; each body-axes entry's and each centre-of-mass
  coordinate's error against the virtual body, in stds and absolute, and the tensor's stds
  against one mounting's;
- **misalignment**: the second mounting again, its body turned by 0.5 deg about x, y or z
  (in turn) from what its device.toml states (virtual.toml ``[mounting] misalignment_deg``):
  does ``combine`` warn? And does it stay quiet on the correct pair (false alarms)?
- **speed**: ``combine`` of 2 and of 10 mountings (the pair's results repeated), wall time.

Writes DIR/mountings.md and DIR/mountings.json (default benchmarks/results).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from benchmarks.tables import command_line

COM_MM = (3.0, -2.0, 4.0)
"""The body's centre of mass in body axes, mm (the issue's)."""

TURNED_X90 = ((1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0))
"""The second mounting: body axes -> rig axes, the body turned 90 deg about x."""

MISALIGNMENT_DEG = 0.5
"""How far the misaligned mounting's body is turned from what its device.toml states."""

ENTRIES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")


def _set(text: str, key: str, value: str) -> str:
    text, count = re.subn(rf"(?m)^{key}\s*=\s*[^#\n]*", f"{key} = {value} ", text)
    assert count == 1, f"no single {key}"
    return text


RELEASE_JITTER_DEG = 0.5
"""Each mounting's release angle is drawn uniformly within this of the default's (seeded): a
new experiment's encoder counts fall elsewhere, so its quantization errors are its own (with
one release angle for every seed they repeat, and the seeds' errors do not scatter as
independent experiments' do; tests/estimation/test_uncertainty.py does the same)."""


def _mounting(folder: Path, seed: int, rotation, misalignment: tuple | None) -> dict:
    """One mounting identified (the virtual device's noise seed ``seed``, its release angle
    drawn from it); its folder and timings."""
    from rsp_inertia.identifying import identify
    from rsp_inertia.scenarios import create_default_experiment
    from rsp_inertia.simulating import simulate

    root = create_default_experiment(folder)
    virtual = root / "virtual.toml"
    text = _set(virtual.read_text(), "seed", str(seed))
    default = float(re.search(r"(?m)^release_angle_deg\s*=\s*([-\d.eE+]+)", text).group(1))
    jitter = np.random.default_rng(seed).uniform(-1.0, 1.0) * RELEASE_JITTER_DEG
    text = _set(text, "release_angle_deg", repr(default + jitter))
    text = _set(text, "com", "[" + ", ".join(f"{c * 1e-3!r}" for c in COM_MM) + "]")
    if misalignment is not None:
        text += f"\n[mounting]\nmisalignment_deg = {list(misalignment)!r}\n"
    virtual.write_text(text)
    rows = ", ".join("[" + ", ".join(repr(float(c)) for c in row) + "]" for row in rotation)
    with open(root / "device.toml", "a") as file:
        file.write(f"\n[mounting]\nrotation = [{rows}]\norigin = [0.0, 0.0, 0.0]\n")
    start = time.perf_counter()
    simulate(root, part="braking")
    simulate(root, part="reverse", ideal=True)
    identify(root)
    return {"folder": str(root), "seconds": time.perf_counter() - start}


def run_seed(seed: int, work: str, misaligned: bool, accuracy: bool) -> dict:
    """Seed ``seed``'s mountings and combinations (one process: its own folders)."""
    from rsp_inertia.api import combine
    from rsp_inertia.virtual.config import load_virtual

    base = Path(work) / f"seed{seed}"
    first = _mounting(base / "m1", seed, np.eye(3), None)
    second = _mounting(base / "m2", seed + 1000, TURNED_X90, None)
    body = load_virtual(Path(first["folder"]) / "virtual.toml").body
    row: dict = {"seed": seed, "identify_seconds": [first["seconds"], second["seconds"]]}
    pair = combine([first["folder"], second["folder"]], base / "body")
    c = pair.combination
    row["correct_warned"] = bool(c.warnings)
    row["correct_p"] = float(c.p)
    if accuracy:
        single = json.loads((Path(first["folder"]) / "result.json").read_text())
        row["entries_err"] = (c.entries - body.inertia).tolist()
        row["entries_std"] = np.asarray(c.entries_std).tolist()
        row["single_std"] = [single["tensor_std"][k] for k in ENTRIES]
        row["com_err"] = (c.com - body.com).tolist()
        row["com_std"] = np.asarray(c.com_std).tolist()
    if misaligned:
        axis = seed % 3
        angles = [0.0, 0.0, 0.0]
        angles[axis] = MISALIGNMENT_DEG
        bad = _mounting(base / "m2bad", seed + 1000, TURNED_X90, tuple(angles))
        wrong = combine([first["folder"], bad["folder"]], base / "bad").combination
        row["misaligned_axis"] = "xyz"[axis]
        row["misaligned_warned"] = bool(wrong.warnings)
        row["misaligned_p"] = float(wrong.p)
    return row


def speed(folders: list[str], work: Path) -> dict[str, float]:
    """Wall time of combine for 2 and 10 mountings (the pair's folders copied, each copy a
    mounting of its own): the API call once the package is imported (reading result.json
    and device.toml, hashing the logs against the provenance, writing body.json), and the
    command line as a user runs it (a new process: Python's start and the imports too)."""
    import shutil
    import subprocess

    from rsp_inertia.api import combine

    combine(folders, work / "warm")  # the imports, once
    times = {}
    for n in (2, 10):
        copies = []
        for k in range(n):
            target = work / f"speed{n}" / f"m{k}"
            shutil.copytree(folders[k % 2], target)
            copies.append(str(target))
        start = time.perf_counter()
        combine(copies, work / f"speed{n}" / "body")
        times[f"api {n}"] = time.perf_counter() - start
        command = [sys.executable, "-m", "rsp_inertia.cli", "combine", *copies, "--out",
                   str(work / f"speed{n}" / "cli")]
        start = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        times[f"command line {n}"] = time.perf_counter() - start
    return times


def report(rows: list[dict], times: dict[str, float], command: str) -> str:
    """The Markdown report.

    Parameters
    ----------
    rows : list of dict
        One per seed, from :func:`run_seed`.
    times : dict of str to float
        Seconds of ``combine``, from :func:`speed`.
    command : str
        The command line that made them, written at the top.

    Returns
    -------
    str
        The report's text (mountings.md).
    """
    acc = [r for r in rows if "entries_err" in r]
    mis = [r for r in rows if "misaligned_warned" in r]
    lines = [
        "# Combining mountings (virtual device)",
        "",
        f"Command: `{command}`",
        "",
        (f"Seeds: {len(acc)} for accuracy, {len(mis)} for the misalignment test. Body centre "
        f"of mass at {COM_MM} mm in body axes; mounting 1 as drawn, mounting 2 turned 90 deg "
        "about x; default experiment, ideal reverse, each mounting's release angle within "
        f"{RELEASE_JITTER_DEG} deg of the default's."),
        "",
    ]
    if acc:
        err = np.array([r["entries_err"] for r in acc])
        std = np.array([r["entries_std"] for r in acc])
        single = np.array([r["single_std"] for r in acc])
        com_err = np.array([r["com_err"] for r in acc]) * 1e3
        com_std = np.array([r["com_std"] for r in acc]) * 1e3
        largest = 0.028
        lines += [
            "## Accuracy (two mountings combined)",
            "",
            ("| quantity | worst abs error | worst error / largest moment or mm | worst |err|/std | "
            "mean (err/std)^2 | std / one mounting's |"),
            "|---|---|---|---|---|---|",
        ]
        for k, name in enumerate(ENTRIES):
            z = err[:, k] / std[:, k]
            lines.append(
                f"| {name} | {np.abs(err[:, k]).max():.2e} kg m^2 | "
                f"{np.abs(err[:, k]).max() / largest:.1e} | {np.abs(z).max():.2f} | "
                f"{np.mean(z ** 2):.2f} | {np.median(std[:, k] / single[:, k]):.3f} |"
            )
        for k, name in enumerate("xyz"):
            z = com_err[:, k] / com_std[:, k]
            lines.append(
                f"| com {name} | {np.abs(com_err[:, k]).max():.2e} mm | "
                f"{np.abs(com_err[:, k]).max():.1e} mm | {np.abs(z).max():.2f} | "
                f"{np.mean(z ** 2):.2f} | |"
            )
        lines.append("")
    correct = [r["correct_warned"] for r in rows]
    correct_p = ", ".join(format(r["correct_p"], ".2g") for r in rows)
    lines += [
        "## The consistency test",
        "",
        (f"- correct mountings: {sum(correct)} warning(s) in {len(correct)} seeds "
        f"(p: {correct_p})"),
    ]
    if mis:
        warned = sum(r["misaligned_warned"] for r in mis)
        mis_p = ", ".join(f"{r['misaligned_axis']} {r['misaligned_p']:.2g}" for r in mis)
        lines.append(
            f"- mounting 2 turned {MISALIGNMENT_DEG} deg about x, y or z from its stated "
            f"rotation: {warned} warning(s) in {len(mis)} seeds (axis and p: {mis_p})"
        )
    lines += [
        "",
        "## Speed",
        "",
        *(f"- combine, {what} mountings: {t:.2f} s" for what, t in times.items()),
        ("  (api: the call once the package is imported, reading result.json and device.toml, "
        "hashing the logs against the provenance, writing body.json; command line: "
        "`rsp-inertia combine` in a new process, Python's start and the imports included)"),
        (f"- identify of one mounting: median "
        f"{np.median([s for r in rows for s in r['identify_seconds']]):.1f} s"),
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.mountings")
    parser.add_argument("--seeds", type=int, default=10, help="seeds for accuracy (10)")
    parser.add_argument("--misaligned", type=int, default=20,
                        help="seeds for the misalignment test (20)")
    parser.add_argument("--jobs", type=int, default=2, help="processes (2)")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = parser.parse_args(argv)
    n = max(args.seeds, args.misaligned)
    with tempfile.TemporaryDirectory(prefix="rsp-mountings-") as work:
        with ProcessPoolExecutor(args.jobs) as pool:
            futures = [
                pool.submit(run_seed, seed, work, seed < args.misaligned, seed < args.seeds)
                for seed in range(n)
            ]
            rows = []
            for future in futures:
                rows.append(future.result())
                print(f"seed {rows[-1]['seed']} done", file=sys.stderr, flush=True)
        seed0 = Path(work) / "seed0"
        times = speed([str(seed0 / "m1"), str(seed0 / "m2")], Path(work))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "mountings.json").write_text(json.dumps({"rows": rows, "combine_seconds": times},
                                                        indent=2) + "\n")
    text = report(rows, times, command_line("mountings", argv))
    (args.out / "mountings.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
