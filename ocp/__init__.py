"""The torque program of the reverse pass: mirror, nominal model, OCP feedforward, LQR regulator.

The names below are its public API, each from the module that is its home; they load on
first use (rsp_inertia.infra.lazy, as ``rsp_inertia`` does), so importing one module of the
package does not import the others.
"""

from __future__ import annotations

from rsp_inertia.infra.lazy import lazy_names

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

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
