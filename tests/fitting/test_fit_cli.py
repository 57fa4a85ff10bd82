"""``terrain-odom fit`` / ``compare`` and parameter files, end to end on simulated logs."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from terrain_odom.cli.main import main
from terrain_odom.errors import InputFileError
from terrain_odom.fitting.params import ModelParams, ParamSet
from terrain_odom.io.params import read_params, write_params
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.sim.model_log import constant_model_log

FAST = ("--popsize", "8")


def run_main(capsys, *argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_one_line_error(code, out, err, *fragments):
    assert code == 2 and out == "" and "Traceback" not in err
    assert len(err.splitlines()) == 1, err
    for fragment in fragments:
        assert fragment in err, (fragment, err)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Two terrains, two files each (train, eval), with known edd-sym parameters."""
    folder = tmp_path_factory.mktemp("logs")
    paths = {}
    for terrain, params, seed in (("grass", [0.9, 1.8], 1), ("asphalt", [0.95, 2.6], 2)):
        for role, s in (("train", seed), ("eval", seed + 10)):
            log = constant_model_log("edd-sym", params, seconds=40.0, seed=s, terrain=terrain)
            paths[terrain, role] = folder / f"{terrain}_{role}.csv"
            write_wheel_log(paths[terrain, role], log)
    return paths


def test_fit_writes_parameters_and_held_out_errors(logs, tmp_path, capsys):
    out = tmp_path / "p" / "params_edd-sym.yaml"
    code, text, err = run_main(
        capsys, "fit", "--model", "edd-sym", "--wheels", logs["grass", "train"],
        "--eval", logs["grass", "eval"], "--out", out.parent, *FAST,
    )  # fmt: skip
    assert code == 0, err
    assert "fitted in" in text and "m/m" in text
    assert text.splitlines()[-1] == f"parameters: {out}"
    mp = read_params(out)
    np.testing.assert_allclose(mp.vector(), [0.9, 1.8], atol=0.02)
    data = yaml.safe_load(out.read_text())
    assert data["format_version"] == 2 and data["horizon"] == "2m"
    assert data["bounds"]["alpha"] == [0.0, 1.5]
    assert data["fit"]["segments"] > 5 and data["fit"]["loss"] >= 0
    groups = data["evaluation"]["groups"]["all"]
    fitted, ideal = groups["edd-sym"], groups["idd (B=0.5 m)"]
    assert fitted["translation_m_per_m"]["median"] < 0.01 < ideal["translation_m_per_m"]["median"]


def test_fit_sigma_and_time_horizon_are_recorded(logs, tmp_path, capsys):
    out = tmp_path / "params_edd-sym.yaml"
    code, _, err = run_main(
        capsys, "fit", "--model", "edd-sym", "--wheels", logs["grass", "train"], "--out", tmp_path,
        "--horizon", "3s", "--sigma", "0.1", "0.1", "0.05", "--seed", "3", *FAST,
    )  # fmt: skip
    assert code == 0, err
    data = yaml.safe_load(out.read_text())
    assert data["horizon"] == "3s" and data["sigma"] == [0.1, 0.1, 0.05]
    assert data["fit"]["duration_s"] >= 3.0 * data["fit"]["segments"]
    np.testing.assert_allclose(read_params(out).vector(), [0.9, 1.8], atol=0.02)
    code, text, err = run_main(
        capsys, "fit", "--model", "edd-sym", "--wheels", logs["grass", "train"], "--out", tmp_path,
        "--sigma", "0.1", "0", "0.1",
    )  # fmt: skip
    assert_one_line_error(code, text, err, "--sigma", "> 0")


def test_fit_by_terrain_and_evaluate_with_the_matching_set(logs, tmp_path, capsys):
    folder = tmp_path / "terrains"
    out = folder / "params_icr-slip.yaml"
    train = [logs["grass", "train"], logs["asphalt", "train"]]
    code, text, err = run_main(
        capsys, "fit", "--model", "icr-slip", "--by-terrain", "--wheels", *train, "--out", folder,
        *FAST,
    )  # fmt: skip
    assert code == 0, err
    assert "[grass]" in text and "[asphalt]" in text
    mp = read_params(out)
    assert mp.per_terrain and sorted(mp.sets) == ["asphalt", "grass"]
    # edd-sym (alpha, b) is icr-slip with y_l = -y_r = b / 2: the EKF seed per terrain
    np.testing.assert_allclose(mp.icr("grass"), (0.9, -0.9, 0.0, 0.9), atol=0.02)
    np.testing.assert_allclose(mp.icr("asphalt"), (1.3, -1.3, 0.0, 0.95), atol=0.03)
    derived = yaml.safe_load(out.read_text())["terrains"]["grass"]["derived"]
    assert derived["steering_efficiency"] == pytest.approx(1.8 / 0.5, abs=0.1)
    code, text, err = run_main(
        capsys, "evaluate", "--wheels", logs["asphalt", "eval"], "--params", folder,
        "--out", tmp_path / "e",
    )  # fmt: skip
    assert code == 0, err
    result = json.loads((tmp_path / "e" / "evaluation.json").read_text())
    entry = result["models"]["icr-slip (params_icr-slip.yaml)"]
    assert entry["translation_m_per_m"]["median"] < 0.01


