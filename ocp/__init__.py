"""The torque program of the reverse pass: mirror, nominal model, OCP feedforward, LQR regulator.

The names below are its public API, each from the module that is its home; they load on
first use (module ``__getattr__``, as ``rsp_inertia`` does), so importing one module of the
package does not import the others.
"""

from __future__ import annotations

import importlib

_HOMES = {
    "Mirror": "reference",
    "mirror": "reference",
    "fit_nominal": "nominal",
    "OcpSolution": "feedforward",
    "required_torque": "feedforward",
    "solve_program_ocp": "feedforward",
    "bandwidth": "regulator",
    "lqr_gains": "regulator",
    "TorqueProgram": "program",
    "make_program": "program",
}
"""Each public name and the module (of this package) that is its home."""

__all__ = [
    "Mirror",
    "OcpSolution",
    "TorqueProgram",
    "bandwidth",
    "fit_nominal",
    "lqr_gains",
    "make_program",
    "mirror",
    "required_torque",
    "solve_program_ocp",
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
