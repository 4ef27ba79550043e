"""`rsp-inertia design`: the report and the Fig. 1 plot through the command line."""

from __future__ import annotations

from pathlib import Path

from rsp_inertia.cli import main

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
    from rsp_inertia.pipeline import create_default_experiment

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
