"""The result of every command: one module per command, each with its result class and the
text the command prints.

Each result is a frozen dataclass returned by :mod:`rsp_inertia.api` (``design``'s by the
command line): ``str`` is the text the command prints, ``to_json()`` a JSON document
(:func:`json_text`), and, where the command draws, ``draw()`` its figures as (file name,
matplotlib Figure) pairs and ``figures(folder)`` the same written as PNG files. A result
holds the library's record of its computation and reads its fields from it (a view, never
a copy): ``IdentifyResult.identification``, ``CalibrateResult.calibration``,
``PlanResult.plan``, ``CombineResult.combination``, ``ExportResult.exported``,
``ProgramSummary.details``.

==================  ===========================  ======================================
command             result                       module, and the records inside it
==================  ===========================  ======================================
simulate            :class:`SimulateResult`      ``simulate``: :class:`PassSummary`, one
                                                 per log
program             :class:`ProgramResult`       ``program``: :class:`ProgramSummary`,
                                                 one per run
calibrate           :class:`CalibrateResult`     ``calibrate``
identify, demo      :class:`IdentifyResult`      ``identify``
plan                :class:`PlanResult`          ``plan``
check               :class:`CheckResult`         ``check``
combine             :class:`CombineResult`       ``combine``
export              :class:`ExportResult`        ``export``
design              :class:`AxisDesignResult`    ``axis_designs``
==================  ===========================  ======================================

What they share (iterating over records, drawing, the JSON text) is in ``common``.

This package formats; the commands compute (:mod:`rsp_inertia.identifying`,
:mod:`rsp_inertia.planning`, ...). Its modules import numpy and the light modules of the
device (plant.geometry, plant.toml_writer), never the estimation stack, CasADi or
matplotlib (tests/test_architecture.py checks): every command builds its result from here,
and ``check`` or ``combine`` must not pay for what they do not use. So a result does not
draw by itself: the command that makes it hands it the function of :mod:`rsp_inertia.plots`
that draws its figures (``drawer``; for :func:`rsp_inertia.identify`, one that imports
matplotlib on first use). The names below load from their modules on first use
(rsp_inertia.infra.lazy), so a command loads only its own result's module.
"""

from __future__ import annotations

from rsp_inertia.infra.lazy import lazy_names

_HOMES = {
    "Drawer": "common",
    "json_text": "common",
    "PassSummary": "simulate",
    "SimulateResult": "simulate",
    "ProgramResult": "program",
    "ProgramSummary": "program",
    "CalibrateResult": "calibrate",
    "IdentifyResult": "identify",
    "format_identification": "identify",
    "PlanResult": "plan",
    "LEVELS": "check",
    "CheckResult": "check",
    "CombineResult": "combine",
    "ExportResult": "export",
    "AxisDesignResult": "axis_designs",
    "axis_design_report": "axis_designs",
    "mounting_report": "axis_designs",
}
"""Each public name and the module (of this package) that is its home."""

__all__ = [
    "LEVELS",
    "AxisDesignResult",
    "CalibrateResult",
    "CheckResult",
    "CombineResult",
    "Drawer",
    "ExportResult",
    "IdentifyResult",
    "PassSummary",
    "PlanResult",
    "ProgramResult",
    "ProgramSummary",
    "SimulateResult",
    "axis_design_report",
    "format_identification",
    "json_text",
    "mounting_report",
]

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
