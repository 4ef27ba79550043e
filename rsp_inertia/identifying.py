"""``rsp-inertia identify``: every stage's logs in, the tensor and centre of mass out.

Reads device.toml, every run's braking and reverse logs, calibration.toml and the pendulum
logs when present (rsp_inertia.estimation.reading.identify_experiment) and writes
``EXP/result.json`` atomically, with its provenance: the time, the software and every input's
sha256 as identify read them, and its own hash, ``integrity`` (rsp_inertia.provenance). Its result object is
:class:`rsp_inertia.results.IdentifyResult`, its table
:func:`rsp_inertia.results.format_identification`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from rsp_inertia.estimation.coverage import DEFAULT_COVERAGE_FACTOR, check_coverage_factor
from rsp_inertia.estimation.reading import identify_experiment
from rsp_inertia.estimation.results import Identification
from rsp_inertia.infra.files import check_writable, write_atomic
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.provenance import make_provenance, sealed_json

__all__ = ["identify"]


def identify(
    path: str | Path, coverage_factor: float = DEFAULT_COVERAGE_FACTOR
) -> Identification:
    """The command behind :func:`rsp_inertia.api.identify`, documented there; returns the
    library's record (rsp_inertia.estimation.results.Identification), which the API views as
    its IdentifyResult."""
    coverage_factor = check_coverage_factor(coverage_factor)
    exp = open_experiment(path)
    check_writable(exp.result_path)
    provenance = make_provenance("identify", exp.root, exp.identify_inputs())
    result = identify_experiment(exp, made=provenance["created"], coverage_factor=coverage_factor)
    result = replace(result, provenance=provenance)
    # sealed last, over the whole document (docs/files.md, result.json integrity)
    write_atomic(exp.result_path, sealed_json(result.to_dict()))
    return result
