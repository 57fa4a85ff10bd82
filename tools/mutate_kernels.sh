#!/usr/bin/env bash
# Mutation testing of the EKF kernels (estimation/_kernels.py, _slip_kernels.py,
# _kalman_kernels.py) as Python: docs/testing.md.
#
# mutmut reads [tool.mutmut] from the pyproject.toml of the folder it runs in, and
# the core's configuration there mutates other modules against other tests. This
# script checks the committed tree (HEAD) out into a scratch worktree, swaps that
# block for tools/mutmut_kernels.toml, runs mutmut there with numba's JIT off
# (njit returns the Python function, so mutmut's trampolines run) and prints the
# survivors; the scratch tree is removed at exit. Uncommitted changes are not seen.
#
# Usage (with the project's venv active, from anywhere in the repository):
#   tools/mutate_kernels.sh                                   # every kernel mutant
#   tools/mutate_kernels.sh "terrain_odom.estimation._kalman_kernels.x_wrap*"
# Arguments go to `mutmut run` (mutant names or globs).
set -euo pipefail

repo=$(git -C "$(dirname "${BASH_SOURCE[0]}")" rev-parse --show-toplevel)
config="$repo/tools/mutmut_kernels.toml"
scratch=$(mktemp -d "${TMPDIR:-/tmp}/mutate_kernels.XXXXXX")
cleanup() {
    git -C "$repo" worktree remove --force "$scratch/tree" 2>/dev/null || true
    rm -rf "$scratch"
    git -C "$repo" worktree prune
}
trap cleanup EXIT

git -C "$repo" worktree add --quiet --detach "$scratch/tree" HEAD
cd "$scratch/tree"
# drop the [tool.mutmut] table (up to the next table) and append the kernels' one
awk '/^\[/ { skip = ($0 == "[tool.mutmut]") } !skip' pyproject.toml > "$scratch/pyproject.toml"
{ echo; cat "$config"; } >> "$scratch/pyproject.toml"
mv "$scratch/pyproject.toml" pyproject.toml

NUMBA_DISABLE_JIT=1 OPENCV_FOR_THREADS_NUM=1 mutmut run --max-children 1 "$@"
mutmut results | grep -v ': not checked$' || true  # the survivors (and timeouts), by name
python - <<'PY'  # mutmut's counts per file, from its .meta files
import collections, json, pathlib
from mutmut.stats import status_by_exit_code
for meta in sorted(pathlib.Path("mutants/src").rglob("*.py.meta")):
    codes = list(json.loads(meta.read_text())["exit_code_by_key"].values())
    counts = collections.Counter(status_by_exit_code[code] for code in codes)
    print(f"{meta.name[:-5]}: {len(codes)} mutants:", ", ".join(f"{n} {s}" for s, n in counts.items()))
PY
