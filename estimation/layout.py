"""Layouts of the vectors of unknowns: each described once, by named segments.

A vector of unknowns laid out by hand-written offsets breaks quietly when a segment grows or
moves; here each vector is a :class:`Layout`, a sequence of named :class:`Segment` s (a
segment's element names, once or per stage), and every slice, index and name list is derived
from it. Two vectors are laid out so:

- theta, the rig's known terms (rsp_inertia.estimation.known_terms.KnownTerms, docs/method.md
  §5 Calibration): the drive's gains, the empty system's harmonics per stage, the fixture's
  gravity, the encoder's zero offset and its error coefficients (:func:`theta_layout`);
- the tensor fit's shared unknowns (rsp_inertia.estimation.tensor_fit.TensorFit): the tensor's
  six entries and the body's gravity terms (:data:`SHARED_LAYOUT`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from rsp_inertia.plant.geometry import ENTRY_KEYS, GRAVITY_NAMES, HARMONIC_NAMES

__all__ = [
    "GAIN_NAMES",
    "SHARED_LAYOUT",
    "ZERO_NAME",
    "Layout",
    "Segment",
    "encoder_names",
    "theta_layout",
]

GAIN_NAMES = ("h_d", "h_b")
"""Names of the drive's gains, driving and back-driven (rsp_inertia.plant.transducers)."""

ZERO_NAME = "zero"
"""Name of the encoder's zero offset z, rad: it reads phi + z + e(phi)
(rsp_inertia.plant.transducers)."""


@dataclass(frozen=True)
class Segment:
    """A named run of consecutive unknowns of a :class:`Layout`."""

    name: str
    """What the segment holds, e.g. "gains"; :meth:`Layout.slice` finds it by this."""
    names: tuple[str, ...]
    """Its unknowns' names, in order (of one stage, when ``per_stage``)."""
    per_stage: bool = False
    """The segment repeats for every stage, its names suffixed ``[s]`` (s from 1)."""


@dataclass(frozen=True)
class Layout:
    """A vector of unknowns: its segments in order, each once or once per stage."""

    segments: tuple[Segment, ...]
    """The segments, in the vector's order."""
    stages: int = 0
    """How many times each per-stage segment repeats."""

    def __post_init__(self) -> None:
        seen = [segment.name for segment in self.segments]
        if len(set(seen)) != len(seen):
            raise ValueError(f"Layout: segment names repeat: {seen}")

    def _length(self, segment: Segment) -> int:
        """How many entries ``segment`` takes: its names, once or once per stage."""
        return len(segment.names) * (self.stages if segment.per_stage else 1)

    def _segment(self, name: str) -> tuple[int, Segment]:
        """(start, segment) of the segment ``name``."""
        start = 0
        for segment in self.segments:
            if segment.name == name:
                return start, segment
            start += self._length(segment)
        raise KeyError(f"Layout: no segment {name!r} (segments {[s.name for s in self.segments]})")

    @property
    def size(self) -> int:
        """Length of the vector."""
        return sum(self._length(segment) for segment in self.segments)

    def slice(self, name: str, stage: int | None = None) -> slice:
        """The vector's entries of segment ``name``: of stage ``stage`` (from 1) of a per-stage
        segment, or of every stage (``stage`` None).

        Parameters
        ----------
        name : str
            The segment's name.
        stage : int, optional
            The stage, from 1 (per-stage segments only).

        Returns
        -------
        slice
            The entries' positions.
        """
        start, segment = self._segment(name)
        width = len(segment.names)
        if stage is None:
            return slice(start, start + self._length(segment))
        if not segment.per_stage or not 1 <= stage <= self.stages:
            raise ValueError(f"Layout: segment {name!r} has no stage {stage}")
        start += width * (stage - 1)
        return slice(start, start + width)

    def indices(self, *names: str) -> list[int]:
        """Positions of the segments ``names`` (every stage's), in the order given."""
        return [i for name in names for i in range(self.size)[self.slice(name)]]

    def names(self, name: str | None = None, stage: int | None = None) -> list[str]:
        """The unknowns' names: of the whole vector (``name`` None), or of one segment, as
        :meth:`slice` selects it."""
        out = []
        for segment in self.segments:
            if segment.per_stage:
                out += [f"{n}[{s}]" for s in range(1, self.stages + 1) for n in segment.names]
            else:
                out += list(segment.names)
        return out if name is None else out[self.slice(name, stage)]


def encoder_names(orders: int) -> tuple[str, ...]:
    """The encoder's error coefficients' names, c1, s1, c2, ... (``orders`` orders)."""
    return tuple(f"{kind}{n}" for n in range(1, orders + 1) for kind in ("c", "s"))


@cache
def theta_layout(stages: int, orders: int) -> Layout:
    """theta = [h_d, h_b, M0[1] .. Mc1[1], ..., M0[n] .. Mc1[n], Gs, Gc, zero, c1, s1, ...]:
    the rig's known terms of ``stages`` stages, the encoder's zero offset and an encoder error
    of ``orders`` orders.

    Parameters
    ----------
    stages : int
        The gimbal's stages (the empty system's harmonics repeat per stage).
    orders : int
        Orders of the encoder's error series (two coefficients each).

    Returns
    -------
    Layout
        Segments "gains", "harmonics" (per stage), "gravity", "zero", "encoder".
    """
    return Layout(
        (
            Segment("gains", GAIN_NAMES),
            Segment("harmonics", HARMONIC_NAMES, per_stage=True),
            Segment("gravity", GRAVITY_NAMES),
            Segment("zero", (ZERO_NAME,)),
            Segment("encoder", encoder_names(orders)),
        ),
        stages,
    )


SHARED_LAYOUT = Layout((Segment("entries", ENTRY_KEYS), Segment("gravity", GRAVITY_NAMES)))
"""The tensor fit's unknowns shared by every run: [Jx, Jy, Jz, Jxy, Jyz, Jxz, Gs, Gc]."""
