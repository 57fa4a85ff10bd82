"""vision.frame_classifier: a grey frame given to a colour model is refused, not labelled."""

from __future__ import annotations

import re
import shutil

import cv2
import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.config import load_config
from terrain_odom.errors import InputFileError
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io.classifier_file import default_classifier, load_classifier
from terrain_odom.io.images import read_image_rgb


def _odometry(sample_dir, classifier):
    odo = OnlineOdometry(load_config(sample_dir / "config.yaml"), classifier)
    odo.wheels(0.0, 0.5, 0.5)
    return odo


def test_a_grey_frame_and_a_colour_model_is_an_error_naming_the_features(sample_dir):
    model = load_classifier(default_classifier())
    assert model.config.features != "sfta"
    image = read_image_rgb(sample_dir / "frames" / "000000.jpg")
    assert image is not None
    odo = _odometry(sample_dir, model)
    assert odo.frame(0.0, image).label  # the colour frame is classified
    grey = np.repeat(cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)[..., None], 3, axis=2)
    with pytest.raises(
        InputFileError, match=f"grey .* uses {re.escape(model.config.features)} features"
    ):
        odo.frame(0.0, grey)


def test_the_cli_refuses_grey_frames_in_one_line(sample_dir, tmp_path, capsys):
    frames = tmp_path / "frames"
    shutil.copytree(sample_dir, frames, ignore=shutil.ignore_patterns("groundtruth.csv"))
    for path in sorted((frames / "frames").glob("*.jpg")):
        grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        cv2.imwrite(str(path), grey)
    args = ["run", "--images", str(frames), "--wheels", str(frames / "log.csv")]
    assert main([*args, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "is grey" in err and "--features sfta" in err
