"""Config instances written as TOML files that their readers give back equal.

The writer walks the fields of a config class (rsp_inertia.infra.toml_schema) as the reader
does: every key whose value is not None, in field order, each with its unit as a comment (a
matrix one row per line, a free table's keys in their order). Before anything is written, the
text is read back with the file's reader; a value the reader refuses, or one that would not
come back equal, is refused.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from collections.abc import Callable
from typing import Any

import numpy as np
import tomlkit

from rsp_inertia.infra.files import write_atomic
from rsp_inertia.infra.toml_schema import ContentError, Key, is_table, layout


def write_text(value: Any, header: str) -> str:
    """The TOML text of config instance ``value``: ``header`` as a comment, then every key
    that is not None, in field order, with its unit as a comment."""
    doc = tomlkit.document()
    for line in header.splitlines():
        doc.add(tomlkit.comment(line))
    doc.add(tomlkit.nl())
    _fill(doc, value)
    return tomlkit.dumps(doc)


def document(value: Any) -> dict[str, Any]:
    """The parsed TOML document of config instance ``value``: plain dicts, lists, strings,
    numbers and booleans, as tomllib reads :func:`write_text`'s text."""
    doc = tomlkit.document()
    _fill(doc, value)
    return doc.unwrap()


def _fill(container: Any, value: Any, without: tuple[str, ...] = ()) -> None:
    for name, entry in layout(type(value), without).items():
        if isinstance(entry, Key):
            _put(container, entry, getattr(value, entry.field))
            continue
        table = tomlkit.table()
        for member in entry:
            _put(table, member, getattr(value, member.field))
        container.add(name, table)


def _put(container: Any, entry: Key, value: Any) -> None:
    if value is None:
        return
    if is_table(entry.kind):
        if entry.array:
            tables = tomlkit.aot()
            for element in value:
                table = tomlkit.table()
                _fill(table, element)
                tables.append(table)
            container.add(entry.name, tables)
        else:
            table = tomlkit.table()
            _fill(table, value, entry.meta["without"])
            container.add(entry.name, table)
        return
    if entry.free:
        table = tomlkit.table()
        for name, entry_value in value.items():
            table.add(name, entry.kind(entry_value))
        container.add(entry.name, table)
        return
    if entry.matrix:
        item = tomlkit.array()
        for row in value:
            item.append([entry.kind(v) for v in row])
        item.multiline(True)
    elif entry.array:
        item = tomlkit.item([entry.kind(v) for v in value])
    else:
        item = tomlkit.item(entry.kind(value))
    if entry.meta["unit"]:
        item.comment(entry.meta["unit"])
        item.trivia.comment_ws = "  "
    container.add(entry.name, item)


def write_file(
    path: str | os.PathLike, value: Any, header: str, read: Callable[[dict[str, Any]], Any]
) -> None:
    """Write config instance ``value`` to ``path`` atomically, after checking that ``read``
    gives ``value`` back.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its folder must exist.
    value : object
        The config instance (rsp_inertia.infra.toml_schema.config_class).
    header : str
        The file's header, written as a comment (one per line).
    read : callable
        The file's reader, from the parsed document to the instance (raising ContentError).

    Raises
    ------
    ValueError
        ``value`` breaks a rule of its file (the reader's one-line message, the path in
        front) or holds something the file cannot (a key the table does not have, a field
        no file holds).
    """
    text = checked_text(value, header, read, str(path))
    write_atomic(path, text)


def checked_text(
    value: Any, header: str, read: Callable[[dict[str, Any]], Any], source: str
) -> str:
    """:func:`write_text`'s text of config instance ``value``, once ``read`` gives ``value``
    back from it.

    Parameters
    ----------
    value : object
        The config instance (rsp_inertia.infra.toml_schema.config_class).
    header : str
        The file's header, written as a comment (one per line).
    read : callable
        The file's reader, from the parsed document to the instance (raising ContentError).
    source : str
        The file's name, in front of messages.

    Returns
    -------
    str
        The TOML text.

    Raises
    ------
    ValueError
        As :func:`write_file`, the message beginning with ``source`` (the file's name).
    """
    text = write_text(value, header)
    try:
        back = read(tomllib.loads(text))
    except ContentError as error:
        raise ValueError(f"{source}: {error}") from None
    fault = difference(value, back)
    if fault is not None:
        raise ValueError(f"{source}: {fault}")
    return text


def difference(written: Any, read: Any, where: str = "") -> str | None:
    """Where config instance ``written`` and its file's reading ``read`` first differ.

    Parameters
    ----------
    written : object
        What was written: a config instance, or one of its values.
    read : object
        What the reader gave back from the text.
    where : str
        The dotted field of ``written`` (for the message; '' at the top).

    Returns
    -------
    str or None
        ``"{dotted field}: {written!r} would be read back as {read!r}"`` at the first
        difference, None when they are equal (arrays entry by entry, NaN equal to NaN).
    """
    if dataclasses.is_dataclass(written) and type(written) is type(read):
        for field in dataclasses.fields(written):
            child = f"{where}.{field.name}" if where else field.name
            found = difference(getattr(written, field.name), getattr(read, field.name), child)
            if found is not None:
                return found
        return None
    arrays = (tuple, list, np.ndarray)
    if isinstance(written, arrays) or isinstance(read, arrays):
        same = (
            isinstance(written, arrays)
            and isinstance(read, arrays)
            and len(written) == len(read)
            and all(difference(a, b) is None for a, b in zip(written, read, strict=True))
        )
    elif isinstance(written, float) and isinstance(read, float):
        same = written == read or (math.isnan(written) and math.isnan(read))
    else:
        same = written == read
    return None if same else f"{where}: {written!r} would be read back as {read!r}"
