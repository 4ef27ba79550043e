"""Public names of a package loaded from their homes on first use (PEP 562).

Each subpackage's ``__init__`` lists its public API as a table, name -> the module of the
package that is its home, and takes its ``__getattr__`` and ``__dir__`` from
:func:`lazy_names`: importing one module of a package then imports no other (``combine``
does not pay for CasADi), while ``rsp_inertia.plant.Device`` and ``from rsp_inertia.plant
import Device`` work as if the package had imported them.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping

__all__ = ["lazy_names"]


def lazy_names(
    package: str, homes: Mapping[str, str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module-level ``__getattr__`` and ``__dir__`` of a package with lazy public names.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    homes : mapping of str to str
        Each public name and the module of the package that defines it (``"Device":
        "config"``).

    Returns
    -------
    tuple of callable
        ``__getattr__(name)``: the name from its home, kept in the package for the next
        look-up (AttributeError for a name not in ``homes``); ``__dir__()``: the package's
        names and the public ones.
    """

    def __getattr__(name: str) -> object:
        if name not in homes:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{homes[name]}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(homes))

    return __getattr__, __dir__
