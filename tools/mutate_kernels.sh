#!/usr/bin/env bash
# Mutation testing of the EKF kernels (estimation/_kernels.py, _slip_kernels.py,
# _kalman_kernels.py) as Python: docs/testing.md.
#
# mutmut reads [tool.mutmut] from the pyproject.toml of the folder it runs in, and
# the core's configuration there mutates other modules against other tests. This
# script checks the committed tree (HEAD) out into a scratch worktree, swaps that
# block for tools/mutmut_kernels.toml, runs mutmut there with numba's JIT off
# (njit returns the Python function, so mutmut's trampolines run) and prints the
# survivors with their diffs and mutmut's counts per module; the scratch tree (and with it
# mutants/) is removed at exit. Uncommitted changes are not seen: commit first.
#
# Usage (with the project's venv active, from anywhere in the repository):
#   tools/mutate_kernels.sh                                   # every kernel mutant
#   tools/mutate_kernels.sh "terrain_odom.estimation._kalman_kernels.x_wrap*"
# Arguments go to `mutmut run` (mutant names or globs).
set -euo pipefail

repo=$(git -C "$(dirname "${BASH_SOURCE[0]}")" rev-parse --show-toplevel)
if ! command -v mutmut > /dev/null; then
    echo "mutate_kernels.sh: mutmut not found: activate the project's venv (pip install -e '.[dev]')" >&2
    exit 2
fi
if ! git -C "$repo" diff --quiet HEAD; then
    echo "mutate_kernels.sh: note: uncommitted changes are not mutated (HEAD is)" >&2
fi

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
{ echo; cat tools/mutmut_kernels.toml; } >> "$scratch/pyproject.toml"  # as committed
mv "$scratch/pyproject.toml" pyproject.toml

NUMBA_DISABLE_JIT=1 OPENCV_FOR_THREADS_NUM=1 OMP_NUM_THREADS=1 mutmut run --max-children 1 "$@"
survivors=$(mutmut results | grep -v ': not checked$' || true)  # survivors, timeouts, by name
echo "$survivors"
for name in $(echo "$survivors" | sed -n 's/^ *\([^ :]*\): survived$/\1/p'); do
    mutmut show "$name"  # its diff: mutants/ goes with the scratch tree
done
# mutmut's verdicts counted per module (tools/mutation.py, as committed)
python tools/mutation.py counts estimation._kernels estimation._slip_kernels estimation._kalman_kernels
