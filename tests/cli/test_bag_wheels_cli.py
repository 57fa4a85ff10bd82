"""``fit`` and ``evaluate`` read a ROS bag where they read a wheel log: the import's results."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from terrain_odom.cli.main import main
from terrain_odom.io.bag.writer import log_records, write_bag
from terrain_odom.io.wheel_log import read_wheel_log
from tests.conftest import SHARED_DATA

TOPICS = ["--wheels-topic", "/joint_states", "--pose-topic", "/pose", "--wheel-radius", "0.1"]


@pytest.fixture(scope="module")
def recording(sample_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Return the quick start's simulated log written as a ROS 1 bag, and its import."""
    log = read_wheel_log(sample_dir / "log.csv")
    folder = tmp_path_factory.mktemp("bags")
    bag = write_bag(folder / "sample.bag", "ros1", log_records(log, 0.1))
    assert main(["import", str(bag), "--out", str(folder / "imp"), *TOPICS]) == 0
    return bag, folder / "imp"


FIT = ["fit", "--model", "edd-sym", "--popsize", "5", "--maxiter", "3"]


def test_fit_on_a_bag_is_fit_on_its_import(
    recording: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag, imported = recording
    config = ["--config", str(imported / "config.yaml")]
    capsys.readouterr()
    csv, direct = tmp_path / "csv", tmp_path / "bag"
    assert main([*FIT, "--wheels", str(imported / "log.csv"), *config, "--out", str(csv)]) == 0
    from_csv = capsys.readouterr().out.splitlines()
    assert main([*FIT, "--wheels", str(bag), *TOPICS, "--out", str(direct)]) == 0
    from_bag = capsys.readouterr().out.splitlines()
    assert f"log:        {direct / 'bag' / 'log.csv'}" in from_bag
    assert f"config:     {direct / 'bag' / 'config.yaml'}" in from_bag
    params = [line for line in from_csv if line.startswith("edd-sym")]
    assert params and params[0] in from_bag  # the same fit
    assert (direct / "params_edd-sym.yaml").is_file()


def test_fit_imports_several_bags_into_their_own_folders(
    recording: tuple[Path, Path], tmp_path: Path
) -> None:
    bag, _ = recording
    other = tmp_path / "other.bag"
    other.write_bytes(bag.read_bytes())
    argv = [*FIT, "--wheels", str(bag), "--eval", str(other), *TOPICS, "--out", str(tmp_path)]
    assert main(argv) == 0
    assert (tmp_path / "bag" / "sample" / "log.csv").is_file()
    assert (tmp_path / "bag" / "other" / "log.csv").is_file()


def test_evaluate_on_a_bag_is_evaluate_on_its_import(
    recording: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag, imported = recording
    config = ["--config", str(imported / "config.yaml")]
    argv = [
        "evaluate",
        "--wheels",
        str(imported / "log.csv"),
        *config,
        "--out",
        str(tmp_path / "a"),
    ]
    capsys.readouterr()
    assert main(argv) == 0
    from_csv = capsys.readouterr().out.splitlines()
    argv = ["evaluate", "--wheels", str(bag), *TOPICS, "--out", str(tmp_path / "b")]
    assert main(argv) == 0
    from_bag = capsys.readouterr().out.splitlines()
    table = [line for line in from_csv if line.startswith("idd")]
    assert len(table) == 2 and all(line in from_bag for line in table)
    assert (tmp_path / "b" / "bag" / "log.csv").is_file()
    assert (tmp_path / "b" / "evaluation.json").is_file()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["evaluate", "--wheels", "{bag}"], "is a ROS bag: give --wheels-topic"),
        (["evaluate", "--wheels", "{bag}", *TOPICS], "give --out (or --run)"),
        (["fit", "--model", "idd", "--wheels", "{bag}", "--out", "o"], "give --wheels-topic"),
        (["fit", "--model", "idd", "--wheels", "{csv}", "--out", "o", *TOPICS], "is not one"),
    ],
)
def test_bag_options_misused(
    recording: tuple[Path, Path],
    capsys: pytest.CaptureFixture[str],
    argv: list[str],
    message: str,
) -> None:
    bag, imported = recording
    argv = [a.format(bag=bag, csv=imported / "log.csv") for a in argv]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_fit_and_evaluate_on_the_real_bag(tmp_path: Path) -> None:
    """The Jackal bag's controller pose: re-integrated to 0.5 %, its geometry fitted back."""
    bag = SHARED_DATA / "bags" / "jackal_odom_imu.bag"
    if not bag.is_file():
        pytest.skip(f"real data not present: {bag} (../shared beside the repository)")
    odom = "/jackal_velocity_controller/odom"
    topics = ["--wheels-topic", odom, "--pose-topic", odom, "--track-width", "0.563"]
    assert main(["evaluate", "--wheels", str(bag), *topics, "--out", str(tmp_path / "e")]) == 0
    report = json.loads((tmp_path / "e" / "evaluation.json").read_text())
    idd = report["models"]["idd (B=0.563 m)"]["translation_m_per_m"]
    assert idd["median"] == pytest.approx(0.0049, abs=5e-5)  # docs/bags.md
    argv = ["fit", "--model", "edd-sym", "--wheels", str(bag), *topics, "--out", str(tmp_path)]
    assert main(argv) == 0
    params = yaml.safe_load((tmp_path / "params_edd-sym.yaml").read_text())
    assert params["params"]["b_hat"] == pytest.approx(0.5634, abs=5e-5)  # docs/bags.md
    assert params["params"]["alpha"] == pytest.approx(1.0005, abs=5e-5)
