"""Digest every output of the documented commands, to prove a refactor changes none.

Runs the README's commands (the quick start, the demo log with
``evaluate``, ``simulate``/``patches``/``train``, and where ``../shared``
is present the stitched Warthog log with ``evaluate``, ``degrade`` +
``calibrate`` + ``run`` + ``evaluate`` on the grass log, the Jackal bag's
``import`` + ``run``) in a temporary folder and prints one SHA-256 per
output file and per command's printout. What a run measures of its own
speed is left out of the digests: CSV columns named ``ms_*``, JSON keys
``run_time_s``, ``seconds``, ``created`` and those with an ``ms`` word
(also in a classifier's metadata), durations in printouts and Markdown
(``in 1.48 s``, ``run time 4.7 s``, ``frames/s``), the folder manifest
(its hashes cover the timed files) and the temporary folder's name.

Usage::

    python bench/fingerprint.py --save before.json     # on the old tree
    python bench/fingerprint.py --check before.json    # on the new one: exit 1 on a change
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import io
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"

_ENTRY = "import sys; from terrain_odom.cli.main import main; sys.exit(main(sys.argv[1:]))"

_TIMED = [
    re.compile(r"\b(in|run time|took) \d+(\.\d+)? ?(s|ms)\b"),
    re.compile(r"\d+(\.\d+)? (frames/s|ms)\b"),
    re.compile(r"; \d+(\.\d+)? s\b"),
]
_MS = re.compile(r"(^|_)ms(_|$)")
_UNTIMED = {"run_time_s", "seconds", "created"}


def commands(out: Path) -> list[tuple[str, list[str]]]:
    """Return the documented commands, each with a name, writing under ``out``."""
    sample = "sample_images/chen2023"
    cmds = [
        (
            "quick",
            ["run", "--images", sample, "--wheels", f"{sample}/log.csv", "--out", f"{out}/quick"],
        ),
        (
            "demo",
            [
                "run",
                "--wheels",
                "examples/demo_log.csv",
                "--config",
                "examples/demo.yaml",
                "--out",
                f"{out}/demo",
            ],
        ),
        ("demo-eval", ["evaluate", "--run", f"{out}/demo", "--wheels", "examples/demo_log.csv"]),
        (
            "sim",
            [
                "simulate",
                "--out",
                f"{out}/sim",
                "--seed",
                "1",
                "--duration",
                "40",
                "--frame-rate",
                "5",
                "--no-patches",
            ],
        ),
        (
            "patches",
            [
                "patches",
                "--images",
                f"{out}/sim",
                "--wheels",
                f"{out}/sim/log.csv",
                "--out",
                f"{out}/train",
                "--horizon",
                "2s",
            ],
        ),
        ("train", ["train", "--images", f"{out}/train", "--out", f"{out}/model"]),
    ]
    drive = SHARED / "drive"
    if drive.is_dir():
        stitched = str(drive / "stitched_grass_to_asphalt.csv")
        grass = str(drive / "warthog_wheels_grass.csv")
        cmds += [
            (
                "warthog",
                [
                    "run",
                    "--config",
                    "config/warthog.yaml",
                    "--wheels",
                    stitched,
                    "--out",
                    f"{out}/warthog",
                ],
            ),
            (
                "warthog-eval",
                [
                    "evaluate",
                    "--config",
                    "config/warthog.yaml",
                    "--run",
                    f"{out}/warthog",
                    "--wheels",
                    stitched,
                ],
            ),
            (
                "degrade",
                [
                    "degrade",
                    "--wheels",
                    grass,
                    "--config",
                    "config/warthog.yaml",
                    "--out",
                    f"{out}/gps",
                    "--seed",
                    "1",
                ],
            ),
            (
                "calibrate",
                [
                    "calibrate",
                    "--wheels",
                    f"{out}/gps/log.csv",
                    "--config",
                    f"{out}/gps/config.yaml",
                    "--out",
                    f"{out}/gps/cal",
                ],
            ),
            (
                "gps-run",
                [
                    "run",
                    "--wheels",
                    f"{out}/gps/log.csv",
                    "--config",
                    f"{out}/gps/cal/config.yaml",
                    "--out",
                    f"{out}/gps/run",
                    "--no-checks",
                ],
            ),
            ("gps-eval", ["evaluate", "--run", f"{out}/gps/run", "--wheels", f"{out}/gps/log.csv"]),
        ]
    bag = SHARED / "bags" / "jackal_odom_imu.bag"
    if bag.is_file():
        cmds += [
            (
                "jackal",
                [
                    "import",
                    str(bag),
                    "--out",
                    f"{out}/jackal",
                    "--wheels-topic",
                    "/jackal_velocity_controller/odom",
                    "--heading-topic",
                    "/imu/data",
                    "--track-width",
                    "0.563",
                ],
            ),
            (
                "jackal-run",
                [
                    "run",
                    "--wheels",
                    f"{out}/jackal/log.csv",
                    "--config",
                    f"{out}/jackal/config.yaml",
                    "--out",
                    f"{out}/jackal/run",
                ],
            ),
        ]
    return cmds


def _text(s: str, out: Path) -> str:
    s = s.replace(str(out), "OUT")
    for pattern in _TIMED:
        s = pattern.sub("<timed>", s)
    return s


def _json(value: object) -> object:
    if isinstance(value, dict):
        return {k: _json(v) for k, v in value.items() if k not in _UNTIMED and not _MS.search(k)}
    if isinstance(value, list):
        return [_json(v) for v in value]
    return value


def _csv(text: str) -> str:
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        return text
    keep = [i for i, name in enumerate(rows[0]) if not name.startswith("ms_")]
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(
        [[r[i] for i in keep if i < len(r)] for r in rows]
    )
    return buf.getvalue()


def _npz(path: Path) -> str:
    sha = hashlib.sha256()
    with np.load(path, allow_pickle=False) as z:
        for key in sorted(z.files):
            value = z[key]
            if key == "metadata":
                value = np.array(json.dumps(_json(json.loads(str(value))), sort_keys=True))
            sha.update(key.encode() + value.tobytes())
    return sha.hexdigest()


def digest(path: Path, out: Path) -> str:
    """Return the SHA-256 of ``path`` with its timings and the folder's name left out."""
    if path.suffix == ".npz":
        return _npz(path)
    data = path.read_bytes()
    if path.suffix in {".csv", ".json", ".md", ".yaml", ".tum", ".txt"}:
        text = _text(data.decode("utf-8", "replace"), out)
        if path.suffix == ".csv":
            text = _csv(text)
        elif path.suffix == ".json":
            text = json.dumps(_json(json.loads(text)), sort_keys=True)
        data = text.encode()
    return hashlib.sha256(data).hexdigest()


