"""theta and the tensor fit's unknowns are laid out once (rsp_inertia.estimation.layout), and
every slice, index and name list of them is derived from that layout.

The layout's slices tile the vector exactly; KnownTerms, calibration.toml's covariance and the
calibration fit name theta's entries by the layout's names, and the tensor fit's shared
unknowns are the layout's. A scan of estimation/ finds no hand-written stage offset (the
arithmetic the layout replaced, ``2 + 5 * (stage - 1)``), and the scan can fail.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import rsp_inertia.estimation
from rsp_inertia.estimation import calibration
from rsp_inertia.estimation.calibration_file import CalibrationFile
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.layout import (
    SHARED_LAYOUT,
    Layout,
    Segment,
    encoder_names,
    theta_layout,
)
from rsp_inertia.estimation.tensor_fit import tensor_block
from rsp_inertia.plant.config import TrueBody
from rsp_inertia.plant.geometry import ENTRY_KEYS, GRAVITY_NAMES, HARMONIC_NAMES

SHAPES = [(stages, orders) for stages in (1, 2, 3) for orders in (0, 1, 3)]


def _positions(layout: Layout) -> list[int]:
    """Every position each segment's slices cover, stage by stage, in the segments' order."""
    out = []
    for segment in layout.segments:
        stages = range(1, layout.stages + 1) if segment.per_stage else [None]
        for stage in stages:
            out += list(range(layout.size)[layout.slice(segment.name, stage)])
    return out


@pytest.mark.parametrize("stages, orders", SHAPES)
def test_the_slices_tile_theta_exactly(stages: int, orders: int) -> None:
    layout = theta_layout(stages, orders)
    assert _positions(layout) == list(range(layout.size))
    assert layout.size == 2 + 5 * stages + 2 + 1 + 2 * orders  # the hand count, once, here
    names = layout.names()
    assert len(names) == layout.size == len(set(names))
    assert names[layout.slice("harmonics", stages)] == [f"{h}[{stages}]" for h in HARMONIC_NAMES]
    assert layout.names("encoder") == list(encoder_names(orders))
    assert layout.indices("harmonics", "gravity") == list(
        range(layout.slice("harmonics").start, layout.slice("gravity").stop)
    )


def test_a_gap_or_an_overlap_is_seen() -> None:
    """The tiling check can fail: positions that skip or repeat are not range(size)."""
    layout = theta_layout(2, 1)
    positions = _positions(layout)
    assert positions[:-1] != list(range(layout.size))
    assert positions + positions[:1] != list(range(layout.size))
    with pytest.raises(ValueError):
        layout.slice("gains", 1)  # not per stage
    with pytest.raises(ValueError):
        layout.slice("harmonics", 3)  # no such stage
    with pytest.raises(KeyError):
        layout.slice("tare")
    with pytest.raises(ValueError):
        Layout((Segment("a", ("x",)), Segment("a", ("y",))))


@pytest.mark.parametrize("stages, orders", SHAPES)
def test_known_terms_are_laid_out_by_the_layout(stages: int, orders: int) -> None:
    rng = np.random.default_rng(stages + 10 * orders)
    layout = theta_layout(stages, orders)
    known = KnownTerms(
        tuple(rng.normal(size=2)),
        rng.normal(size=(stages, 5)),
        rng.normal(size=2),
        np.zeros((layout.size, layout.size)),
        encoder=rng.normal(size=2 * orders),
        zero=rng.normal(),
    )
    assert known.layout == layout and known.names() == layout.names()
    theta = known.theta
    np.testing.assert_array_equal(theta[layout.slice("gains")], known.gains)
    for s in range(1, stages + 1):
        np.testing.assert_array_equal(theta[known.harmonics_slice(s)], known.inertia[s - 1])
    np.testing.assert_array_equal(theta[known.gravity_slice], known.gravity)
    np.testing.assert_array_equal(theta[known.encoder_slice], known.encoder)
    assert theta[known.zero_slice] == [known.zero]
    again = known.with_theta(theta, known.cov)
    np.testing.assert_array_equal(again.theta, theta)
    groups = known.budget_groups()
    assert sorted(i for indices in groups.values() for i in indices) == list(range(layout.size))
    assert KnownTerms.exact(stages, known.encoder).cov.shape == (layout.size, layout.size)


def test_calibration_file_names_theta_by_the_layout() -> None:
    """calibration.toml's covariance parameters are the layout's names, as written and as
    the file's tables imply them."""
    cal = calibration.Calibration("x", 1, (0.5, 2.0), ((0.0,), (0.0,)),
                                  KnownTerms.exact(2, np.zeros(6)), True)
    file = cal.to_file()
    assert list(file.covariance.parameters) == theta_layout(2, 3).names()
    assert CalibrationFile.parameters(file) == theta_layout(2, 3).names()




