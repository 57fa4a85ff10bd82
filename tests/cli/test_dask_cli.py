"""``--dask`` on the command line and ``evaluate --wheels LOG LOG ...`` (the batch mode).

The cluster is a scheduler with two worker threads in this process, reached
by its address (``--dask inproc://...``) as a remote one would be; the
subcommands must print and write what they do without ``--dask``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from terrain_odom.cli.main import main

distributed = pytest.importorskip("distributed")


@pytest.fixture
def logs(tmp_path: Path, examples_dir: Path) -> list[str]:
    """Return the demo log and its first half (two logs of different lengths)."""
    text = (examples_dir / "demo_log.csv").read_text(encoding="utf-8").splitlines()
    (tmp_path / "a.csv").write_text("\n".join(text) + "\n", encoding="utf-8")
    (tmp_path / "b.csv").write_text("\n".join(text[: len(text) // 2]) + "\n", encoding="utf-8")
    return [str(tmp_path / "a.csv"), str(tmp_path / "b.csv")]


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_evaluate_batch_on_the_cluster_prints_and_writes_the_same(
    logs: list[str], tmp_path: Path, scheduler: str, capsys: pytest.CaptureFixture[str]
) -> None:
    base = ["evaluate", "--wheels", *logs, "--horizon", "1m"]
    code, here, _ = _run([*base, "--out", str(tmp_path / "here")], capsys)
    assert code == 0
    code, there, _ = _run([*base, "--out", str(tmp_path / "there"), "--dask", scheduler], capsys)
    assert code == 0
    assert there.replace("there", "here") == here
    assert "| all 2 logs | idd (B=" in here and "| a.csv | idd" in here and "| b.csv | idd" in here
    report = json.loads((tmp_path / "here" / "evaluation.json").read_text(encoding="utf-8"))
    assert report == json.loads((tmp_path / "there" / "evaluation.json").read_text("utf-8"))
    (model,) = report["pooled"]["models"]
    per_log = [entry["models"][model]["translation_m_per_m"]["count"] for entry in report["logs"]]
    assert report["pooled"]["windows"] == sum(per_log) > 0
    assert report["pooled"]["models"][model]["translation_m_per_m"]["count"] == sum(per_log)
    assert (tmp_path / "here" / "evaluation.md").read_text(encoding="utf-8") in here


def test_compare_on_the_cluster_prints_the_same(
    logs: list[str], tmp_path: Path, scheduler: str, capsys: pytest.CaptureFixture[str]
) -> None:
    base = ["compare", "--wheels", logs[0], "--eval", logs[1], "--models", "idd", "edd-sym"]
    base += ["--horizon", "1m", "--popsize", "5", "--maxiter", "3"]
    code, here, _ = _run(base, capsys)
    assert code == 0
    code, there, _ = _run([*base, "--dask", scheduler], capsys)
    assert code == 0

    def strip_times(text: str) -> list[str]:  # the fit (s) column differs
        return [line.rsplit("|", 2)[0] for line in text.splitlines()]

    assert strip_times(there) == strip_times(here) and "edd-sym" in here


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--dask", "local:0"], "--dask: local:N needs a whole number of workers N >= 1"),
        (["--dask", "10.0.0.5:8786"], "--dask: expected a scheduler address like tcp://"),
        (["--dask", "local:2", "--run", "R"], "--run evaluates one run on its own log"),
    ],
)
def test_bad_dask_uses_are_one_line(
    logs: list[str], argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = _run(["evaluate", "--wheels", *logs, *argv], capsys)
    assert code == 2 and err.count("\n") == 1 and message in err


def test_dask_with_one_log_is_one_line(logs: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(["evaluate", "--wheels", logs[0], "--dask", "local:1"], capsys)
    assert code == 2 and err.count("\n") == 1 and "give two or more --wheels logs" in err


def test_without_dask_installed_one_line(
    logs: list[str], monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)
    for argv in (
        ["evaluate", "--wheels", *logs, "--dask", "local:1"],
        ["compare", "--wheels", logs[0], "--eval", logs[1], "--dask", "local:1"],
    ):
        code, _, err = _run(argv, capsys)
        assert code == 2 and err.count("\n") == 1, argv
        assert "--dask needs Dask: pip install 'terrain-odom[dask]'" in err, argv


def test_dask_option_is_on_the_four_subcommands(capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["train"], ["report", "accuracy"], ["compare"], ["evaluate"]):
        with pytest.raises(SystemExit):
            main([*argv, "--help"])
        assert "--dask ADDRESS" in capsys.readouterr().out, argv
