"""What the commands' results share: iterating over records, drawing, the JSON text.

The results import numpy and the light modules of the device, never the estimation stack,
CasADi or matplotlib (rsp_inertia.results).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["Drawer", "Drawn", "Records", "json_text"]

Drawer = Callable[[Any], "list[tuple[str, Figure]]"]
"""What draws a result's figures: called with the result, returns (file name, Figure) pairs
(the functions ``*_figures`` of :mod:`rsp_inertia.plots`)."""


class Records:
    """Iterating, ``len``, indexing and ``str`` of a result over its records (the field
    named by ``_records``), one printed line each."""

    _records: ClassVar[str]

    def __iter__(self) -> Iterator:
        return iter(getattr(self, self._records))

    def __len__(self) -> int:
        return len(getattr(self, self._records))

    def __getitem__(self, index: int):
        return getattr(self, self._records)[index]

    def __str__(self) -> str:
        return "\n".join(str(record) for record in getattr(self, self._records))


class Drawn:
    """``draw()`` of a result with figures: its ``drawer``, which its command handed it."""

    drawer: Drawer | None

    def draw(self) -> list[tuple[str, Figure]]:
        """The command's figures, drawn and not written.

        Returns
        -------
        list of (str, matplotlib.figure.Figure)
            Each figure with the file name the command gives it.

        Raises
        ------
        TypeError
            The result was made without its drawer (not by its command or the API).
        """
        if self.drawer is None:
            raise TypeError(
                f"this {type(self).__name__} was made without its drawer: make it through "
                "rsp_inertia's API, whose functions hand it rsp_inertia.plots' drawing"
            )
        return self.drawer(self)


def _plain(value: Any) -> Any:
    """``value`` as plain JSON types: arrays and tuples as lists, paths as strings, numpy
    scalars as Python numbers, NaN and infinities as None (JSON has no such numbers)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "tolist"):  # numpy array or scalar
        return _plain(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(document: dict) -> str:
    """The JSON text of a result document: indented, with a final newline (as result.json)."""
    return json.dumps(_plain(document), indent=2) + "\n"
