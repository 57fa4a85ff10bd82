"""Bad input files and values are one line on stderr and exit code 2, never a traceback.

Issue 13, section 6: a truncated, random or inconsistent model file, a binary
or too deeply nested YAML file (robot and classifier configurations,
parameter and prior files), ``evaluate --horizon 0|-1|nan`` and
``simulate --seed -1``. Every case also checks that its input files are
byte-identical afterwards.
"""

from __future__ import annotations

import hashlib
import io
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.io.classifier_file import default_classifier_path

SRC = Path(__file__).resolve().parents[2] / "src"
NESTED_YAML = "".join(" " * i + "-\n" for i in range(3000))
"""3,000 lines of lists nested in lists: deeper than the parser's recursion."""
BINARY = bytes(range(256)) * 8
"""Not UTF-8: what a YAML reader gets when given an image or a model."""


@pytest.fixture
def inputs(tmp_path: Path, examples_dir: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Write the inputs into ``tmp_path`` (the working folder): log, images, bad files."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "log.csv").write_bytes((examples_dir / "demo_log.csv").read_bytes())
    images = tmp_path / "images"
    images.mkdir()
    (images / "0.5.png").write_bytes(_png())
    model = default_classifier_path().read_bytes()
    (tmp_path / "truncated.npz").write_bytes(model[: len(model) // 2])
    (tmp_path / "random.npz").write_bytes(np.random.default_rng(0).bytes(4096))
    (tmp_path / "mismatch.npz").write_bytes(_scaler_short_by_one(model))
    (tmp_path / "narrow.npz").write_bytes(_one_column_fewer(model))
    (tmp_path / "binary.yaml").write_bytes(BINARY)
    (tmp_path / "nested.yaml").write_text(NESTED_YAML, encoding="utf-8")
    classes = tmp_path / "classes"
    for name in ("grass", "gravel"):
        (classes / name).mkdir(parents=True)
        (classes / name / "a.png").write_bytes(_png())
    return tmp_path


def _png() -> bytes:
    import cv2

    ok, data = cv2.imencode(".png", np.full((16, 16, 3), 90, np.uint8))
    assert ok
    return data.tobytes()


def _scaler_short_by_one(model: bytes) -> bytes:
    """Return the model file with one value fewer in its scaler than feature columns."""
    with np.load(io.BytesIO(model), allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["scaler_mean"] = arrays["scaler_mean"][:-1]
    arrays["scaler_scale"] = arrays["scaler_scale"][:-1]
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def _one_column_fewer(model: bytes) -> bytes:
    """Return the model file with its features and scaler one column narrower (consistent)."""
    with np.load(io.BytesIO(model), allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["features"] = arrays["features"][:, :-1]
    arrays["scaler_mean"] = arrays["scaler_mean"][:-1]
    arrays["scaler_scale"] = arrays["scaler_scale"][:-1]
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def _digests(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def assert_one_line_exit_2(capsys, argv: list[str], root: Path, *fragments: str) -> str:  # noqa: ANN001
    """Run the CLI in-process; check exit 2, one stderr line with ``fragments``, inputs intact."""
    before = _digests(root)
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    assert len(err.splitlines()) == 1 and err.endswith("\n"), err
    line = err.rstrip("\n")
    assert line.startswith("terrain-odom: error: "), line
    for fragment in fragments:
        assert fragment in line, (fragment, line)
    after = _digests(root)
    assert {k: after.get(k) for k in before} == before  # inputs byte-identical
    return line


_RUN_IMAGES = ["run", "--wheels", "log.csv", "--images", "images", "--out", "out"]


@pytest.mark.parametrize(
    ("model", "fragments"),
    [
        ("truncated.npz", ["truncated.npz: truncated or damaged model file"]),
        ("random.npz", ["random.npz: not a terrain-odom model file (not an .npz archive)"]),
        ("mismatch.npz", ["mismatch.npz: inconsistent model file", "scaler disagree"]),
        ("narrow.npz", ["training features have 49 columns", "compute 50", "retrain"]),
    ],
)
def test_a_bad_model_file(capsys, inputs, model, fragments):
    line = assert_one_line_exit_2(capsys, [*_RUN_IMAGES, "--classifier", model], inputs, *fragments)
    assert "pickle" not in line


_YAML_USES = {
    "robot config": ["run", "--wheels", "log.csv", "--out", "out", "--config"],
    "classifier config": ["train", "--images", "classes", "--out", "m", "--config"],
    "params file": ["evaluate", "--wheels", "log.csv", "--out", "e", "--params"],
    "priors file": ["run", "--wheels", "log.csv", "--out", "out", "--priors"],
}


@pytest.mark.parametrize("use", list(_YAML_USES))
@pytest.mark.parametrize(
    ("name", "problem"),
    [
        ("binary.yaml", "binary.yaml: not a UTF-8 text file"),
        ("nested.yaml", "nested.yaml: not a YAML"),
    ],
)
def test_a_file_that_is_no_yaml(capsys, inputs, use, name, problem):
    line = assert_one_line_exit_2(capsys, [*_YAML_USES[use], name], inputs, problem)
    assert ("nested too deeply" in line) == (name == "nested.yaml")


@pytest.mark.parametrize("horizon", ["0", "-1", "nan", "1e-300"])
def test_evaluate_horizon_not_a_distance(capsys, inputs, horizon):
    argv = ["evaluate", "--wheels", "log.csv", "--out", "e", f"--horizon={horizon}"]
    assert_one_line_exit_2(capsys, argv, inputs, "--horizon", "finite distance >= 0.001 m", horizon)


def test_simulate_negative_seed(capsys, inputs):
    argv = ["simulate", "--out", "sim", "--seed=-1", "--duration", "1", "--no-frames"]
    assert_one_line_exit_2(capsys, argv, inputs, "--seed: must be a whole number >= 0, got -1")
    assert not (inputs / "sim").exists()


@pytest.mark.parametrize(
    "argv",
    [
        [*_RUN_IMAGES, "--classifier", "truncated.npz"],
        ["run", "--wheels", "log.csv", "--out", "out", "--config", "nested.yaml"],
    ],
    ids=["truncated model", "nested yaml"],
)
def test_a_real_process_prints_one_line(inputs, argv):
    path = os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run(
        [sys.executable, "-m", "terrain_odom", *argv],
        env={**os.environ, "PYTHONPATH": path},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.splitlines()) == 1, proc.stderr


def test_ground_truth_of_a_run_shorter_than_a_window_is_one_line(
    sample_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    short = tmp_path / "short.csv"  # 2 s of the sample run: < 2 m travelled
    short.write_text("".join((sample_dir / "log.csv").read_text().splitlines(True)[:40]))
    args = ["run", "--wheels", str(short), "--config", str(sample_dir / "config.yaml")]
    truth = ["--groundtruth", str(sample_dir / "groundtruth.csv")]
    assert main([*args, *truth, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "no 2 m window" in err and "travels less than 2 m" in err
