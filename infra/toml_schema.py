"""TOML tables read into frozen dataclasses and written back, both driven by the fields.

A config class is a frozen dataclass made by :func:`config_class`; each field that a TOML
file holds is made by :func:`key`, and that field is the whole contract of its key:

- the TOML key is the field's name (``name=`` where the file spells it otherwise);
- the type is the annotation: ``float`` (integers accepted), ``int``, ``str``, ``bool``,
  or a ``StrEnum`` (a string, one of its values, read as its member);
  ``tuple[float, ...]``, ``tuple[str, ...]`` or ``np.ndarray`` for an array (``names=``
  fixes its length and names its entries in messages; it may be empty unless a check
  refuses that); ``tuple[tuple[float, ...], ...]`` for a matrix (an array of arrays of
  one length); ``dict[str, str]`` for a free table (any keys, each a value of that type);
  another config class for a table; ``tuple[C, ...]`` for an array of tables; ``X | None``
  for a key whose absence means None;
- the default is the field's default, or ``absent=`` for a field the constructor requires
  while the file may leave it out; a table whose class has a default for every key may
  be left out, and so may a table typed ``C | None``;
- the metadata holds the unit, the bounds (:class:`Bound`, checked on a number or on each
  entry of an array, a matrix or a free table), a ``check`` of the whole value for
  semantics beyond bounds, and the doc (which :func:`config_class` puts into the class
  docstring's Attributes section);
- numbers are finite, unless ``nan=True`` lets a float be NaN (an undefined value; TOML
  spells it ``nan``), which the bounds then leave alone.

:func:`read_table` walks a class's fields to read a table: unknown keys are errors, types
are converted, bounds and checks applied. A fault is a :class:`ContentError` naming the
dotted key; the file readers prefix the path and raise
:class:`rsp_inertia.infra.errors.InputError`. rsp_inertia.infra.toml_writer walks the same
fields to write an instance back.
"""

from __future__ import annotations

import codecs
import copy
import dataclasses
import datetime
import enum
import functools
import inspect
import math
import operator
import os
import re
import textwrap
import tomllib
import types
import typing
from collections.abc import Callable
from typing import Any

import numpy as np

from rsp_inertia.infra.errors import InputError

REQUIRED: Any = dataclasses.MISSING
"""The default of a key the file must give."""


class ContentError(Exception):
    """A fault at a dotted key of a file; the file readers prefix the file's name."""

    def __init__(self, key: str, fault: str) -> None:
        super().__init__(f"{key}: {fault}")


@dataclasses.dataclass(frozen=True)
class Bound:
    """A condition a value must meet; its fault reads ``must be {text}, got {value!r}``.

    ``holds`` tests a value; without it, ``text`` is a comparison with a number, such as
    ``"> 0"``, ``">= 0"`` or ``"< 0.5"``, optionally followed by a note in the message
    (``"<= 0.25 (of a period)"``).
    """

    text: str
    holds: Callable[[Any], bool] | None = None

    def __post_init__(self) -> None:
        if self.holds is None:
            match = re.fullmatch(r"(>=|<=|>|<) (\S+)( .*)?", self.text)
            if match is None:
                raise ValueError(f"Bound {self.text!r} needs a test (holds=)")
            compare = {">": operator.gt, ">=": operator.ge, "<": operator.lt, "<=": operator.le}
            test, limit = compare[match.group(1)], float(match.group(2))
            object.__setattr__(self, "holds", lambda value: test(value, limit))

    def check(self, value: Any, key: str) -> None:
        """Raise ContentError at ``key`` unless ``value`` meets the bound."""
        if not self.holds(value):  # type: ignore[misc]
            raise ContentError(key, f"must be {self.text}, got {value!r}")


def iso_date(value: str, key: str) -> None:
    """A ``check`` (:func:`key`): refuse a date that is not ISO 8601 ``YYYY-MM-DD``."""
    try:
        ok = len(value) == 10 and datetime.date.fromisoformat(value).isoformat() == value
    except ValueError:
        ok = False
    if not ok:
        raise ContentError(key, f"must be a date YYYY-MM-DD, got {value!r}")


