"""Experiment design: pilot fit, stage models, candidate protocols, plan, rehearsal, the
device.toml edit and mounting conditioning.

The names below are its public API, each from the module that is its home; they load on
first use (rsp_inertia.infra.lazy, as ``rsp_inertia`` does), so importing one module of the
package does not import the others.
"""

from __future__ import annotations

from rsp_inertia.infra.lazy import lazy_names

_HOMES = {
    "PilotFit": "pilot",
    "fit_pilot": "pilot",
    "guess_model": "models",
    "stage_models": "models",
    "Candidate": "candidates",
    "StageModel": "candidates",
    "stage_candidates": "candidates",
    "Plan": "plan",
    "make_plan": "plan",
    "Rehearsal": "rehearsal",
    "rehearse": "rehearsal",
    "write_protocols": "device_edit",
    "best_cone_opening": "mountings",
    "mounting_conditioning": "mountings",
}
"""Each public name and the module (of this package) that is its home."""

__all__ = [
    "Candidate",
    "PilotFit",
    "Plan",
    "Rehearsal",
    "StageModel",
    "best_cone_opening",
    "fit_pilot",
    "guess_model",
    "make_plan",
    "mounting_conditioning",
    "rehearse",
    "stage_candidates",
    "stage_models",
    "write_protocols",
]

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
