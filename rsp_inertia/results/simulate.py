"""``simulate``'s result: one summary per log the virtual device wrote."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

from rsp_inertia.plant.direction import Direction
from rsp_inertia.results.common import Records, json_text

__all__ = ["PassSummary", "SimulateResult"]


@dataclass(frozen=True)
class PassSummary:
    """What one simulated pass produced: a record of :class:`SimulateResult`."""

    stage: int
    """Stage number, from 1."""
    part: str
    """'braking', 'reverse', 'ideal reverse', 'pilot' or 'pendulum at node K'."""
    path: Path
    """The log written."""
    rows: int
    """Rows of the log."""
    duration: float
    """s, the pass's physical duration."""
    turns: float
    """Turns covered by the pass (encoder angle span / 2 pi)."""
    turns_past_last_node: float | None
    """Braking only: turns after the first passage of the stage's last node."""
    direction: Direction = Direction.FORWARD
    """Direction of the stage's run (pendulum and pilot runs: forward)."""

    def __str__(self) -> str:
        part = self.part if self.direction is Direction.FORWARD else f"{self.part} {self.direction}"
        text = (
            f"stage {self.stage}: {part}: {self.duration:.2f} s, {self.rows} rows, "
            f"{self.turns:.2f} turns"
        )
        if self.turns_past_last_node is not None:
            text += f" ({self.turns_past_last_node:.2f} past the last node)"
        return f"{text} -> {self.path}"


@dataclass(frozen=True)
class SimulateResult(Records):
    """The logs the virtual device wrote: one summary per pass, in the order written.

    Returned by :func:`rsp_inertia.simulate`. Iterating, ``len`` and indexing go over ``passes``.

    Attributes
    ----------
    passes : tuple of PassSummary
        One per log written, each with ``stage`` (from 1), ``part`` ('braking', 'reverse',
        'ideal reverse', 'pilot' or 'pendulum at node K'), ``direction``, ``path`` (the CSV
        written), ``rows``, ``duration`` (s), ``turns`` (angle span / 2 pi) and, for a
        braking, ``turns_past_last_node``.
    experiment : pathlib.Path
        The experiment folder.

    Examples
    --------
    >>> passes = rsp_inertia.simulate("bench-A", part="braking")    # doctest: +SKIP
    >>> [p.duration for p in passes]                                 # doctest: +SKIP
    [14.49, 22.09]
    """

    passes: tuple[PassSummary, ...]
    experiment: Path
    _records: ClassVar[str] = "passes"

    def to_json(self) -> str:
        """The passes as JSON.

        Returns
        -------
        str
            ``{"experiment": ..., "passes": [{"stage", "part", "direction", "path", "rows",
            "duration", "turns", "turns_past_last_node"}, ...]}``; durations in s.
        """
        passes = [
            {
                "stage": p.stage,
                "part": p.part,
                "direction": p.direction,
                "path": p.path,
                "rows": p.rows,
                "duration": p.duration,
                "turns": p.turns,
                "turns_past_last_node": p.turns_past_last_node,
            }
            for p in self.passes
        ]
        return json_text({"experiment": self.experiment, "passes": passes})