def key(
    default: Any = REQUIRED,
    *,
    doc: str,
    unit: str = "",
    bound: str | Bound | tuple[str | Bound, ...] = (),
    names: tuple[str, ...] | None = None,
    check: Callable[[Any, str], None] | None = None,
    absent: Any = REQUIRED,
    name: str | None = None,
    table: str | None = None,
    without: tuple[str, ...] = (),
    nan: bool = False,
    free_key: str = "key",
) -> Any:
    """A dataclass field that a TOML file holds.

    Parameters
    ----------
    default : optional
        The field's default, which is also the value when the file leaves the key out.
    doc : str
        What the key means.
    unit : str
        Its unit, as the docs and the written files' comments give it ('' for none).
    bound : str or Bound or tuple of them
        Conditions on the value (on each entry of an array), checked in order.
    names : tuple of str, optional
        An array's entries: it must have exactly these many.
    check : callable, optional
        ``check(value, dotted_key)`` raises ContentError where the value means nothing.
    absent : optional
        The value when the file leaves the key out, for a field without a default.
    name : str, optional
        The TOML key when it is not the field's name.
    table : str, optional
        The table ``[table]`` that holds this key of a whole file's class.
    without : tuple of str
        For a table: keys of its class that this table does not hold (they keep their
        defaults).
    nan : bool
        Whether a float (or each entry of an array of floats) may be NaN, an undefined
        value; infinities never may.
    free_key : str
        For a free table: what its keys stand for, as the docs name them
        (``inputs.<file>`` for ``free_key="file"``; :func:`accepted_keys`).

    Returns
    -------
    dataclasses.Field
        The field, its metadata holding all of the above for the reader, the writer and
        :func:`config_class`'s documentation.
    """
    bounds = (bound,) if isinstance(bound, (str, Bound)) else bound
    metadata = {
        "doc": doc,
        "unit": unit,
        "bounds": tuple(b if isinstance(b, Bound) else Bound(b) for b in bounds),
        "names": names,
        "check": check,
        "absent": absent,
        "name": name,
        "table": table,
        "without": without,
        "nan": nan,
        "free_key": free_key,
    }
    return dataclasses.field(default=default, metadata=metadata)


@typing.dataclass_transform(frozen_default=True, field_specifiers=(key, dataclasses.field))
def config_class(cls: type) -> type:
    """Make ``cls`` a frozen dataclass and document its keys in an Attributes section."""
    cls = dataclasses.dataclass(frozen=True)(cls)
    lines = []
    hints = typing.get_type_hints(cls)
    for field in dataclasses.fields(cls):
        meta = field.metadata
        if "doc" not in meta:
            continue
        facts = [f"unit {meta['unit']}"] if meta["unit"] else []
        bounds = [bound.text for bound in meta["bounds"]]
        choices = _choices(_kind(hints[field.name])[0])
        if choices:  # a StrEnum's values, checked first (_convert)
            bounds.insert(0, choices)
        if bounds:
            facts.append("must be " + " and ".join(bounds))
        if meta["nan"]:
            facts.append("may be nan")
        default = field.default if field.default is not REQUIRED else meta["absent"]
        if default is not REQUIRED and not dataclasses.is_dataclass(default):
            facts.append(f"default {default!r}")
        text = meta["doc"] + (f" ({'; '.join(facts)})" if facts else "")
        lines.append(f"{field.name} : {field.type}")
        lines += textwrap.wrap(text, 88, initial_indent="    ", subsequent_indent="    ")
    if lines:
        doc = inspect.cleandoc(cls.__doc__ or "")
        cls.__doc__ = doc + "\n\nAttributes\n----------\n" + "\n".join(lines) + "\n"
    return cls