def test_evaluate_per_terrain_file_on_an_unknown_terrain(logs, tmp_path, capsys):
    params = tmp_path / "grass_only.yaml"
    write_params(params, ModelParams("edd-sym", {"grass": ParamSet({"alpha": 0.9, "b_hat": 1.8})}))
    code, out, err = run_main(
        capsys, "evaluate", "--wheels", logs["asphalt", "eval"], "--params", params,
        "--out", tmp_path / "e",
    )  # fmt: skip
    assert_one_line_error(code, out, err, "asphalt_eval.csv", "terrain 'asphalt'", "['grass']")


def test_compare_writes_tables_plot_and_parameter_files(logs, tmp_path, capsys):
    out = tmp_path / "cmp"
    train = [logs["grass", "train"], logs["asphalt", "train"]]
    evals = [logs["grass", "eval"], logs["asphalt", "eval"]]
    code, text, err = run_main(
        capsys, "compare", "--wheels", *train, "--eval", *evals, "--by-terrain",
        "--models", "idd", "edd-sym", "icr", "--out", out, *FAST,
    )  # fmt: skip
    assert code == 0, err
    assert "| edd-sym | asphalt |" in text and "| idd | grass |" in text
    for name in ("compare.md", "compare.json", "compare.png", "params_edd-sym.yaml"):
        assert (out / name).stat().st_size > 0, name
    report = json.loads((out / "compare.json").read_text())
    sets = report["models"]["edd-sym"]["sets"]
    assert sets["asphalt"]["params"]["b_hat"] == pytest.approx(2.6, abs=0.05)
    assert sets["grass"]["params"]["b_hat"] == pytest.approx(1.8, abs=0.05)
    errors = report["models"]
    for terrain in ("grass", "asphalt"):
        fitted = errors["edd-sym"]["errors"][terrain]["translation_m_per_m"]["median"]
        assert fitted < errors["idd"]["errors"][terrain]["translation_m_per_m"]["median"]
    assert "c=" in report["markdown"] and "e=" in report["markdown"]


def test_bad_input_is_one_line_and_exit_2(logs, tmp_path, capsys):
    no_pose = tmp_path / "no_pose.csv"
    no_pose.write_text("t,v_l,v_r\n0,1,1\n0.1,1,1\n")
    no_terrain = tmp_path / "no_terrain.csv"
    write_wheel_log(no_terrain, constant_model_log("edd-sym", [0.9, 1.8], seconds=10.0))
    grass = logs["grass", "train"]
    out = tmp_path / "p"
    cases = [
        (["--wheels", no_pose], ["no_pose.csv", "no pose measurements"]),
        (["--wheels", grass, "--horizon", "2x"], ["horizon '2x'", "'2m' or '2s'"]),
        (["--wheels", no_terrain, "--by-terrain"], ["no_terrain.csv", "no terrain column"]),
        (["--wheels", grass, "--horizon", "500m"], ["no training segment of 500m", "shorter"]),
        (["--wheels", tmp_path / "missing.csv"], ["missing.csv"]),
    ]
    for extra, fragments in cases:
        code, text, err = run_main(capsys, "fit", "--model", "edd-sym", "--out", out, *extra)
        assert_one_line_error(code, text, err, *fragments)
    assert not out.exists()
    with pytest.raises(SystemExit) as exc:
        main(["fit", "--model", "magic", "--wheels", str(grass), "--out", str(out)])
    assert exc.value.code == 2
    assert "invalid choice: 'magic'" in capsys.readouterr().err


def test_params_file_versions(tmp_path):
    v1 = tmp_path / "v1.yaml"
    v1.write_text("format_version: 1\nmodel: icr\nparams: {y_l: 0.4, y_r: -0.35, x_icr: 0.1}\n")
    mp = read_params(v1)
    assert not mp.per_terrain and mp.icr() == (0.4, -0.35, 0.1, 1.0)
    v2 = tmp_path / "v2.yaml"
    write_params(v2, ModelParams("icr", mp.sets, 0.5, {"horizon": "2s"}))
    again = read_params(v2)
    assert again.sets == mp.sets and again.track_width == 0.5 and again.info["horizon"] == "2s"
    derived = yaml.safe_load(v2.read_text())["derived"]
    assert derived["steering_efficiency"] == pytest.approx(0.75 / 0.5)
    assert derived["eccentricity"] == pytest.approx(-0.05 / 0.75)
    bad = tmp_path / "bad.yaml"
    for text, message in (
        ("format_version: 1\nmodel: icr\nparams: {y_l: 1, y_r: -1, x_icr: 0}\nfit: {}\n",
         "unknown key(s) ['fit']"),
        ("format_version: 2\nmodel: icr\nterrains: {a: {params: {y_l: 1}}}\n",
         "terrains.a: model 'icr' needs params"),
        ("format_version: 2\nmodel: icr\nparams: {y_l: 1, y_r: -1, x_icr: 0}\nterrains: {}\n",
         "either 'terrains'"),
        ("format_version: 3\nmodel: icr\n", "format_version 3"),
    ):  # fmt: skip
        bad.write_text(text)
        with pytest.raises(InputFileError, match=None) as exc:
            read_params(bad)
        assert message in str(exc.value), (message, str(exc.value))
    with pytest.raises(ValueError, match="no ICR state"):
        ModelParams("edd-sym", {"*": ParamSet({"alpha": 1.0, "b_hat": 1.0})}).icr()
