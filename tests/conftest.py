"""Shared fixtures: the default experiment of ``rsp-inertia demo`` (plant/defaults/)."""

import dataclasses
import os
import shutil
from pathlib import Path

import pytest

# result.json records when identify made it; with a fixed SOURCE_DATE_EPOCH (the
# reproducible-builds convention, rsp_inertia.provenance.created_now) the same inputs give
# the same bytes, which several tests compare. tests/test_report.py checks the clock's own.
os.environ["SOURCE_DATE_EPOCH"] = "1795000000"

import rsp_inertia.plant
from rsp_inertia.plant.config import Device, load_device
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import Virtual, load_virtual

DEFAULTS = Path(rsp_inertia.plant.__file__).parent / "defaults"
"""The embedded default experiment: the paper's icosahedron design on a virtual gimbal."""


@pytest.fixture(scope="session")
def default_device() -> Device:
    """The gimbal of plant/defaults/device.toml (two stages, lam = 0.764 and 5.236)."""
    return load_device(DEFAULTS / "device.toml")


@pytest.fixture(scope="session")
def default_virtual() -> Virtual:
    """The true body, friction and run settings of plant/defaults/virtual.toml."""
    return load_virtual(DEFAULTS / "virtual.toml")


@pytest.fixture(scope="module")
def virtual(default_virtual):
    """The default truth without torque noise, so that logged torques are exact (the virtual
    device's tests, and the plant's that drive it)."""
    run = dataclasses.replace(default_virtual.run, torque_noise=0.0)
    return dataclasses.replace(default_virtual, run=run)


@pytest.fixture(scope="session")
def default_logs(tmp_path_factory) -> Path:
    """The default experiment with its braking and ideal reverse logs, simulated once per
    session (about 3 s): a test takes its own copy (:func:`copy_experiment`), never this
    folder itself."""
    root = create_default_experiment(tmp_path_factory.mktemp("default-logs") / "exp")
    simulate(root, part="braking")
    simulate(root, part="reverse", ideal=True)
    return root


def copy_experiment(source: Path, root: Path) -> Path:
    """A copy of the experiment folder ``source`` at ``root`` (created): the folder a test may
    change.

    Parameters
    ----------
    source : pathlib.Path
        The folder to copy (a session fixture's, such as ``default_logs``).
    root : pathlib.Path
        Where the copy goes; its parent must exist and it must not.

    Returns
    -------
    pathlib.Path
        ``root``.
    """
    return Path(shutil.copytree(source, root))
