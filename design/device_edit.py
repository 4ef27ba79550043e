"""The device.toml edit that ``plan`` makes: each stage's chosen protocol written in place.

``launch_speed``, ``braking_torque`` (a two-level braking's ``braking_torque_2`` and
``braking_switch_turns`` too; a one-level protocol takes them out) and the release the plan
assumed (``release_angle_deg``) go into each ``[[stage]]`` table of device.toml, the file's comments and key order kept
(tomlkit); a key the stage lacked is added with its unit as a comment. The file is written
atomically.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

import tomlkit

from rsp_inertia.design.candidates import Candidate, planned_release
from rsp_inertia.infra.files import write_atomic
from rsp_inertia.plant.config import Device

__all__ = ["set_key", "write_protocols"]


def set_key(table, name: str, value: float, unit: str) -> None:
    """``name = value`` in a ``[[stage]]`` table of device.toml: in place where the key is
    (its comment kept), else added with its unit as a comment.

    Parameters
    ----------
    table : tomlkit.items.Table
        The stage's table, as tomlkit parsed it.
    name : str
        The key.
    value : float
        Its new value.
    unit : str
        The comment of a key that is added.
    """
    if name in table:
        table[name] = value
    else:
        table[name] = tomlkit.item(value).comment(unit)


def write_protocols(
    path: str | os.PathLike, device: Device, chosen: Iterable[Candidate]
) -> None:
    """Write each chosen protocol into its stage of device.toml (module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        device.toml.
    device : Device
        What it held before (the release a stage states is kept).
    chosen : iterable of Candidate
        One protocol per stage planned (``stage``, ``launch_speed``, ``braking_torque``).
    """
    doc = tomlkit.parse(Path(path).read_text())
    for c in chosen:
        table = doc["stage"][c.stage - 1]
        set_key(table, "launch_speed", c.launch_speed, "rad/s")
        set_key(table, "braking_torque", c.braking_torque, "N m")
        if c.braking_torque_2 is None:  # one level: a two-level braking's keys go
            for name in ("braking_torque_2", "braking_switch_turns"):
                if name in table:
                    del table[name]
        else:
            set_key(table, "braking_torque_2", c.braking_torque_2, "N m")
            set_key(table, "braking_switch_turns", c.braking_switch_turns, "turns")
        table["release_angle_deg"] = planned_release(device.stages[c.stage - 1])
    write_atomic(path, tomlkit.dumps(doc))
