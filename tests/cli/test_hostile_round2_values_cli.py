"""Issue 24, round two: robot sizes no robot has, a track width far off, sizes equal but for noise."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.config import RobotConfig
from terrain_odom.errors import ConfigError
from terrain_odom.evaluation.plausibility import check_log
from terrain_odom.io.params import read_priors
from terrain_odom.io.wheel_log import read_wheel_log
from tests.cli.refusal import refused


@pytest.mark.parametrize(
    ("robot", "expected"),
    [
        ("track_width: 1e9", "robot.track_width: 1e+09 m is no ground robot's"),
        ("track_width: 1.0e9", "robot.track_width: 1e+09 m is no ground robot's"),
        ("track_width: 108", "robot.track_width: 108 m is no ground robot's (1 mm to 100 m)"),
        ("track_width: 1e-300", "robot.track_width: 1e-300 m is no ground robot's"),
        ("wheel_radius: 0.0001", "robot.wheel_radius: 0.0001 m is no ground robot's"),
        ("length: 500", "robot.length: 500 m is no ground robot's"),
        # within the bounds, but the demo robot is 0.5 m wide: its wheels' turn 1/100 of the heading's
        ("track_width: 50", "the heading turns x46.3 as fast as the wheels say (correlation 0.97)"),
        ("track_width: 5", "the heading turns x4.63 as fast as the wheels say"),
    ],
)
def test_a_robot_size_that_is_not_the_robots_is_one_line(
    robot: str,
    expected: str,
    examples_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Sizes no robot has are refused naming the key; a track width far off by the turn check."""
    config = tmp_path / "robot.yaml"
    config.write_text(f"format_version: 1\nrobot:\n  {robot}\n")
    argv = ["run", "--wheels", str(examples_dir / "demo_log.csv"), "--config", str(config)]
    err = refused([*argv, "--out", str(tmp_path / "o"), "--no-plots"], capsys)
    named = config if expected.startswith("robot.") else examples_dir / "demo_log.csv"
    assert expected in err and str(named) in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("track_width", [1e-300, 1e-3, 1e3, 1e300])
def test_the_yaw_fit_neither_overflows_nor_warns(track_width: float, examples_dir: Path) -> None:
    """Any track width (the API does not bound it): a finite fit, ``1 / track_width`` times 0.5's."""
    log = read_wheel_log(examples_dir / "demo_log.csv")
    nominal = check_log(log, 0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = check_log(log, track_width)
    assert result.yaw_correlation == pytest.approx(nominal.yaw_correlation, rel=1e-9)
    assert result.yaw_scale == pytest.approx(nominal.yaw_scale * track_width / 0.5, rel=1e-9)
    assert [f.check for f in result.findings] == ["yaw_follow"]
    assert np.isfinite(result.yaw_scale)


PRIORS = """\
format_version: 2
model: icr
track_width: 0.5
wheel_radius: RADIUS
pose_delay: 0.0
horizon: 2m
sigma: null
bounds:
  y_l: [0.05, 50.0]
  y_r: [-50.0, -0.05]
  x_icr: [-50.0, 50.0]
params: {y_l: 0.3, y_r: -0.3, x_icr: 0.0}
at_bounds: []
"""


@pytest.mark.parametrize("radius", ["0.30000001", "0.3", "0.2999999999"])
def test_a_wheel_radius_equal_but_for_its_last_digits_is_the_same(
    radius: str, tmp_path: Path
) -> None:
    path = tmp_path / "params_icr.yaml"
    path.write_text(PRIORS.replace("RADIUS", radius))
    priors = read_priors(path, RobotConfig(wheel_radius=0.3, track_width=0.5))
    assert priors.start is not None and priors.start.y_l == 0.3


@pytest.mark.parametrize(("radius", "shown"), [("0.3001", "0.3001 m"), ("0.30001", "0.30001 m")])
def test_a_wheel_radius_that_differs_is_printed_with_the_digits_it_differs_in(
    radius: str, shown: str, tmp_path: Path
) -> None:
    path = tmp_path / "params_icr.yaml"
    path.write_text(PRIORS.replace("RADIUS", radius))
    with pytest.raises(ConfigError, match=rf"wheel_radius {shown}, but .* says 0\.3 m"):
        read_priors(path, RobotConfig(wheel_radius=0.3, track_width=0.5))
