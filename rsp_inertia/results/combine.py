"""``combine``'s result: the library's record of the mountings' least squares
(rsp_inertia.estimation.combine.Combination) and the body.json written."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from rsp_inertia.provenance import sealed_json

if TYPE_CHECKING:
    from rsp_inertia.estimation.combine import Combination

__all__ = ["CombineResult"]


@dataclass(frozen=True)
class CombineResult:
    """The body's tensor and whole centre of mass in body axes, from several mountings.

    Returned by :func:`rsp_inertia.combine`.

    Attributes
    ----------
    combination : rsp_inertia.estimation.combine.Combination
        The generalised least squares over the mountings: ``entries`` (6,) kg m^2 about the
        body frame's origin, ``com`` (3,) m, their joint ``cov`` (9, 9), the principal
        moments and axes, each mounting's residuals in stds, the consistency test
        (``chi2``, ``dof``, ``p``), the ``warnings`` and the GUM statement
        (``expanded_uncertainty``, rsp_inertia.estimation.coverage.ExpandedUncertainty).
    path : pathlib.Path
        The body.json written (``OUT/body.json``).
    warnings : tuple of str
        The combination's warnings (as body.json's); not in ``str(result)``: the command
        line prints them on stderr.

    Examples
    --------
    >>> body = rsp_inertia.combine(["bench-A", "bench-A-x90"], "body")    # doctest: +SKIP
    >>> body.combination.com, body.combination.com_std                     # doctest: +SKIP
    """

    combination: Combination
    path: Path

    @property
    def warnings(self) -> tuple[str, ...]:
        """The combination's warnings, as in body.json."""
        return tuple(self.combination.warnings)

    def __str__(self) -> str:
        return f"{self.combination}\nbody -> {self.path}"

    def to_json(self) -> str:
        """The text of body.json.

        Returns
        -------
        str
            The document of docs/files.md (body.json): ``tensor``, ``tensor_std``, ``com``,
            ``com_std``, ``covariance``, the principal moments and axes, each mounting's
            residuals, ``consistency``, ``warnings`` and ``integrity``
            (rsp_inertia.provenance.sealed_json): exactly the text combine writes.
        """
        return sealed_json(self.combination.to_dict())
