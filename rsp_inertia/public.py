"""The package's public names, written once: ``rsp_inertia.__all__`` and
``rsp_inertia.api.__all__`` are made from them.

A leaf module (it imports nothing), so that the package can list its names without loading
the API, and the API without importing the package back (which would close a cycle).
"""

from __future__ import annotations

__all__ = ["API_NAMES", "PACKAGE_NAMES", "RESULT_CLASSES"]

RESULT_CLASSES = (
    "CalibrateResult",
    "CheckResult",
    "CombineResult",
    "ExportResult",
    "IdentifyResult",
    "PlanResult",
    "ProgramResult",
    "SimulateResult",
)
"""The commands' result classes among the public names (homes: rsp_inertia.results)."""

API_NAMES = tuple(
    sorted(
        (
            *RESULT_CLASSES,
            "InputError",
            "calibrate",
            "check",
            "combine",
            "create_experiment",
            "demo",
            "export",
            "identify",
            "plan",
            "program",
            "simulate",
            "write_report",
        )
    )
)
"""The public names of rsp_inertia.api, sorted: the result classes, the exception, and one
function per command (``design``'s, rsp_inertia.api.axis_designs, is the command line's
only)."""

PACKAGE_NAMES = tuple(sorted((*API_NAMES, "__version__")))
"""The public names of rsp_inertia, sorted: the API's and the version."""
