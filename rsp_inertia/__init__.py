"""rsp-inertia: inertia tensor and centre of mass by reverse-symmetrical semi-program precession.

The Python API (docs/api.md) has one function per command, each taking the experiment
folder and returning a result object::

    import rsp_inertia

    result = rsp_inertia.identify("bench-A")    # reads the logs, writes bench-A/result.json
    print(result)                               # the table rsp-inertia identify prints
    result.tensor, result.tensor_std            # (3, 3) arrays, kg m^2

Functions: :func:`create_experiment`, :func:`simulate`, :func:`program`, :func:`identify`,
:func:`calibrate`, :func:`plan`, :func:`check`, :func:`write_report`, :func:`combine`,
:func:`export`, :func:`demo`. Bad input
raises :class:`InputError`, with the line the command line prints.

The names are loaded on first use (module ``__getattr__``): ``import rsp_inertia`` imports
nothing heavy (each API function imports its command's modules when called: rsp_inertia.api
is the lazy boundary), so the command line starts fast. The layers are subpackages:
``rsp_inertia.plant`` (device, geometry, virtual device, files), ``rsp_inertia.estimation``
(identification), ``rsp_inertia.ocp`` (torque programs) and ``rsp_inertia.design``
(experiment design: pilot fit, plan, rehearsal, mountings); the commands' result classes are
in ``rsp_inertia.results``, their figures in ``rsp_inertia.plots``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rsp_inertia.public import PACKAGE_NAMES

if TYPE_CHECKING:  # for type checkers and IDEs; at run time, __getattr__ below
    from rsp_inertia.api import (
        InputError,
        calibrate,
        check,
        combine,
        create_experiment,
        demo,
        export,
        identify,
        plan,
        program,
        simulate,
        write_report,
    )
    from rsp_inertia.results import (
        CalibrateResult,
        CheckResult,
        CombineResult,
        ExportResult,
        IdentifyResult,
        PlanResult,
        ProgramResult,
        SimulateResult,
    )

__all__ = list(PACKAGE_NAMES)
"""The public names: the API's (rsp_inertia.public, written once for both) and the version."""


def _version() -> str:
    """The installed distribution's version (pyproject.toml's), "unknown" if not installed."""
    # importlib.metadata reads the installed distributions: only when the version is asked for
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rsp-inertia")
    except PackageNotFoundError:  # a checkout that was never installed
        return "unknown"


def __getattr__(name: str):
    """The API's names on first use (PEP 562), kept in the module."""
    if name == "__version__":
        value = _version()
    elif name in __all__:
        # the API on first use: ``import rsp_inertia`` (and every subpackage's import) loads
        # none of the command layer; a result class loads rsp_inertia.results (numpy) then
        from rsp_inertia import api

        value = getattr(api, name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
