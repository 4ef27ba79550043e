"""Axis-design report and Fig. 1 (docs/method.md §5), directly and through `rsp-inertia design`."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rsp_inertia.cli import main
from rsp_inertia.design.mountings import best_cone_opening
from rsp_inertia.plant.geometry import cone_plus_z_design, icosahedron_design
from rsp_inertia.plots import plot_cone_conditioning
from rsp_inertia.results import axis_design_report

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def test_design_prints_both_designs_and_writes_the_plot(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["design"]) == 0
    out = capsys.readouterr().out
    assert "icosahedron" in out and "cone+z" in out
    assert "min 63.4349  max 63.4349" in out  # all 15 icosahedron angles
    assert "cond(V) = 1.5811" in out
    assert "cond(V) = 1.489" in out  # the cone + z optimum
    png = Path(tmp_path / "design.png").read_bytes()
    assert png.startswith(PNG_SIGNATURE) and len(png) > 10_000


def test_design_of_an_experiment(tmp_path, capsys):
    from rsp_inertia.scenarios import create_default_experiment

    create_default_experiment(tmp_path)
    plot = tmp_path / "fig.png"
    assert main(["design", str(tmp_path), "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    assert "Axis design: device" in out
    assert plot.read_bytes().startswith(PNG_SIGNATURE)


def test_design_of_a_missing_experiment_is_one_line(tmp_path, capsys):
    assert main(["design", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "device.toml" in err


def test_report_states_the_icosahedron_and_the_cone_optimum() -> None:
    opening, _ = best_cone_opening()
    report = axis_design_report([icosahedron_design(), cone_plus_z_design(opening)])
    assert "icosahedron" in report
    # arccos(1/sqrt 5) = 63.4349 deg between every pair of axes; cond(V) = sqrt(5/2).
    assert "63.43" in report
    assert "cond(V) = 1.5811" in report
    reported = float(re.search(r"2beta = ([0-9.]+) deg", report).group(1))
    assert abs(reported - 142.0) < 1.0
    assert "cond(V) = 1.4892" in report


def test_report_lists_every_axis() -> None:
    report = axis_design_report([icosahedron_design()])
    # One table row per axis: index, stage, lambda, 2beta, node, ex, ey, ez.
    axis_row = re.compile(r"\s+\d+\s+[12]" + r"\s+-?\d+\.\d+" * 6 + r"\s*$")
    rows = [line for line in report.splitlines() if axis_row.match(line)]
    assert len(rows) == 6


def test_plot_writes_a_png(tmp_path: Path) -> None:
    out = tmp_path / "cone_conditioning.png"
    plot_cone_conditioning(out)
    data = out.read_bytes()
    assert data.startswith(PNG_SIGNATURE)
    assert len(data) > 1000
    # Atomic write: no temporary file left behind.
    assert [p.name for p in tmp_path.iterdir()] == [out.name]


def test_plot_accepts_its_own_openings(tmp_path: Path) -> None:
    out = tmp_path / "coarse.png"
    plot_cone_conditioning(str(out), openings_deg=[60.0, 100.0, 140.0, 170.0])
    assert out.read_bytes().startswith(PNG_SIGNATURE)


def test_mounting_conditioning_closed_form():
    # As drawn, the gravity terms see body x and y; turned 90 deg about x, body x and z.
    # G^T G = diag(2, 1, 1): x_c's std 1/sqrt 2 of one mounting's, y_c's and z_c's 1.
    import math

    import numpy as np

    from rsp_inertia.design.mountings import mounting_conditioning

    turned = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    condition, gain = mounting_conditioning([np.eye(3), turned])
    assert condition == pytest.approx(math.sqrt(2))
    assert gain == pytest.approx([1 / math.sqrt(2), 1.0, 1.0])
    condition, gain = mounting_conditioning([np.eye(3)])
    assert math.isinf(condition) and math.isinf(gain[2]) and gain[:2] == pytest.approx(1.0)


def test_design_of_two_mountings_reports_the_centre_of_mass(tmp_path, capsys):
    from rsp_inertia.cli import main
    from rsp_inertia.scenarios import create_default_experiment

    folders = []
    for name, rows in (("a", None), ("b", "[[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]")):
        root = create_default_experiment(tmp_path / name)
        if rows:
            with open(root / "device.toml", "a") as file:
                file.write(f"\n[mounting]\nrotation = {rows}\n")
        folders.append(str(root))
    assert main(["design", folders[0], "--plot", str(tmp_path / "d.png")]) == 0
    assert "Mountings" not in capsys.readouterr().out  # one mounting as drawn: nothing to say
    assert main(["design", *folders, "--plot", str(tmp_path / "d.png")]) == 0
    out = capsys.readouterr().out
    assert "std of x_c, y_c, z_c over one mounting's std of x_c: 0.707, 1.000, 1.000" in out


def test_design_result_is_what_the_command_prints(tmp_path, capsys):
    """The command's result object (rsp_inertia.api.axis_designs): ``str`` is the printed
    report, ``to_json`` its numbers, ``figures`` redraws the same PNG; a result made without
    its drawer says so."""
    import dataclasses
    import json

    from rsp_inertia import api

    plot = tmp_path / "a.png"
    result = api.axis_designs(plot=plot)
    written = plot.read_bytes()
    assert main(["design", "--plot", str(plot)]) == 0
    assert capsys.readouterr().out == f"{result}\n"
    document = json.loads(result.to_json())
    assert [d["name"][:6] for d in document["designs"]] == ["icosah", "cone+z"]
    assert document["mountings"] is None and document["figure"] == str(plot)
    assert document["best_condition"] == pytest.approx(1.4892, abs=1e-4)
    assert len(document["designs"][0]["axes"]) == 6
    again = result.figures(tmp_path / "again")
    assert again == [tmp_path / "again" / "a.png"] and again[0].read_bytes() == written
    with pytest.raises(TypeError, match="without its drawer"):
        dataclasses.replace(result, drawer=None).draw()
