"""One grammar across the subcommands (issue 13, section 7), through the command line.

The new spellings (``--wheels``, ``--classifier``, ``--out DIR``, ``--config``
with a ``classifier:`` section, ``--horizon 2m``) work everywhere; each old
spelling prints one deprecation line and gives the same result as the new
one; two spellings of one option, a duration where only a distance is taken
and an unknown classifier key are one line on stderr with exit code 2.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from terrain_odom.cli.main import build_parser, main
from terrain_odom.io.classifier_file import load_classifier

WARNING = "terrain-odom: warning: "
ERROR = "terrain-odom: error: "
FAST = ["--maxiter", "1", "--popsize", "5"]
CLASSIFIER = {"k": 1, "tiles": 1, "features": "sfta"}
"""Classifier settings for six tiny training images (k = 1: every fold has a neighbour)."""


def _deprecation(old: str, new: str) -> str:
    return f"{WARNING}{old} is deprecated and will be removed in 0.3; use {new}"


def _main(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, list[str]]:
    """Run the CLI in-process; return the exit code, stdout and the stderr lines."""
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err.splitlines()


def _one_line_error(capsys: pytest.CaptureFixture[str], *argv: object) -> str:
    code, _, err = _main(capsys, *argv)
    assert code == 2 and len(err) == 1 and err[0].startswith(ERROR), err
    return err[0]


@pytest.fixture
def log(tmp_path: Path, examples_dir: Path) -> Path:
    """Return the demo log's first 20 s (poses and terrain labels)."""
    lines = (examples_dir / "demo_log.csv").read_text(encoding="utf-8").splitlines(True)
    path = tmp_path / "log.csv"
    path.write_text("".join(lines[:401]), encoding="utf-8")
    return path


@pytest.fixture
def images(tmp_path: Path) -> Path:
    """Two classes of three 40-px images: noise and a smooth ramp."""
    rng = np.random.default_rng(0)
    ramp = np.tile(np.linspace(60, 90, 40).astype(np.uint8)[:, None, None], (1, 40, 3))
    for name in ("noise", "ramp"):
        (tmp_path / "classes" / name).mkdir(parents=True)
        for i in range(3):
            image = rng.integers(0, 255, (40, 40, 3), np.uint8) if name == "noise" else ramp + i
            cv2.imwrite(str(tmp_path / "classes" / name / f"{i}.png"), image)
    return tmp_path / "classes"


def _config(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("words", "old", "new"),
    [
        (["evaluate"], "--log", "--wheels"),
        (["fit"], "--log", "--wheels"),
        (["compare"], "--log", "--wheels"),
        (["run"], "--model", "--classifier"),
    ],
)
def test_help_shows_only_the_new_spelling(capsys, words, old, new):
    with pytest.raises(SystemExit):
        main([*words, "--help"])
    text = capsys.readouterr().out
    usage, listed = (
        text.split("\n\n")[0],
        [line.split()[0] for line in text.splitlines()[1:] if line.startswith("  -")],
    )
    assert new in usage and new in listed
    assert f"{old} " not in usage and old not in listed


def test_every_option_has_one_spelling_across_subcommands():
    """The concepts of the grammar table are spelled alike wherever they exist."""
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    options = {
        name: {s for a in parser._actions for s in a.option_strings}
        for name, parser in sub.choices.items()
    }
    for name in ("run", "evaluate", "fit", "compare"):
        assert "--wheels" in options[name] and "--log" not in options[name], name
    aliases = {
        name: set(parser._option_string_actions) - options[name]
        for name, parser in sub.choices.items()
    }
    assert {name: old for name, old in aliases.items() if old} == {
        "run": {"--model"},
        "evaluate": {"--log"},
        "fit": {"--log"},
        "compare": {"--log"},
    }
    for name in ("run", "evaluate", "fit", "compare", "train", "simulate"):
        assert "--out" in options[name], name
    assert [name for name in options if "--model" in options[name]] == ["fit"]


@pytest.mark.parametrize("command", ["evaluate", "fit", "compare"])
def test_log_is_a_deprecated_alias_of_wheels(command, log, tmp_path, capsys):
    extra = {
        "evaluate": [],
        "fit": ["--model", "idd", *FAST],
        "compare": ["--eval", log, "--models", "idd", *FAST],
    }[command]
    results = {}
    for option, folder in (("--wheels", "new"), ("--log", "old")):
        out = tmp_path / folder
        code, text, err = _main(capsys, command, option, log, *extra, "--out", out)
        assert code == 0, err
        assert err == ([] if option == "--wheels" else [_deprecation("--log", "--wheels")])
        results[option] = text.replace(str(out), "OUT")
    if command == "evaluate":  # nothing timed: the whole output is the same
        assert results["--log"] == results["--wheels"]
        evaluated = [tmp_path / name / "evaluation.json" for name in ("new", "old")]
        first, second = (json.loads(p.read_text(encoding="utf-8"))["models"] for p in evaluated)
        assert first == second
    else:
        name = "params_idd.yaml"
        first, second = (yaml.safe_load((tmp_path / d / name).read_text()) for d in ("new", "old"))
        assert first["params"] == second["params"] == {}
        assert first["fit"]["segments"] == second["fit"]["segments"] > 0


