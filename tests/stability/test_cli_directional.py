"""CLI: the 2-D options of `stability` (--velocity-gradient, --angles, --plot) and the unchanged 1-D output."""

import argparse
import json

import pytest

from icidr_pde.cli import stability as cli


def _run(argv):
    parser = argparse.ArgumentParser(prog="icidr-pde")
    sub = parser.add_subparsers(dest="command", required=True)
    cli.add_parser(sub)
    args = parser.parse_args(["stability", *argv])
    return cli.cmd(args)


ONE_D = ("M", "chi", "trace_gamma", "det_gamma", "lambda_plus", "lambda_minus", "max_re_eig_over_xi2", "lambda0_limit")
TWO_D = ("angles_deg", "lambda_max", "max_lambda", "worst_angle_deg", "ill_posed_intervals_deg")


def test_mui_steady_shear_json_and_plot(tmp_path, capsys):
    out, png = tmp_path / "s.json", tmp_path / "p.png"
    rc = _run(["--rheology", "mui", "--phi", "0.78", "--velocity-gradient", "0", str(1 / 30), "0", "0",
               "--angles", "0:180:1", "--json", str(out), "--plot", str(png)])
    assert rc == 0
    data = json.loads(out.read_text())
    assert set(TWO_D) <= set(data) and set(ONE_D) <= set(data)      # 1-D form: the 1-D keys too
    assert len(data["angles_deg"]) == len(data["lambda_max"]) == 180
    assert len(data["ill_posed_intervals_deg"]) == 1
    a, b = data["ill_posed_intervals_deg"][0]
    assert 0 <= a < 45 < b < 90
    assert data["lambda_max"][90] == pytest.approx(data["lambda_plus"], rel=1e-12)
    assert png.stat().st_size > 10000
    assert "ILL-POSED for plane waves" in capsys.readouterr().out


def test_icidr_general_gradient_has_no_1d_keys(tmp_path):
    out = tmp_path / "s.json"
    assert _run(["--rheology", "icidr", "--phi", "0.7", "--velocity-gradient", "0.01", "0.2", "-0.05", "-0.03",
                 "--angles", "0:180:2", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["ill_posed_intervals_deg"] == [] and data["max_lambda"] < 0
    assert len(data["angles_deg"]) == 90 and not set(ONE_D) & set(data) - {"trace_gamma"}


def test_1d_flags_unchanged(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert _run(["--rheology", "mui", "--phi", "0.78", "--uz", "0.0333333", "--wz", "0.05", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert set(data) == set(ONE_D) | {"rheology", "phi", "uz", "wz", "xi"}
    assert "2-D" not in capsys.readouterr().out


@pytest.mark.parametrize("argv, word", [
    (["--velocity-gradient", "0", "0", "0", "0"], "--velocity-gradient"),  # the option, as given
    (["--velocity-gradient", "0", "1", "0", "0", "--uz", "1"], "velocity-gradient"),
    (["--uz", "1"], "wz"),
    (["--velocity-gradient", "0", "1", "0", "0", "--angles", "0:180:-1"], "angles"),
])
def test_bad_input_exit_2(argv, word, capsys, tmp_path):
    out = tmp_path / "s.json"
    assert _run(["--rheology", "mui", "--phi", "0.78", *argv, "--json", str(out)]) == 2
    assert word in capsys.readouterr().err
    assert not out.exists()
