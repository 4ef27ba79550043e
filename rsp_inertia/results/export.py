"""``export``'s result: the library's record of the body in the frame
(rsp_inertia.exporting.Exported) and the file written."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rsp_inertia.exporting import Exported

__all__ = ["ExportResult"]


@dataclass(frozen=True)
class ExportResult:
    """A body's mass, centre of mass and tensor in a frame, with their covariance.

    Returned by :func:`rsp_inertia.export`.

    Attributes
    ----------
    exported : rsp_inertia.exporting.Exported
        The record: ``values`` (16,) [mass (kg), centre of mass (3, m), the tensor about the
        frame's origin (6, kg m^2), the tensor about the centre of mass (6, kg m^2)] in the
        frame's axes, their ``cov`` (16, 16) and ``std``, ``source`` (what was read),
        ``frame``, ``notes``.
    path : pathlib.Path
        The file written.
    format : str
        ``"json"``, ``"csv"`` or ``"urdf"``.

    Examples
    --------
    >>> out = rsp_inertia.export("body", "body.urdf", format="urdf")    # doctest: +SKIP
    >>> out.exported.values[0], out.exported.std[0]                     # doctest: +SKIP
    """

    exported: Exported
    path: Path
    format: str

    def __str__(self) -> str:
        return f"export ({self.format}) -> {self.path}"

    def to_json(self) -> str:
        """The export as JSON (the text ``--format json`` writes).

        Returns
        -------
        str
            The document of docs/files.md (export): mass, centre of mass and tensor about
            the frame's origin with their stds and covariance, the tensor about the centre
            of mass, the source, the frame and the notes.
        """
        return self.exported.to_json()
