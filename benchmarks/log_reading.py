"""Log reading: rows per second of every logger's format and dialect, checks included
(issue 35).

One synthetic braking-like log of ``--rows`` rows (default 3 million: 50 min at 1 kHz) on
the default encoder (16 bits, 1 kHz, a 32-bit counter), its stamps jittered by a fifth of a
period, its torque noisy, its motor warming, is written once in each layout of LAYOUTS
(rsp_inertia.plant.logs.write_log) and read back by ``read_log`` with every check a device
gives (torque limit, launch speed: rsp_inertia.plant.logs.read_device_log's), the best of
``--repeat`` reads timed. Each read is checked to give the written log (the angle bit for
bit, time and torque within the layouts' rounding). The target: every format at least as
fast as the plain CSV reader, and memory linear in rows (the peak of the Python heap while
reading, tracemalloc, over the rows: bytes per row).

    python -m benchmarks.log_reading [--rows N] [--repeat K] [--out MD]

Writes benchmarks/results/log_reading.md with the command that made it.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from benchmarks import RESULTS
from benchmarks.tables import command_line, table_lines
from rsp_inertia.plant.config import Encoder, LogLayout
from rsp_inertia.plant.logs import Log, read_log, write_log

ENCODER = Encoder(counts_per_rev=65536, sample_rate=1000.0, counter_bits=32)
TORQUE_LIMIT = 0.5
"""N m, the default device's."""
LAUNCH_SPEED = 12.0
"""rad/s, the default device's fastest stage."""
BEFORE = 0.9
"""Million rows/s: the CSV reader before issue 35, its checks included, on this machine (the
issue's number; it read 0.65 beside this benchmark's other work at commit caffba6)."""

TORQUE_CONSTANT = 0.05
"""N m/A, for the current-logging layout."""

LAYOUTS = {
    "CSV t,phi,torque (default)": LogLayout(),
    "CSV t,counts,torque (default, a counter)": LogLayout(angle_unit="counts"),
    "CSV ; decimal comma, units row, ms, deg, mN m, temperature": LogLayout(
        delimiter=";",
        decimal=",",
        skip_after_header=1,
        time_column="Time [ms]",
        time_unit="ms",
        angle_column="Angle [deg]",
        angle_unit="deg",
        torque_column="Torque [mN m]",
        torque_unit="mN m",
        temperature_column="Motor temperature [C]",
    ),
    "CSV tab, counts, epoch ns": LogLayout(
        delimiter="\t", angle_unit="counts", time_unit="ns", time_origin="first"
    ),
    "CSV blanks, us, current in A": LogLayout(delimiter=" ", time_unit="us", torque_unit="A"),
    "TDMS, time channel": LogLayout(format="tdms"),
    "TDMS, epoch timestamps, temperature": LogLayout(
        format="tdms", time_origin="first", temperature_column="T"
    ),
    "Parquet": LogLayout(format="parquet"),
    "Parquet, epoch timestamps, counts, temperature": LogLayout(
        format="parquet", time_origin="first", angle_unit="counts", temperature_column="T"
    ),
}


def synthetic_log(rows: int) -> Log:
    """A braking-like log: a body slowing from 12 rad/s at 1 kHz, jittered stamps, a noisy
    braking torque, a motor warming by half a degree."""
    rng = np.random.default_rng(35)
    t = (np.arange(rows) + rng.uniform(-0.2, 0.2, rows)) / ENCODER.sample_rate
    t[0] = 0.0
    speed = np.linspace(12.0, 0.5, rows)
    phi = np.floor(np.cumsum(speed / ENCODER.sample_rate) / ENCODER.quantum) * ENCODER.quantum
    torque = -0.005 + 1e-4 * rng.standard_normal(rows)
    return Log(t=t, phi=phi, torque=torque, temperature=np.linspace(24.8, 25.3, rows))


