"""Fixtures of the virtual device's tests."""

import dataclasses

import pytest


@pytest.fixture(scope="module")
def virtual(default_virtual):
    """The default truth without torque noise, so that logged torques are exact."""
    run = dataclasses.replace(default_virtual.run, torque_noise=0.0)
    return dataclasses.replace(default_virtual, run=run)
