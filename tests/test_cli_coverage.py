"""``identify --coverage-factor K``: k reaches result.json, the printed output and the report;
a k that is not a finite number above 0 is bad input (exit 2, nothing written); the report
says when principal axes are not determined."""

import contextlib
import io
import json

import numpy as np
import pytest

import rsp_inertia
from rsp_inertia.cli import main
from rsp_inertia.estimation.coverage import expanded_uncertainty
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.geometry import principal
from rsp_inertia.report import VALUE
from tests.conftest import copy_experiment


@pytest.fixture(scope="module")
def identified(default_logs, tmp_path_factory):
    """The default experiment identified with ``--coverage-factor 3``, and what it printed."""
    root = copy_experiment(default_logs, tmp_path_factory.mktemp("coverage") / "exp")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["identify", str(root), "--coverage-factor", "3"]) == 0
    return root, out.getvalue()


def test_the_coverage_factor_reaches_result_json_and_the_output(identified):
    identified, printed = identified
    result = json.loads((identified / "result.json").read_text())
    stated = result["expanded_uncertainty"]
    assert stated["k"] == 3.0
    assert stated["coverage_probability"] == 0.9973  # JCGM 100 table G.1
    for key, std in result["tensor_std"].items():
        assert stated["tensor"][key] == 3.0 * std
    for key, std in result["com_std"].items():
        assert stated["com"][key] == 3.0 * std
    # the default experiment's moments are thousands of stds apart: every axis determined,
    # the Monte Carlo's U near the linearised k std
    assert stated["principal_axes_determined"] == [True, True, True]
    linear = 3.0 * np.array(result["principal_moments_std"])
    assert np.allclose(stated["principal_moments"], linear, rtol=0.05)
    assert stated["monte_carlo"]["seed"] == 101 and stated["monte_carlo"]["draws"] >= 2 * 37_040
    assert "U = k u with k = 3" in printed and "99.73 %" in printed
    assert printed.count("axis tilt <=") == 3


@pytest.mark.parametrize("k", ["0", "-2", "nan", "inf"])
def test_a_bad_coverage_factor_exits_2_and_writes_nothing(default_logs, tmp_path, capsys, k):
    root = copy_experiment(default_logs, tmp_path / "exp")
    assert main(["identify", str(root), "--coverage-factor", k]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--coverage-factor" in err[0] and "finite number above 0" in err[0]
    assert not (root / "result.json").exists()


def test_the_api_takes_the_coverage_factor_and_refuses_a_bad_one(default_logs, tmp_path):
    root = copy_experiment(default_logs, tmp_path / "exp")
    with pytest.raises(InputError, match="coverage_factor"):
        rsp_inertia.identify(root, coverage_factor=-1.0)
    assert not (root / "result.json").exists()
    result = rsp_inertia.identify(root, coverage_factor=1.0)
    stated = result.expanded_uncertainty
    assert stated == json.loads(result.path.read_text())["expanded_uncertainty"]
    assert stated["k"] == 1.0 and stated["coverage_probability"] == 0.6827
    assert stated["tensor"]["Jx"] == result.entries_std[0]


def test_the_report_states_U_with_its_k_and_what_it_means(identified):
    root, _ = identified
    assert main(["report", str(root)]) == 0
    page = (root / "report.html").read_text()
    result = json.loads((root / "result.json").read_text())
    assert "U = k u</b> with k = 3" in page and "99.73 %" in page
    assert "<th>U (k = 3)</th>" in page
    low, high = result["expanded_uncertainty"]["principal_moments_interval"][0]
    assert f"[{low:{VALUE}}, {high:{VALUE}}]" in page
    assert "not determined" not in page


def test_the_report_says_when_two_moments_leave_their_axes_undetermined(identified, tmp_path):
    """The result of a body with Jx = Jy and no products (an axisymmetric body about z), as
    identify would state it: the report names both axes not determined and gives the Monte
    Carlo's intervals of their moments."""
    root = tmp_path / "exp"
    root.mkdir()
    for name in ("device.toml", "result.json"):
        (root / name).write_bytes((identified[0] / name).read_bytes())
    for folder in identified[0].glob("stage*"):
        copy = root / folder.name
        copy.mkdir()
        for log in folder.glob("*.csv"):
            (copy / log.name).write_bytes(log.read_bytes())
    result = json.loads((root / "result.json").read_text())
    tensor = result["tensor"]
    tensor["Jy"] = tensor["Jx"]
    tensor["Jxy"] = tensor["Jyz"] = tensor["Jxz"] = 0.0
    entries = np.array(list(tensor.values()))
    cov = np.array(result["covariance"])[:6, :6]
    moments, axes = principal(entries)
    result["principal_moments"] = list(moments)
    result["principal_axes"] = axes.tolist()
    result["expanded_uncertainty"] = expanded_uncertainty(
        entries, cov, 2.0, com_std=np.array(list(result["com_std"].values()))
    ).to_dict()
    (root / "result.json").write_text(json.dumps(result))
    assert main(["report", str(root)]) == 0
    page = (root / "report.html").read_text()
    assert page.count("not determined (moment within 3 stds of another)") == 2
    stated = result["expanded_uncertainty"]
    assert stated["principal_axes_determined"].count(False) == 2
    for low, high in stated["principal_moments_interval"]:
        assert f"[{low:{VALUE}}, {high:{VALUE}}]" in page


def test_combine_states_U_of_the_whole_centre_of_mass_with_its_k(tmp_path, capsys):
    from tests.test_combine_cli import TURNED_X90, _mounting

    first = _mounting(tmp_path / "a", np.eye(3))
    second = _mounting(tmp_path / "b", TURNED_X90)
    out = tmp_path / "body"
    args = ["combine", str(first), str(second), "--out", str(out)]
    assert main([*args, "--coverage-factor", "-1"]) == 2
    assert "finite number above 0" in capsys.readouterr().err
    assert not (out / "body.json").exists()
    assert main([*args, "--coverage-factor", "2.5"]) == 0
    printed = capsys.readouterr().out
    body = json.loads((out / "body.json").read_text())
    stated = body["expanded_uncertainty"]
    assert stated["k"] == 2.5 and stated["coverage_probability"] == 0.9876
    assert stated["com"] == {key: 2.5 * std for key, std in body["com_std"].items()}
    assert stated["tensor"] == {key: 2.5 * std for key, std in body["tensor_std"].items()}
    assert "U = k u with k = 2.5" in printed
