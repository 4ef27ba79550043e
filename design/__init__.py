"""Experiment design: pilot fit, stage models, candidate protocols, plan, rehearsal, the
device.toml edit and mounting conditioning.

The names below are its public API, each from the module that is its home; they load on
first use (module ``__getattr__``, as ``rsp_inertia`` does), so importing one module of the
package does not import the others.
"""

from __future__ import annotations

import importlib

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


def __getattr__(name: str):
    """Load a public name from its home on first use (PEP 562) and keep it here."""
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