# --- the keys of a class --------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Key:
    """One key of a config class, as :func:`key` declared it and the annotation types it."""

    field: str
    name: str
    kind: type
    """float, int, str, bool, a StrEnum, or a config class (a table)."""
    array: bool
    """An array of ``kind`` (of values, or of tables); a matrix too."""
    default: Any
    """The value when the file leaves the key out; REQUIRED when it must be there."""
    meta: typing.Mapping[str, Any]
    matrix: bool = False
    """An array of arrays of ``kind``, all of one length (``tuple[tuple[float, ...], ...]``)."""
    free: bool = False
    """A free table: any keys, each a value of ``kind`` (``dict[str, kind]``)."""


@functools.cache
def keys(cls: type) -> tuple[Key, ...]:
    """The keys of config class ``cls`` in field order."""
    hints = typing.get_type_hints(cls)
    found = []
    for field in dataclasses.fields(cls):
        if "doc" not in field.metadata:
            continue
        kind, form, optional = _kind(hints[field.name])
        array = form in ("array", "matrix")
        meta = field.metadata
        default = field.default if field.default is not REQUIRED else meta["absent"]
        if default is REQUIRED and optional:
            default = None
        if default is REQUIRED and is_table(kind) and not array and _all_defaults(kind):
            default = kind()
        name = meta["name"] or field.name
        found.append(
            Key(field.name, name, kind, array, default, meta, form == "matrix", form == "free")
        )
    return tuple(found)


def layout(cls: type, without: tuple[str, ...] = ()) -> dict[str, Key | tuple[Key, ...]]:
    """The entries of a table of class ``cls``, in field order, by their TOML name: a key
    (a value, a table or an array of tables), or the keys a ``[table]`` groups (``key(table=)``);
    the keys named in ``without`` left out."""
    out: dict[str, Any] = {}
    for entry in keys(cls):
        if entry.name in without:
            continue
        group = entry.meta["table"]
        if group is None:
            out[entry.name] = entry
        else:
            out[group] = (*out.get(group, ()), entry)
    return out


def accepted_keys(cls: type) -> dict[str, set[str]]:
    """Per table of a file of class ``cls`` ('' for the top level), the keys its reader
    accepts; tables named as in the file (``stage`` for ``[[stage]]``), a free table's keys
    as the one placeholder ``<free_key>``."""
    out: dict[str, set[str]] = {"": set(layout(cls))}
    for name, entry in layout(cls).items():
        if isinstance(entry, tuple):
            out[name] = {member.name for member in entry}
        elif is_table(entry.kind):
            out[name] = set(layout(entry.kind, entry.meta["without"]))
        elif entry.free:
            out[name] = {f"<{entry.meta['free_key']}>"}
    return out


def _kind(hint: Any) -> tuple[type, str, bool]:
    """(entry type, form, may be None) of a field's annotation; the form is 'value',
    'array', 'matrix' (an array of arrays) or 'free' (a free table)."""
    optional = False
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        args = [arg for arg in typing.get_args(hint) if arg is not type(None)]
        optional, (hint,) = True, args
    if hint is np.ndarray:
        return float, "array", optional
    if typing.get_origin(hint) is dict:
        return typing.get_args(hint)[1], "free", optional
    if typing.get_origin(hint) is tuple:
        (entry,) = set(typing.get_args(hint)) - {Ellipsis}
        if typing.get_origin(entry) is tuple:
            (entry,) = set(typing.get_args(entry)) - {Ellipsis}
            return entry, "matrix", optional
        return entry, "array", optional
    return hint, "value", optional


def is_table(kind: type) -> bool:
    """Whether ``kind`` is a config class (a TOML table)."""
    return dataclasses.is_dataclass(kind)


def _all_defaults(cls: type) -> bool:
    return all(entry.default is not REQUIRED for entry in keys(cls))


# --- reading ----------------------------------------------------------------------------------