def test_the_fits_unknowns_are_named_by_the_layouts(default_device, default_balances) -> None:
    """The calibration fit's theta unknowns are the layout's names (its fit with a reference
    that shows the rig's orientation has every segment), and the tensor fit's blocks have the
    shared layout's columns."""
    theta = theta_layout(len(default_device.stages), calibration.ENCODER_ORDERS)
    turned = TrueBody(mass=3.0, inertia=[0.03, 0.032, 0.02, 0.001, -0.002, 0.0015],
                      com=[0.0, 0.01, 0.0])
    blocks = calibration._blocks(default_device, default_balances, "empty", None, True,
                                 calibration.ENCODER_ORDERS, orientation=True)
    blocks += calibration._blocks(default_device, default_balances, "reference", turned, True,
                                  calibration.ENCODER_ORDERS, orientation=True)
    unknowns = {n for b in blocks for n in (*b.columns, *b.inertia_scaled_columns)}
    assert set(theta.names()) <= unknowns
    assert {n for n in unknowns if n in theta.names()} == set(theta.names())
    known = KnownTerms.from_tares([bal.tare_inertia for bal in default_balances])
    block = tensor_block(default_balances[0], "0", known, False)
    assert list(block.columns)[: SHARED_LAYOUT.size] == SHARED_LAYOUT.names()


def test_the_tensor_fits_shared_unknowns_are_the_layouts() -> None:
    assert SHARED_LAYOUT.names() == [*ENTRY_KEYS, *GRAVITY_NAMES]
    assert SHARED_LAYOUT.slice("entries") == slice(0, 6)
    assert SHARED_LAYOUT.slice("gravity") == slice(6, 8)


STAGE_OFFSET = re.compile(
    r"\b\d+\s*\*\s*\(?\s*(?:stage|stages|n_stages|len\((?:self\.inertia|device\.stages|"
    r"self\.stages)\))\b"
    r"|\b\d+\s*\+\s*\d+\s*\*\s*\(?\s*(?:stage|stages|len\b)"
)
"""Hand-written arithmetic of a per-stage offset: ``5 * (stage - 1)``, ``2 + 5 * stages``,
``4 + 5 * len(self.inertia)``."""


def _offsets(text: str) -> list[str]:
    return [line.strip() for line in text.splitlines() if STAGE_OFFSET.search(line)]


def test_no_hand_written_stage_offsets_in_estimation() -> None:
    root = Path(rsp_inertia.estimation.__file__).parent
    found = {
        path.name: _offsets(path.read_text())
        for path in sorted(root.glob("*.py"))
        if _offsets(path.read_text())
    }
    assert found == {}, f"stage offsets written by hand (use the layout): {found}"


@pytest.mark.parametrize(
    "line",
    [
        "return slice(2 + 5 * (stage - 1), 7 + 5 * (stage - 1))",
        "start = 2 + 5 * len(self.inertia)",
        "size = 2 + 5 * stages + 2 + encoder.size",
        "cov = np.zeros((4 + 5 * n_stages,) * 2)",
    ],
)
def test_the_offset_scan_finds_the_old_arithmetic(line: str) -> None:
    assert _offsets(line) == [line]
