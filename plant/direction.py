"""The direction of a run: forward or backward (device.toml ``[[stage]] directions``).

A run is one stage in one direction of rotation. Forward, phi increases during the braking
pass and decreases during its reverse pass; backward, the other way round (the mirror of
docs/method.md §4). The words "forward" and "backward" name a run in device.toml, on the
command line (``--direction``), in the API (``direction=``), in the log files' names
(``braking_backward.csv``) and in the results. They are parsed into :class:`Direction` where
they enter (device.toml by rsp_inertia.infra.toml_schema, the others by
:meth:`Direction.parse`); everything inside takes a Direction, and its :attr:`Direction.sign`
is the one place the word becomes the sign s = +1 / -1 of the mathematics.
"""

from __future__ import annotations

import enum

from rsp_inertia.infra.errors import InputError

__all__ = ["Direction"]


class Direction(enum.StrEnum):
    """The direction of a run. A ``str``: it prints, formats, compares and serialises (JSON,
    TOML) as its word, so text and files read "forward" or "backward"."""

    FORWARD = "forward"
    """phi increases during the braking pass and decreases during its reverse pass."""
    BACKWARD = "backward"
    """phi decreases during the braking pass and increases during its reverse pass."""

    def __repr__(self) -> str:
        # The word, quoted, as the str it stands for: messages that show a direction with
        # !r (a duplicate in device.toml, a stage that does not run it) read as they did.
        return repr(self.value)

    @property
    def sign(self) -> int:
        """s = +1 forward, -1 backward: the sign of Omega during the braking pass (an int;
        float(sign) where the mathematics holds floats)."""
        return 1 if self is Direction.FORWARD else -1

    @classmethod
    def of_sign(cls, sign: float) -> Direction:
        """The direction whose braking pass moves with sign ``sign`` (> 0: forward)."""
        return cls.FORWARD if sign > 0 else cls.BACKWARD

    @classmethod
    def parse(cls, text: str, key: str) -> Direction:
        """The Direction named ``text``, given for ``key`` (an option such as
        ``--direction``, or a file's key), for messages.

        Parameters
        ----------
        text : str
            "forward" or "backward".
        key : str
            What gave it: the error message starts with it.

        Returns
        -------
        Direction
            The direction named.

        Raises
        ------
        InputError
            ``text`` is neither: ``{key}: must be one of forward, backward, got {text!r}``.
        """
        try:
            return cls(text)
        except ValueError:
            words = ", ".join(direction.value for direction in cls)
            raise InputError(f"{key}: must be one of {words}, got {text!r}") from None
