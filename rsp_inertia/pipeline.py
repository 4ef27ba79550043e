"""The experiment pipeline in one import, for scripts, tests and benchmarks.

Each command's library function lives in its own module, so that the command line imports
only what its command needs (``combine`` does not pay for CasADi, ``simulate`` not for the
estimation stack): :mod:`rsp_inertia.scenarios` (the virtual experiments),
:mod:`rsp_inertia.simulating`, :mod:`rsp_inertia.programming`, :mod:`rsp_inertia.identifying`,
:mod:`rsp_inertia.calibrating` and :mod:`rsp_inertia.combining`. This module gathers them
(and so imports all of them). Each function takes an experiment folder, calls the library
(plant/, estimation/, ocp/) and writes its outputs atomically; what it did comes back as the
library's records (:class:`rsp_inertia.results.PassSummary` per log simulated, the
Identification, the Calibration, ...). The demo, which runs them on the virtual rig, is
:mod:`rsp_inertia.rig_demo`.
"""

from __future__ import annotations

from rsp_inertia.calibrating import calibrate
from rsp_inertia.combining import combine
from rsp_inertia.identifying import identify
from rsp_inertia.plant.experiment import BODY_FILE, ENCODER_FIGURE
from rsp_inertia.programming import program, program_summaries
from rsp_inertia.results import PassSummary, ProgramSummary, body_json, result_json
from rsp_inertia.scenarios import (
    CALIBRATION_FOLDERS,
    SECOND_MOUNTING,
    TURNED_X90,
    create_default_experiment,
    create_rig_experiment,
    create_second_mounting,
)
from rsp_inertia.simulating import PARTS, simulate

__all__ = [
    "BODY_FILE",
    "CALIBRATION_FOLDERS",
    "ENCODER_FIGURE",
    "PARTS",
    "SECOND_MOUNTING",
    "TURNED_X90",
    "PassSummary",
    "ProgramSummary",
    "body_json",
    "calibrate",
    "combine",
    "create_default_experiment",
    "create_rig_experiment",
    "create_second_mounting",
    "identify",
    "program",
    "program_summaries",
    "result_json",
    "simulate",
]
