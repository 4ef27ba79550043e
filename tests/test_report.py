"""``rsp-inertia report``: one self-contained HTML file from an identified experiment."""

from __future__ import annotations

import hashlib
import json
import re

from rsp_inertia.cli import main
from rsp_inertia.pipeline import create_default_experiment, identify, simulate


def test_report_is_self_contained_and_says_what_went_in(tmp_path, capsys):
    root = create_default_experiment(tmp_path / "exp")
    assert main(["report", str(root)]) == 2  # not identified yet: one line, nothing written
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "run rsp-inertia identify" in err
    assert not (root / "report.html").exists()

    simulate(root, part="braking")
    simulate(root, part="reverse", ideal=True)
    identify(root)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 2))
    FigureCanvasAgg(fig).print_png(str(root / "errors.png"))
    assert main(["report", str(root)]) == 0
    page = (root / "report.html").read_text()
    result = json.loads((root / "result.json").read_text())
    for name, value in result["tensor"].items():
        assert f"<td>{name}</td><td>{value:.8g}</td>" in page
    digest = hashlib.sha256((root / "device.toml").read_bytes()).hexdigest()
    assert f"<td>device.toml</td><td>{digest}</td>" in page
    assert "stage1/braking.csv" in page and "virtual.toml" not in page
    assert "<td>numpy</td>" in page and "<td>casadi</td>" in page
    assert "data:image/png;base64," in page
    # Nothing is fetched: no external source or link.
    assert not re.search(r"(src|href)=['\"]?(https?:|//)", page)