@pytest.mark.parametrize(
    "argv",
    [
        ["evaluate", "--log", "L", "--wheels", "L"],
        ["fit", "--model", "idd", "--wheels", "L", "--log", "L", "--out", "o"],
        ["compare", "--log", "L", "--eval", "L", "--wheels", "L"],
        ["run", "--wheels", "L", "--out", "o", "--classifier", "m", "--model", "m"],
    ],
    ids=["evaluate", "fit", "compare", "run"],
)
def test_both_spellings_at_once_are_one_line(argv, capsys):
    line = _one_line_error(capsys, *argv)
    old, new = ("--model", "--classifier") if argv[0] == "run" else ("--log", "--wheels")
    assert line == (
        f"{ERROR}{old} and {new} given: {old} is the deprecated spelling of {new}; give {new} only"
    )


def test_evaluate_horizon_in_metres_with_or_without_unit(log, capsys):
    outputs = {}
    for value in ("2m", "2", "2 m", "1.5m"):
        code, text, err = _main(capsys, "evaluate", "--wheels", log, "--horizon", value)
        assert code == 0 and err == [], err
        outputs[value] = text
    assert outputs["2m"] == outputs["2"] == outputs["2 m"]
    assert " windows of 2 m on " in outputs["2"] and " windows of 1.5 m on " in outputs["1.5m"]
    assert outputs["1.5m"] != outputs["2"]


@pytest.mark.parametrize(
    ("value", "fragment"),
    [
        ("2s", "--horizon: '2s' is a duration; this subcommand takes a distance like 2m"),
        ("2x", "--horizon: must be a finite distance >= 0.001 m like 2m (or 2, metres)"),
        ("0.0001m", "--horizon: must be a finite distance >= 0.001 m, got 0.0001"),
    ],
)
def test_evaluate_refuses_a_duration_in_one_line(log, value, fragment, capsys):
    assert fragment in _one_line_error(capsys, "evaluate", "--wheels", log, "--horizon", value)


def test_fit_horizon_takes_a_bare_number_as_metres(log, tmp_path, capsys):
    recorded = {}
    for value in ("3", "3m", "3s"):
        out = tmp_path / value
        code, _, err = _main(capsys, "fit", "--wheels", log, "--model", "idd", *FAST,
                             "--horizon", value, "--out", out)  # fmt: skip
        assert code == 0, err
        recorded[value] = yaml.safe_load((out / "params_idd.yaml").read_text())["horizon"]
    assert recorded == {"3": "3m", "3m": "3m", "3s": "3s"}


def test_fit_out_is_a_folder_and_a_yaml_name_the_old_form(log, tmp_path, capsys):
    folder = tmp_path / "new" / "fits"  # created, parents too
    code, text, err = _main(capsys, "fit", "--wheels", log, "--model", "idd", *FAST,
                            "--out", folder)  # fmt: skip
    assert code == 0 and err == [], err
    assert text.splitlines()[-1] == f"parameters: {folder / 'params_idd.yaml'}"
    assert sorted(p.name for p in folder.iterdir()) == [".terrain-odom.json", "params_idd.yaml"]
    old = tmp_path / "grass.yaml"
    code, text, err = _main(capsys, "fit", "--wheels", log, "--model", "idd", *FAST,
                            "--out", old)  # fmt: skip
    assert code == 0 and err == [_deprecation("--out grass.yaml", "--out DIR (a folder)")]
    assert text.splitlines()[-1] == f"parameters: {old}"
    new = yaml.safe_load((folder / "params_idd.yaml").read_text())
    assert yaml.safe_load(old.read_text())["fit"]["segments"] == new["fit"]["segments"]


def test_evaluate_out_is_a_folder_and_a_json_name_the_old_form(log, tmp_path, capsys):
    folder = tmp_path / "eval"
    code, text, err = _main(capsys, "evaluate", "--wheels", log, "--out", folder)
    assert code == 0 and err == []
    words = text.split()  # written: the JSON, then its plots
    assert words[words.index("written:") + 1] == str(folder / "evaluation.json")
    old = tmp_path / "e.json"
    code, _, err = _main(capsys, "evaluate", "--wheels", log, "--out", old)
    assert code == 0 and err == [_deprecation("--out e.json", "--out DIR (a folder)")]
    new = json.loads((folder / "evaluation.json").read_text())
    assert json.loads(old.read_text())["models"] == new["models"]