def read_file(path: str | os.PathLike) -> dict[str, Any]:
    """Parse a TOML file; every failure becomes a one-line InputError."""
    try:
        with open(path, "rb") as file:
            data = file.read()
        # A byte-order mark (some Windows editors write one) is not TOML, but no fault of the
        # file's content: it is skipped, as the CSV readers skip it.
        return tomllib.loads(data.removeprefix(codecs.BOM_UTF8).decode("utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except OSError as error:
        raise InputError(f"{path}: cannot read: {error.strerror or error}") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text") from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"{path}: invalid TOML: {' '.join(str(error).split())}") from None


def read_table(cls: type, table: dict[str, Any], where: str = "", without=()) -> Any:
    """An instance of config class ``cls`` from a parsed TOML table.

    Parameters
    ----------
    cls : type
        The config class (:func:`config_class`).
    table : dict
        The table as tomllib gives it.
    where : str
        Its dotted key in the file, for messages ('' for a whole file).
    without : tuple of str
        Keys of ``cls`` that this table does not hold (they keep their defaults).

    Returns
    -------
    object
        The instance: every key converted, checked and defaulted.

    Raises
    ------
    ContentError
        An unknown key or table, a missing required one, a wrong type, a value out of its
        bounds or failing its check.
    """
    entries = layout(cls, without)
    _known(table, where, set(entries))
    values = {}
    for name, entry in entries.items():
        if isinstance(entry, Key):
            values[entry.field] = _value(table, where, entry)
            continue
        dotted = _dotted(where, name)
        required = any(member.default is REQUIRED for member in entry)
        holder = _table(table, name, dotted, required) or {}
        _known(holder, dotted, {member.name for member in entry})
        values |= {member.field: _value(holder, dotted, member) for member in entry}
    return cls(**values)


def _value(table: dict[str, Any], where: str, entry: Key) -> Any:
    dotted = _dotted(where, entry.name)
    if is_table(entry.kind):
        if entry.array:
            return tuple(
                read_table(entry.kind, holder, f"{dotted}[{k}]")
                for k, holder in enumerate(_tables(table, dotted, entry.name), 1)
            )
        holder = _table(table, entry.name, dotted, entry.default is REQUIRED)
        if holder is None:
            return entry.default
        return read_table(entry.kind, holder, dotted, entry.meta["without"])
    if entry.name not in table:
        if entry.default is REQUIRED:
            raise ContentError(dotted, "missing required key")
        # A free table's default is a dict: each reading gets its own.
        return copy.copy(entry.default) if entry.free else entry.default
    raw = table[entry.name]
    if entry.free:
        value = _free(raw, dotted, entry)
    elif entry.matrix:
        value = _matrix(raw, dotted, entry)
    elif entry.array:
        value = _array(raw, dotted, entry)
    else:
        value = _entry(raw, dotted, entry)
    if entry.meta["check"] is not None:
        entry.meta["check"](value, dotted)
    return value


def _entry(value: Any, dotted: str, entry: Key) -> Any:
    """One value of the key's type (a value, or an entry of an array, a matrix or a free
    table), checked against the key's bounds (NaN, where allowed, against none)."""
    value = _convert(value, entry.kind, dotted, entry.meta["nan"])
    if not (isinstance(value, float) and math.isnan(value)):
        for bound in entry.meta["bounds"]:
            bound.check(value, dotted)
    return value


def _array(values: Any, dotted: str, entry: Key) -> tuple:
    """An array's entries, each converted and checked against the key's bounds."""
    noun = "strings" if issubclass(entry.kind, str) else "numbers"
    if not isinstance(values, list):
        raise ContentError(dotted, f"must be an array of {noun}, got {_describe(values)}")
    names = entry.meta["names"]
    if names is not None and len(values) != len(names):
        raise ContentError(
            dotted, f"must have {len(names)} entries [{', '.join(names)}], got {len(values)}"
        )
    return tuple(_entry(value, f"{dotted}[{k}]", entry) for k, value in enumerate(values, 1))


def _matrix(rows: Any, dotted: str, entry: Key) -> tuple:
    """A matrix's rows, each an array (:func:`_array`) as long as the first."""
    if not isinstance(rows, list):
        raise ContentError(dotted, f"must be an array of arrays, got {_describe(rows)}")
    out = []
    for k, row in enumerate(rows, 1):
        if not isinstance(row, list):
            raise ContentError(f"{dotted}[{k}]", f"must be an array, got {_describe(row)}")
        if out and len(row) != len(out[0]):
            raise ContentError(
                f"{dotted}[{k}]", f"must have {len(out[0])} entries as row 1, got {len(row)}"
            )
        out.append(_array(row, f"{dotted}[{k}]", entry))
    return tuple(out)


def _free(holder: Any, dotted: str, entry: Key) -> dict:
    """A free table's keys and values, each value converted and checked."""
    if not isinstance(holder, dict):
        raise ContentError(dotted, f"must be a table, got {_describe(holder)}")
    return {
        name: _entry(value, _dotted(dotted, _quoted(name)), entry) for name, value in holder.items()
    }


def _table(table: dict[str, Any], name: str, dotted: str, required: bool) -> dict | None:
    """The table ``table[name]`` (at ``dotted`` in the file); None if it may be left out and
    is."""
    if name not in table:
        if required:
            raise ContentError(dotted, f"missing required table [{dotted}]")
        return None
    holder = table[name]
    if not isinstance(holder, dict):
        raise ContentError(dotted, f"must be a table, got {_describe(holder)}")
    return holder


def _tables(table: dict[str, Any], dotted: str, name: str) -> list[dict[str, Any]]:
    """The array of tables ``[[name]]``: at least one, each a table."""
    if name not in table:
        raise ContentError(dotted, f"missing required [[{dotted}]] array")
    holders = table[name]
    if not isinstance(holders, list):
        raise ContentError(
            dotted, f"must be an array of tables ([[{dotted}]]), got {_describe(holders)}"
        )
    if not holders:
        raise ContentError(dotted, f"must have at least one [[{dotted}]]")
    for k, holder in enumerate(holders, 1):
        if not isinstance(holder, dict):
            raise ContentError(f"{dotted}[{k}]", f"must be a table, got {_describe(holder)}")
    return holders


def _known(table: dict[str, Any], where: str, allowed: set[str]) -> None:
    """Reject keys the contract does not define (typos would otherwise become defaults)."""
    for name, value in table.items():
        if name not in allowed:
            kind = "table" if not where and isinstance(value, (dict, list)) else "key"
            raise ContentError(_dotted(where, name), f"unknown {kind}")


def _convert(value: Any, kind: type, key: str, nan: bool = False) -> Any:
    """Check the TOML type of ``value``; integers are accepted as floats, booleans never;
    NaN only where ``nan``."""
    if issubclass(kind, str):
        if not isinstance(value, str):
            raise ContentError(key, f"must be a string, got {_describe(value)}")
        if issubclass(kind, enum.StrEnum):
            if value not in kind._value2member_map_:
                raise ContentError(key, f"must be {_choices(kind)}, got {value!r}")
            return kind(value)
        return value
    if kind is bool:
        if not isinstance(value, bool):
            raise ContentError(key, f"must be a boolean, got {_describe(value)}")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ContentError(key, f"must be an integer, got {_describe(value)}")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ContentError(key, f"must be a number, got {_describe(value)}")
    value = float(value)
    if not (math.isfinite(value) or (nan and math.isnan(value))):
        raise ContentError(key, f"must be finite, got {value!r}")
    return value


def _choices(kind: type) -> str:
    """"one of 'a', 'b'" for a StrEnum's values; "" for any other type."""
    if not (isinstance(kind, type) and issubclass(kind, enum.StrEnum)):
        return ""
    return "one of " + ", ".join(repr(member.value) for member in kind)


def _describe(value: Any) -> str:
    """A short phrase for a TOML value of the wrong type, for messages."""
    if isinstance(value, bool):
        return f"a boolean ({str(value).lower()})"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return f"a string ({value!r})"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "a table"
    return f"a {type(value).__name__}"


def _dotted(where: str, name: str) -> str:
    return f"{where}.{name}" if where else name


def _quoted(name: str) -> str:
    """A free table's key as TOML spells it: bare, or in quotes."""
    if re.fullmatch(r"[A-Za-z0-9_-]+", name):
        return name
    return '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'
