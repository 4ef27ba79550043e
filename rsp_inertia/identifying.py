"""``rsp-inertia identify``: every stage's logs in, the tensor and centre of mass out.

Reads device.toml, every run's braking and reverse logs, calibration.toml and the pendulum
logs when present (rsp_inertia.estimation.reading.identify_experiment) and writes
``EXP/result.json`` atomically, with its provenance: the time, the software and every input's
sha256 as identify read them (rsp_inertia.provenance). Its result object is
:class:`rsp_inertia.results.IdentifyResult`, its table
:func:`rsp_inertia.results.format_identification`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from rsp_inertia.estimation.reading import identify_experiment
from rsp_inertia.estimation.results import Identification
from rsp_inertia.infra.files import check_writable, write_atomic
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.provenance import make_provenance
from rsp_inertia.results import result_json

__all__ = ["identify"]


def identify(
    root: str | Path, progress: Callable[[str], None] | None = None
) -> Identification:
    """``rsp-inertia identify``: all stages' logs -> EXP/result.json (written atomically),
    with its provenance: the time, the software and every input's sha256 as identify read
    them (rsp_inertia.provenance)."""
    exp = open_experiment(root)
    check_writable(exp.result_path)
    provenance = make_provenance("identify", exp.root, exp.identify_inputs())
    result = identify_experiment(exp, progress)
    result = replace(result, provenance=provenance)
    write_atomic(exp.result_path, result_json(result))
    return result
