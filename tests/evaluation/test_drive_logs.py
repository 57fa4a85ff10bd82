"""Acceptance checks on the real Warthog logs in ../shared/data/drive (skipped if absent)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.config import load_config
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.evaluation import (
    icr_twist_from_rows,
    model_twist,
    settling_time,
    spatial_windows,
    window_errors,
)
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import get_model

REPO = Path(__file__).resolve().parents[2]
WARTHOG = REPO / "config" / "warthog.yaml"


@pytest.fixture(scope="module")
def cfg():
    return load_config(WARTHOG)


@pytest.fixture(scope="module")
def grass(cfg, drive_dir):
    logs = [
        read_wheel_log(p, wheel_radius=cfg.robot.wheel_radius)
        for p in sorted(drive_dir.glob("warthog_wheels_grass*.csv"))
    ]
    assert len(logs) == 5
    return [(log, spatial_windows(log)) for log in logs]


def _ekf_medians(grass, cfg):
    trans, rot = [], []
    for log, win in grass:
        res = run_icr_ekf(log, cfg, labels=log.terrain)
        cols = dict(zip(res.names, res.states.T, strict=True))
        alpha = cols.get("alpha", np.ones(len(log)))
        err = window_errors(
            log, win, icr_twist_from_rows(win, cols["y_l"], cols["y_r"], cols["x_icr"], alpha)
        )
        trans.append(err.translation_per_m)
        rot.append(err.rotation_per_m)
    return np.median(np.concatenate(trans)), np.median(np.concatenate(rot))


def _constant_medians(grass, model, params, track_width=None):
    errs = [
        window_errors(log, win, model_twist(get_model(model), params, track_width))
        for log, win in grass
    ]
    return (
        np.median(np.concatenate([e.translation_per_m for e in errs])),
        np.median(np.concatenate([e.rotation_per_m for e in errs])),
    )


def test_online_ekf_beats_ideal_and_best_constant_model_on_grass(grass, cfg):
    ekf_t, ekf_r = _ekf_medians(grass, cfg)
    idd_t, idd_r = _constant_medians(grass, "idd", [], 1.08)
    # best symmetric extended differential drive fitted offline on these very runs
    # (bench/drive_accuracy.py: alpha=0.912, b_hat=1.777)
    edd_t, edd_r = _constant_medians(grass, "edd-sym", [0.912, 1.777])
    assert idd_t == pytest.approx(0.126, abs=0.005) and idd_r == pytest.approx(5.0, abs=0.1)
    assert ekf_t <= 0.046 and ekf_r <= 0.63
    assert ekf_t < edd_t and ekf_r < edd_r


def test_slip_state_wins_on_grass(grass, cfg):
    with_alpha_t, _ = _ekf_medians(grass, cfg)
    no_alpha = dataclasses.replace(cfg, ekf=dataclasses.replace(cfg.ekf, estimate_alpha=False))
    without_t, _ = _ekf_medians(grass, no_alpha)
    assert with_alpha_t < 0.8 * without_t


def test_stitched_run_and_evaluate_through_the_cli(tmp_path, capsys, drive_dir):
    log = str(drive_dir / "stitched_grass_to_asphalt.csv")
    out = tmp_path / "r"
    assert main(["run", "--config", str(WARTHOG), "--wheels", log, "--out", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert [(c["previous"], c["label"]) for c in report["terrain_changes"]] == [
        ("grass", "asphalt")
    ]
    assert report["terrain_changes"][0]["t"] == pytest.approx(113.95, abs=0.1)
    assert main(["evaluate", "--config", str(WARTHOG), "--run", str(out), "--wheels", log]) == 0
    models = json.loads((out / "evaluation.json").read_text())["models"]
    ekf = models["ekf (online)"]["translation_m_per_m"]["median"]
    idd = models["idd (B=1.08 m)"]["translation_m_per_m"]["median"]
    assert ekf < 0.6 * idd
    assert "ekf (online)" in capsys.readouterr().out


def test_reset_reconverges_after_the_grass_to_asphalt_switch(cfg, drive_dir):
    log = read_wheel_log(
        drive_dir / "stitched_grass_to_asphalt.csv", wheel_radius=cfg.robot.wheel_radius
    )
    switch = log.t[np.flatnonzero(log.terrain == "asphalt")[0]]
    t_move = log.t[
        np.flatnonzero((log.t >= switch) & (np.abs(log.v_l) + np.abs(log.v_r) > 0.05))[0]
    ]
    reset = run_icr_ekf(log, cfg, labels=log.terrain).states[:, 3:]
    plain = run_icr_ekf(log, cfg, labels=None).states[:, 3:]
    final = reset[-1]
    tol = 0.1 * np.abs(final)
    tol[2] = 0.05 * (final[0] - final[1])
    t_reset = settling_time(log.t, reset, final, tol, t_from=t_move)
    t_plain = settling_time(log.t, plain, final, tol, t_from=t_move)
    assert t_reset < 10.0
    assert t_reset <= t_plain
    # without the reset the estimate of y_l stays short of the asphalt value
    assert final[0] - plain[-1, 0] > 0.02
