"""Mutation testing's bookkeeping around mutmut 3 (docs/testing.md): seeded samples, and counts.

A module of the core has hundreds of mutants; on a 2-core machine a whole
module can take an hour. ``sample`` draws a seeded uniform sample of a
module's mutants (all of them for a small module), whose names ``mutmut
run`` takes; ``counts`` prints mutmut's verdicts of those mutants (or of
all) per module, from the ``.meta`` files it writes beside the mutated
copies in ``mutants/``. Run both from the repository root after mutmut has
generated the mutants (any ``mutmut run`` does, first thing)::

    mutmut run $(python tools/mutation.py sample evaluation.calibration)
    mutmut run $(python tools/mutation.py sample --todo evaluation.calibration)  # resume
    python tools/mutation.py counts --sample evaluation.calibration
"""

from __future__ import annotations

import argparse
import json
import random
from collections import Counter
from pathlib import Path

from mutmut.stats import status_by_exit_code  # where mutmut defines it (no config read)

SIZE, SEED, WHOLE_UP_TO = 150, 28, 200


def verdicts(module: str, root: Path = Path("mutants")) -> dict[str, int | None]:
    """Return mutmut's exit code of each mutant of ``module`` (``evaluation.calibration``); None if not run."""
    meta = root / "src" / "terrain_odom" / (module.replace(".", "/") + ".py.meta")
    if not meta.is_file():
        raise FileNotFoundError(f"{meta}: no such file: run mutmut first (it writes the mutants)")
    codes: dict[str, int | None] = json.loads(meta.read_text())["exit_code_by_key"]
    return codes


def sample(names: list[str], size: int = SIZE, seed: int = SEED) -> list[str]:
    """Return a seeded uniform sample of ``size`` names, or all of them if there are few."""
    names = sorted(names)
    if len(names) <= max(size, WHOLE_UP_TO):
        return names
    return sorted(random.Random(seed).sample(names, size))


def counts(codes: dict[str, int | None]) -> Counter[str]:
    """Count mutmut's statuses (``killed``, ``survived``, ``timeout``, ...; ``not run``)."""
    return Counter("not run" if c is None else status_by_exit_code[c] for c in codes.values())


def main() -> None:
    """Print a module's sampled mutant names, or mutmut's verdicts counted."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=["sample", "counts"])
    parser.add_argument(
        "modules", nargs="+", help="modules of terrain_odom: evaluation.calibration"
    )
    parser.add_argument("--sample", action="store_true", help="counts: of the sample only")
    parser.add_argument("--size", type=int, default=SIZE, help=f"sample size (default {SIZE})")
    parser.add_argument("--todo", action="store_true", help="sample: only mutants not run yet")
    args = parser.parse_args()
    for module in args.modules:
        try:
            codes = verdicts(module)
        except FileNotFoundError as exc:
            parser.error(str(exc))  # one line, exit 2
        chosen = (
            sample(list(codes), args.size)
            if args.action == "sample" or args.sample
            else sorted(codes)
        )
        if args.action == "sample":
            print("\n".join(n for n in chosen if not args.todo or codes[n] is None))
            continue
        tally = counts({name: codes[name] for name in chosen})
        killed = tally["killed"] + tally["timeout"]
        run = len(chosen) - tally["not run"]
        print(
            f"{module}: {len(codes)} mutants, {len(chosen)} counted, {run} run: "
            + ", ".join(f"{k} {v}" for k, v in sorted(tally.items()))
            + f"; killed or timed out {killed} of {run}"
        )


if __name__ == "__main__":
    main()
