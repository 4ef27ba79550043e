"""The virtual experiments the package writes: the paper's scenario, the demo's rig and its
calibration folders, and the demo's second mounting of its body.

Each writes an experiment's inputs (device.toml, virtual.toml, reference.toml) from the
embedded defaults (plant/defaults/) and keeps every file already there, so a user can edit
them and run again. :func:`rsp_inertia.create_experiment` is :func:`create_default_experiment`.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import tomlkit

from rsp_inertia.infra.files import write_atomic
from rsp_inertia.plant.experiment import (
    DEVICE_FILE,
    REFERENCE_FILE,
    VIRTUAL_FILE,
    open_experiment,
)

__all__ = [
    "CALIBRATION_FOLDERS",
    "SECOND_MOUNTING",
    "TURNED_X90",
    "create_default_experiment",
    "create_rig_experiment",
    "create_second_mounting",
]


def create_default_experiment(root: str | Path) -> Path:
    """Write the default experiment's device.toml and virtual.toml into ``root``.

    The default is the paper's scenario (plant/defaults/). Files already present are kept
    as they are (an experiment's inputs are never overwritten), so a user can edit them and
    rerun the demo.
    """
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    for name in (DEVICE_FILE, VIRTUAL_FILE):
        target = root / name
        if not target.exists():
            text = resources.files("rsp_inertia.plant").joinpath("defaults", name).read_text()
            write_atomic(target, text)
    return root


CALIBRATION_FOLDERS = ("empty", "reference")
"""The demo's calibration experiments, in EXP/calibration/: the empty fixture, the reference."""


def create_rig_experiment(root: str | Path) -> tuple[Path, Path, Path]:
    """Write the demo's rig experiment and its calibration experiments (plant/defaults/rig/).

    The paper's body on a virtual rig with a real one's imperfections (a torque gain, tares
    that device.toml knows only to 1%, an unbalanced fixture, friction 2% larger turning
    backward), every stage run both ways round, and the calibration runs: ``root`` (the
    body), ``root/calibration/empty`` and ``root/calibration/reference`` (with
    reference.toml). Files already present are kept as they are.

    Returns
    -------
    (root, empty, reference) : paths
    """
    root = Path(root)
    folders = [root] + [root / "calibration" / name for name in CALIBRATION_FOLDERS]
    sources = [("rig",)] + [("rig", name) for name in CALIBRATION_FOLDERS]
    for folder, source in zip(folders, sources):
        folder.mkdir(parents=True, exist_ok=True)
        files = resources.files("rsp_inertia.plant").joinpath("defaults", *source)
        for name in (DEVICE_FILE, VIRTUAL_FILE, REFERENCE_FILE):
            target = folder / name
            if not target.exists() and files.joinpath(name).is_file():
                write_atomic(target, files.joinpath(name).read_text())
    return root, folders[1], folders[2]


SECOND_MOUNTING = "mounting-x90"
"""The demo's second mounting of its body, a subfolder of its experiment."""

TURNED_X90 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""A quarter turn about the rig's x axis: takes the body direction on the shaft across it."""


def create_second_mounting(root: str | Path) -> Path:
    """``root/mounting-x90``: the experiment ``root``'s body mounted again, turned 90 deg
    about the rig's x axis (device.toml ``[mounting] rotation`` = TURNED_X90 times root's),
    on the same rig (root's device.toml and virtual.toml otherwise). Files already present
    are kept as they are; returns the folder."""
    root = Path(root)
    folder = root / SECOND_MOUNTING
    folder.mkdir(exist_ok=True)
    device = folder / DEVICE_FILE
    if not device.exists():
        first = open_experiment(root, protocol=False).device.mounting
        rotation = TURNED_X90 @ (np.eye(3) if first is None else first.rotation)
        table = tomlkit.table()
        table["rotation"] = [[float(c) + 0.0 for c in row] for row in rotation]
        table["origin"] = [0.0, 0.0, 0.0] if first is None else [float(c) for c in first.origin]
        doc = tomlkit.parse((root / DEVICE_FILE).read_text())
        doc["mounting"] = table
        write_atomic(device, tomlkit.dumps(doc))
    virtual = folder / VIRTUAL_FILE
    if not virtual.exists():
        write_atomic(virtual, (root / VIRTUAL_FILE).read_text())
    return folder
