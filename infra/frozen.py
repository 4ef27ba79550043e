"""Read-only arrays for frozen records: a frozen dataclass forbids assigning a field, not
writing into the array a field holds; these make the arrays read-only too.

A record made frozen with :func:`freeze_arrays` (in its ``__post_init__``) holds its own
read-only copies of the arrays it was given, so that neither the caller who built it nor one
who reads it can change it afterwards (``record.entries[0] = 0`` raises ValueError).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

__all__ = ["freeze_arrays", "read_only"]


def read_only(value: Any) -> Any:
    """``value`` with every NumPy array in it a read-only copy.

    Parameters
    ----------
    value : object
        An array, a dict, list or tuple holding arrays (at any depth), or anything else.

    Returns
    -------
    object
        An array: its read-only copy (one already read-only and owning its data is returned
        as is). A dict, list or tuple: a new one of the same kind whose arrays are read-only.
        Anything else: ``value`` itself.
    """
    if isinstance(value, np.ndarray):
        if not value.flags.writeable and value.base is None:
            return value
        array = value.copy()
        array.flags.writeable = False
        return array
    if isinstance(value, dict):
        return {key: read_only(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)) and not hasattr(value, "_fields"):
        return type(value)(read_only(item) for item in value)
    return value


def freeze_arrays(record: Any) -> None:
    """Make the arrays a frozen dataclass's fields hold read-only copies (:func:`read_only`);
    call it in the record's ``__post_init__``.

    Parameters
    ----------
    record : dataclass instance
        Its fields holding arrays (directly, or in dicts, lists and tuples) are replaced by
        read-only copies; other fields are left as they are.
    """
    for item in dataclasses.fields(record):
        value = getattr(record, item.name)
        frozen = read_only(value)
        if frozen is not value:
            object.__setattr__(record, item.name, frozen)
