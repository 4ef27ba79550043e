"""Benchmarks of rsp-inertia on its virtual device, run from the repository root.

Programs (``python -m benchmarks.<name>``; each writes its results into benchmarks/results/
with the command that made it):

- ``sweep``: accuracy and speed of RSP against the torsion pendulum over friction x encoder
  bits x centre-of-mass offsets x seeds, and the sensitivity to calibration errors
  (``make bench``) -> accuracy.md, accuracy.png, speed.md, sensitivity.png;
- ``identification``: identification alone, on the ideal reverse -> identification.md;
- ``program``: torque program and closed loop under model errors -> program.md;
- ``plan``: pilot, plan, program, closed loop, identify -> plan.md;
- ``systematics``: rig imperfections, before and after calibration -> systematics.md;
- ``real_logs``: jittered, lossy, wrapping logs against clean ones -> real_logs.md;
- ``mountings``: combining mountings, their accuracy and the misalignment test ->
  mountings.md, mountings.json;
- ``engine``: the calibrated route on logs made by MuJoCo, an independent 3-D engine (and
  the reduced model against it) -> engine.md, engine.json;
- ``conventions``: a rig built against docs/method.md §1's conventions (a reversed gear, a
  left-handed phi, an encoder counting backwards or zeroed off) and clean rigs, through
  calibrate with a turned reference -> conventions.md, conventions.json;
- ``log_reading``: rows per second of every logger's format and dialect (device.toml
  ``[log]``), checks included -> log_reading.md;
- ``glitches``: one corrupted row (a torque x 20, an angle 40 counts off) at a random place
  of a braking or reverse log, per seed: named by file and line, left out, the tensor
  unchanged within its std -> glitches.md, glitches.json;
- ``scale``: wall time and peak memory of simulate, program and identify against braking
  length and sample rate, growth exponents (``make bench-scale``) -> scale.md, scale.png.

Shared modules: :mod:`benchmarks.experiments` (variants of the default experiment through
the config dataclasses), :mod:`benchmarks.truth` (errors against the virtual device's
truth), :mod:`benchmarks.tables` (Markdown tables, figures, command lines). The sweep's own
parts: :mod:`benchmarks.cases` (one case end to end), :mod:`benchmarks.protocol` (a case's
launch speed and braking torque), :mod:`benchmarks.sensitivity`, :mod:`benchmarks.scheduling`
(local processes or Dask, resumable case files), :mod:`benchmarks.accuracy` and
:mod:`benchmarks.report` (its tables and files).

This package is not part of the installed ``rsp_inertia``: it imports the library, never the
other way round.
"""

from pathlib import Path

RESULTS = Path(__file__).parent / "results"
"""benchmarks/results/: where every program writes by default."""
