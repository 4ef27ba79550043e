"""The lab's files of an experiment: ``record.toml`` (who measured what part, and in what
environment) and ``spec.toml`` (the limits the part must meet, and the decision rule).

Both are optional; identify reads them when present and writes what they say into
result.json (``record``, ``decision``). docs/files.md documents every key; the config
classes below declare them (rsp_inertia.infra.toml_schema), and bad content is one line naming
the file and the dotted key (rsp_inertia.infra.errors.InputError).
"""

from __future__ import annotations

import dataclasses
import enum
import os

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.toml_schema import ContentError, config_class, key, read_file, read_table

__all__ = [
    "ComLimits",
    "DecisionRule",
    "Environment",
    "PrincipalLimits",
    "RecordFile",
    "RecordTable",
    "Rule",
    "SpecFile",
    "TensorLimits",
    "load_record",
    "load_spec",
]


# --- record.toml ----------------------------------------------------------------------------


@config_class
class RecordTable:
    """Who measured which part (``[record]``): free text, as the lab's register spells it."""

    operator: str | None = key(None, doc="Who ran the measurement.")
    part_id: str | None = key(None, doc="The part's number (drawing or article number).")
    serial: str | None = key(None, doc="The part's serial number.")
    notes: str | None = key(None, doc="Anything else the report should carry, one paragraph.")


@config_class
class Environment:
    """The conditions during the runs (``[environment]``). The bounds are a lab's, wide
    enough for any measuring room and narrow enough to catch a value in another unit
    (kelvin or degrees Fahrenheit, kPa or Pa, a fraction instead of percent)."""

    temperature_C: float | None = key(
        None, unit="deg C", bound=(">= -40", "<= 60"), doc="Air temperature at the rig."
    )
    pressure_hPa: float | None = key(
        None, unit="hPa", bound=(">= 500", "<= 1100"), doc="Air pressure at the rig."
    )
    humidity_percent: float | None = key(
        None, unit="%", bound=(">= 0", "<= 100"), doc="Relative humidity at the rig."
    )


@config_class
class RecordFile:
    """``record.toml``: the record fields a test report carries (ISO/IEC 17025 section 7.8)."""

    record: RecordTable = key(RecordTable(), doc="Operator, part and serial, notes.")
    environment: Environment = key(Environment(), doc="The conditions during the runs.")


def load_record(path: str | os.PathLike) -> RecordFile:
    """Read an experiment's ``record.toml``.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its name as given appears in error messages.

    Returns
    -------
    RecordFile
        Its tables; a key the file leaves out is None.

    Raises
    ------
    InputError
        The file is missing or not TOML; a key or table is unknown, of the wrong type or out
        of its bounds (one line naming the dotted key).

    Examples
    --------
    >>> load_record("EXP/record.toml").record.operator  # doctest: +SKIP
    'A. Smith'
    """
    doc = read_file(path)
    try:
        return read_table(RecordFile, doc)
    except ContentError as error:
        raise InputError(f"{path}: {error}") from None


# --- spec.toml ------------------------------------------------------------------------------

LIMIT_NAMES = ("low", "high")
"""The two numbers of a limit, ``[low, high]``."""


def _ordered(limits: tuple[float, float], key: str) -> None:
    """Refuse limits whose low exceeds their high."""
    low, high = limits
    if low > high:
        raise ContentError(key, f"must be [low, high] with low <= high, got [{low!r}, {high!r}]")


def _moment_limits(rows: tuple[tuple[float, ...], ...], key: str) -> None:
    """Refuse principal-moment limits that are not three ``[low, high]`` pairs."""
    if len(rows) != 3:
        raise ContentError(
            key, f"must have 3 limits [low, high], one per principal moment (ascending), "
            f"got {len(rows)}"
        )
    for k, row in enumerate(rows, 1):
        if len(row) != 2:
            raise ContentError(f"{key}[{k}]", f"must be [low, high], got {len(row)} numbers")
        _ordered(row, f"{key}[{k}]")


def _limit(unit: str, doc: str):
    """A ``[low, high]`` key of spec.toml, None when left out."""
    return key(None, unit=unit, names=LIMIT_NAMES, check=_ordered, doc=doc)