def test_train_out_folder_feeds_run_classifier(log, images, tmp_path, capsys):
    config = _config(tmp_path / "c.yaml", f"classifier: {json.dumps(CLASSIFIER)}\n")
    trained = tmp_path / "trained"
    code, text, err = _main(capsys, "train", "--images", images, "--config", config,
                            "--jobs", "1", "--out", trained)  # fmt: skip
    assert code == 0 and err == [], err
    model = trained / "classifier.npz"
    assert text.splitlines()[-1] == f"model: {model}"
    frames = tmp_path / "frames"
    frames.mkdir()
    rng = np.random.default_rng(1)
    cv2.imwrite(str(frames / "2.0.png"), rng.integers(0, 255, (480, 640, 3), np.uint8))
    used = {}
    for option, given in (("--classifier", trained), ("--model", model)):
        out = tmp_path / option.strip("-")
        code, text, err = _main(capsys, "run", "--wheels", log, "--images", frames,
                                option, given, "--out", out)  # fmt: skip
        assert code == 0, err
        assert err == (
            [] if option == "--classifier" else [_deprecation("--model", "--classifier")]
        )
        assert "1 of 1 frames classified" in text
        used[option] = json.loads((out / "report.json").read_text())["inputs"]["model"]
        labels = (out / "frames.csv").read_text().splitlines()[1].split(",")[2]
        assert labels in ("noise", "ramp")  # the classes of this model, not the default's
    assert used["--classifier"] == used["--model"] == str(model.resolve())


def test_train_out_npz_name_is_the_old_form(images, tmp_path, capsys):
    config = _config(tmp_path / "c.yaml", f"classifier: {json.dumps(CLASSIFIER)}\n")
    old = tmp_path / "m.npz"
    code, text, err = _main(capsys, "train", "--images", images, "--config", config,
                            "--jobs", "1", "--out", old)  # fmt: skip
    assert code == 0 and err == [_deprecation("--out m.npz", "--out DIR (a folder)")]
    assert text.splitlines()[-1] == f"model: {old}" and load_classifier(old).config.k == 1


def test_classifier_section_drives_train_and_a_flat_file_still_does(images, tmp_path, capsys):
    section = _config(
        tmp_path / "project.yaml",
        f"robot: {{track_width: 0.7}}\nclassifier: {json.dumps(CLASSIFIER)}\n",
    )
    flat = _config(tmp_path / "flat.yaml", yaml.safe_dump(CLASSIFIER))
    models = {}
    for config in (section, flat):
        out = tmp_path / config.stem
        code, text, err = _main(capsys, "train", "--images", images, "--config", config,
                                "--jobs", "1", "--out", out)  # fmt: skip
        assert code == 0, err
        assert "features=sfta " in text and " k=1 " in text and "tiles=1 " in text
        models[config.stem] = load_classifier(out / "classifier.npz").config
        expected = [] if config == section else [
            _deprecation(
                f"a flat classifier YAML ({flat})",
                "--config with the classifier settings in a classifier: section",
            )
        ]  # fmt: skip
        assert err == expected
    assert models["project"] == models["flat"]
    assert (models["project"].k, models["project"].features) == (1, "sfta")


def test_unknown_key_in_the_classifier_section_is_one_line(images, tmp_path, capsys):
    config = _config(tmp_path / "c.yaml", "classifier: {k: 1, neighbours: 3}\n")
    for argv in (
        ["train", "--images", images, "--out", tmp_path / "m"],
        ["report", "accuracy", "--images", images],
        ["run", "--wheels", "log.csv", "--out", tmp_path / "r"],
    ):
        line = _one_line_error(capsys, *argv, "--config", config)
        assert f"{config}: classifier: unknown key(s) ['neighbours']; allowed: [" in line
    assert not (tmp_path / "m").exists() and not (tmp_path / "r").exists()


def test_a_folder_input_must_hold_exactly_one_file(log, tmp_path, capsys):
    fits = tmp_path / "fits"
    for model in ("idd", "edd-sym"):
        code, _, err = _main(capsys, "fit", "--wheels", log, "--model", model, *FAST,
                             "--out", fits)  # fmt: skip
        assert code == 0, err
    several = "2 parameter files (params_edd-sym.yaml, params_idd.yaml) in this folder"
    line = _one_line_error(capsys, "evaluate", "--wheels", log, "--params", fits)
    assert line == f"{ERROR}{fits}: {several}; name one of them"
    line = _one_line_error(capsys, "run", "--wheels", log, "--priors", fits, "--out", tmp_path)
    assert several in line
    empty = tmp_path / "empty"
    empty.mkdir()
    line = _one_line_error(capsys, "run", "--wheels", log, "--classifier", empty, "--out", empty)
    assert line == f"{ERROR}{empty}: no classifier model (*.npz) in this folder"
    (fits / "params_edd-sym.yaml").unlink()
    code, text, err = _main(capsys, "evaluate", "--wheels", log, "--params", fits)
    assert code == 0 and "idd (params_idd.yaml)" in text