def read_once(path: Path, layout: LogLayout) -> Log:
    return read_log(
        path,
        ENCODER,
        "braking",
        torque_limit=TORQUE_LIMIT,
        launch_speed=LAUNCH_SPEED,
        layout=layout,
        torque_constant=TORQUE_CONSTANT,
    )


def measure(log: Log, layout: LogLayout, folder: Path, repeat: int) -> dict:
    """Write ``log`` in ``layout``, read it ``repeat`` times: the best time, the file's size,
    the heap's peak while reading, and whether it read back as written."""
    path = folder / f"braking{layout.extension}"
    written = log if layout.temperature_column else dataclasses.replace(log, temperature=None)
    write_log(path, written, layout=layout, encoder=ENCODER, torque_constant=TORQUE_CONSTANT)
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        back = read_once(path, layout)
        best = min(best, time.perf_counter() - start)
    tracemalloc.start()
    read_once(path, layout)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    same = (
        np.array_equal(back.phi, log.phi)
        and np.allclose(back.t, log.t, rtol=0.0, atol=1e-6)
        and np.allclose(back.torque, log.torque, rtol=1e-12, atol=0.0)
    )
    size = path.stat().st_size
    path.unlink()
    return {"seconds": best, "bytes": size, "peak": peak, "same": same}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.log_reading",
        description="Rows per second of every logger's format and dialect, checks included.",
    )
    parser.add_argument("--rows", type=int, default=3_000_000, help="rows of the log")
    parser.add_argument("--repeat", type=int, default=3, help="reads timed; the best counts")
    parser.add_argument(
        "--out", type=Path, default=RESULTS / "log_reading.md", help="the report (Markdown)"
    )
    args = parser.parse_args(argv)
    command = command_line("log_reading", argv)
    log = synthetic_log(args.rows)
    rows = []
    with tempfile.TemporaryDirectory(prefix="rsp-log-reading-") as folder:
        for name, layout in LAYOUTS.items():
            result = measure(log, layout, Path(folder), args.repeat)
            rate = args.rows / result["seconds"]
            print(f"{name}: {rate / 1e6:.2f} million rows/s", flush=True)
            rows.append((name, result, rate))
    plain = rows[0][2]
    cells = [
        [
            name,
            f"{rate / 1e6:.2f}",
            f"{rate / plain:.2f}",
            f"{result['seconds']:.2f}",
            f"{result['bytes'] / args.rows:.1f}",
            f"{result['peak'] / args.rows:.0f}",
            "yes" if result["same"] else "NO",
        ]
        for name, result, rate in rows
    ]
    head = [
        "format and dialect",
        "million rows/s",
        "x plain CSV",
        "s per read",
        "file bytes/row",
        "peak heap bytes/row",
        "reads back as written",
    ]
    about = (
        f"One braking-like log of {args.rows:,} rows (jittered stamps at 1 kHz, 16-bit encoder, "
        "noisy torque) written in each layout and read by `rsp_inertia.plant.logs.read_log` with "
        "every check (time, grid, speed, direction, torque, turning point), the best of "
        f"{args.repeat} reads. Peak heap: tracemalloc's peak while reading, per row (the arrays "
        "of the columns and the Log; linear in rows). See benchmarks/log_reading.py."
    )
    slowest_name, slowest = min(((name, rate / 1e6) for name, _, rate in rows), key=lambda x: x[1])
    verdict = "PASS" if slowest >= BEFORE else "FAIL"  # both in million rows/s
    lines = [
        "# Log reading: rows per second per format and dialect",
        "",
        f"Command: `{command}`",
        "",
        about,
        "",
        *table_lines(head, cells),
        "",
        (f"- {verdict}: every format and dialect at least as fast as the CSV reader before "
         f"issue 35 ({BEFORE:g} million rows/s with its checks): the slowest, {slowest_name}, "
         f"reads {slowest:.2f}. (Its glitch search, rsp_inertia.plant.log_glitches, is "
         "included.)"),
        "",
    ]
    args.out.write_text("\n".join(lines))
    print(f"-> {args.out}")


if __name__ == "__main__":
    main()
