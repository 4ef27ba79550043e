"""``check``'s result: the findings on an experiment folder, and whether it is ready."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rsp_inertia.results.common import json_text

__all__ = ["LEVELS", "CheckResult"]

LEVELS = ("error", "missing", "suspicious", "ok")
"""The levels of check's findings, worst first."""


@dataclass(frozen=True)
class CheckResult:
    """What an experiment folder has, lacks or looks wrong, one finding per line.

    Returned by :func:`rsp_inertia.check` (rsp_inertia.checking.check). Not being ready is a
    finding, not an error: :func:`rsp_inertia.check` raises only when device.toml cannot be
    read.

    Attributes
    ----------
    ready : bool
        Whether identify has everything it needs (no 'error' and no 'missing' finding); for
        a calibration folder, calibrate.
    findings : tuple of (str, str)
        ``(level, message)`` in the order found; level is 'error', 'missing', 'suspicious'
        or 'ok' (:data:`LEVELS`).
    experiment : pathlib.Path
        The experiment folder.
    calibration : bool
        Whether the folder was checked as a calibration folder (the empty fixture's or the
        reference body's runs, which calibrate reads).

    Examples
    --------
    >>> status = rsp_inertia.check("bench-A")    # doctest: +SKIP
    >>> status.ready                             # doctest: +SKIP
    False
    """

    findings: tuple[tuple[str, str], ...]
    experiment: Path
    calibration: bool = False

    @property
    def ready(self) -> bool:
        """Whether no finding is an 'error' or 'missing'."""
        return not any(level in ("error", "missing") for level, _ in self.findings)

    def __str__(self) -> str:
        out = [f"{level}: {message}" for level, message in self.findings]
        counts = {level: sum(1 for lv, _ in self.findings if lv == level) for level in LEVELS}
        verdict = "ready for " + ("calibrate" if self.calibration else "identify")
        if not self.ready:
            verdict = "not " + verdict
        out.append(
            f"{self.experiment}: {verdict} ({counts['error']} error(s), {counts['missing']} "
            f"missing, {counts['suspicious']} suspicious)"
        )
        return "\n".join(out)

    def to_json(self) -> str:
        """The findings as JSON.

        Returns
        -------
        str
            ``{"experiment": ..., "ready": ..., "findings": [{"level", "message"}, ...]}``.
        """
        findings = [{"level": level, "message": text} for level, text in self.findings]
        return json_text({"experiment": self.experiment, "ready": self.ready, "findings": findings})