@config_class
class TensorLimits:
    """Limits on the tensor's entries (``[tensor]``): any of the six, in result.json's axes
    (rig axes about O; products as tensor entries)."""

    Jx: tuple[float, float] | None = _limit("kg m^2", "[low, high] of Jx.")
    Jy: tuple[float, float] | None = _limit("kg m^2", "[low, high] of Jy.")
    Jz: tuple[float, float] | None = _limit("kg m^2", "[low, high] of Jz.")
    Jxy: tuple[float, float] | None = _limit("kg m^2", "[low, high] of Jxy.")
    Jyz: tuple[float, float] | None = _limit("kg m^2", "[low, high] of Jyz.")
    Jxz: tuple[float, float] | None = _limit("kg m^2", "[low, high] of Jxz.")


@config_class
class ComLimits:
    """Limits on the centre of mass (``[com]``): the coordinates the result has (identify:
    x and y, with device.toml's ``[body] mass``)."""

    x: tuple[float, float] | None = _limit("m", "[low, high] of x_c.")
    y: tuple[float, float] | None = _limit("m", "[low, high] of y_c.")
    z: tuple[float, float] | None = _limit("m", "[low, high] of z_c (a combination only).")


@config_class
class PrincipalLimits:
    """Limits on the principal moments (``[principal]``)."""

    moments: tuple[tuple[float, ...], ...] | None = key(
        None,
        unit="kg m^2",
        check=_moment_limits,
        doc="Three [low, high], one per principal moment in ascending order.",
    )


class Rule(enum.StrEnum):
    """The decision rule (ILAC-G8:09/2019)."""

    SIMPLE = "simple"
    """Simple acceptance: pass if the value is inside the limits, the measurement's
    uncertainty aside (the specific risk of a false pass is not controlled)."""
    GUARDED = "guarded"
    """A guard band of U: pass only if value +- U is inside, fail only if value +- U is
    outside, else indeterminate."""


@config_class
class DecisionRule:
    """How the values are compared with the limits (``[decision]``)."""

    rule: Rule = key(
        doc="'simple' (simple acceptance) or 'guarded' (guard band of the expanded "
        "uncertainty U), as ILAC-G8:09/2019 names them; a lab states its rule, so there is "
        "no default."
    )


@config_class
class SpecFile:
    """``spec.toml``: the part's specification and the decision rule."""

    decision: DecisionRule = key(doc="The decision rule.")
    tensor: TensorLimits = key(TensorLimits(), doc="Limits on the tensor's entries.")
    com: ComLimits = key(ComLimits(), doc="Limits on the centre of mass.")
    principal: PrincipalLimits = key(PrincipalLimits(), doc="Limits on the principal moments.")

    def limits(self) -> dict[str, tuple[float, float]]:
        """Every limit the file gives, by its dotted key: ``tensor.Jx``, ``com.x``,
        ``principal.moments[1]`` (the smallest moment), ..., in the file's table order."""
        out = {}
        for table in ("tensor", "com"):
            holder = getattr(self, table)
            for field in dataclasses.fields(holder):
                value = getattr(holder, field.name)
                if value is not None:
                    out[f"{table}.{field.name}"] = (float(value[0]), float(value[1]))
        for k, row in enumerate(self.principal.moments or (), 1):
            out[f"principal.moments[{k}]"] = (float(row[0]), float(row[1]))
        return out


def load_spec(path: str | os.PathLike) -> SpecFile:
    """Read an experiment's ``spec.toml``.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its name as given appears in error messages.

    Returns
    -------
    SpecFile
        The limits and the rule.

    Raises
    ------
    InputError
        The file is missing or not TOML; a key or table is unknown, of the wrong type; a
        limit is not ``[low, high]`` with low <= high; ``[decision] rule`` is missing or not
        'simple' or 'guarded'; the file gives no limit at all.

    Examples
    --------
    >>> load_spec("EXP/spec.toml").limits()  # doctest: +SKIP
    {'tensor.Jz': (0.0295, 0.0305)}
    """
    doc = read_file(path)
    try:
        spec = read_table(SpecFile, doc)
    except ContentError as error:
        raise InputError(f"{path}: {error}") from None
    if not spec.limits():
        raise InputError(
            f"{path}: no limits: give at least one of [tensor] Jx = [low, high], [com] x = "
            "[low, high] or [principal] moments = [[low, high], ...]"
        )
    return spec
