"""Acceptance of the offline identification on the real Warthog logs (skipped if absent)."""

from __future__ import annotations

from terrain_odom.app.fit import fit
from terrain_odom.config import load_config
from terrain_odom.evaluation import model_twist, spatial_windows, summarize, window_errors
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import get_model


def test_edd_sym_on_held_out_grass_runs(drive_dir, warthog_yaml):
    """Leave-one-run-out on the five grass runs, held-out windows pooled (docs/results/identification.md)."""
    cfg = load_config(warthog_yaml)
    grass = [
        read_wheel_log(p, wheel_radius=cfg.robot.wheel_radius)
        for p in sorted(drive_dir.glob("warthog_wheels_grass*.csv"))
    ]
    assert len(grass) == 5
    edd, idd = get_model("edd-sym"), get_model("idd")
    fitted, ideal = [], []
    for i, test in enumerate(grass):
        report = fit([g for j, g in enumerate(grass) if j != i], "edd-sym", config=cfg)
        windows = spatial_windows(test)
        fitted.append(window_errors(test, windows, model_twist(edd, report.params.vector())))
        ideal.append(window_errors(test, windows, model_twist(idd, [], cfg.robot.track_width)))
    s, base = summarize(fitted), summarize(ideal)
    assert s.translation.median <= 0.05
    assert s.rotation.median <= 0.7
    assert s.translation.median < 0.5 * base.translation.median
    assert s.rotation.median < 0.2 * base.rotation.median


def test_roc_on_real_grass_is_flagged_at_its_beta_2_bound(
    drive_dir, warthog_yaml, tmp_path, capsys
):
    """ROC's beta_2 goes to its bound 0 on the five grass runs (it is then edd-sym): flagged."""
    from terrain_odom.cli.main import main

    logs = [str(p) for p in sorted(drive_dir.glob("warthog_wheels_grass*.csv"))]
    args = ["fit", "--model", "roc", "--wheels", *logs, "--config", str(warthog_yaml)]
    assert main([*args, "--out", str(tmp_path)]) == 0
    assert "at a search bound: beta_2" in capsys.readouterr().out
    assert "at_bounds: [beta_2]" in (tmp_path / "params_roc.yaml").read_text()