def fingerprint() -> dict[str, str]:
    """Run every command in a temporary folder; return ``{name: sha256}``."""
    found: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="fp-") as tmp:
        out = Path(tmp)
        for name, argv in commands(out):
            done = subprocess.run(
                [sys.executable, "-c", _ENTRY, *argv],
                cwd=ROOT,
                capture_output=True,
                text=True,
                check=False,
            )
            found[f"$ {name} (exit {done.returncode})"] = hashlib.sha256(
                _text(done.stdout + done.stderr, out).encode()
            ).hexdigest()
        for path in sorted(p for p in out.rglob("*") if p.is_file()):
            if path.name != ".terrain-odom.json":
                found[str(path.relative_to(out))] = digest(path, out)
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--save", type=Path, help="write the digests to this JSON file")
    group.add_argument("--check", type=Path, help="compare with digests saved earlier")
    parser.add_argument("-v", "--verbose", action="store_true", help="a line per output file")
    args = parser.parse_args()
    found = fingerprint()
    for name, sha in found.items():
        if args.verbose or name.startswith("$"):
            print(f"{sha[:16]}  {name}")
    print(f"{sum(not k.startswith('$') for k in found)} output files")
    if args.save:
        args.save.write_text(json.dumps(found, indent=1) + "\n")
    if args.check:
        saved = json.loads(args.check.read_text())
        changed = sorted(k for k in saved.keys() | found.keys() if saved.get(k) != found.get(k))
        print(
            f"{len(found)} digests, {len(changed)} changed" + "".join(f"\n  {k}" for k in changed)
        )
        return 1 if changed else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
