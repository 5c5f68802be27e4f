#!/usr/bin/env bash
# Builds and installs the Python package (`pip install ./py`, maturin as the
# build backend) into .venv and runs pytest on py/tests. The CLI-equality
# tests need the vpctl binary: VPCTL_BIN (default: the debug build that
# `cargo test --workspace` just made); VP_REQUIRE_VPCTL=1 turns a missing
# binary into a failure instead of a skip (scripts/test.sh sets it).
set -euo pipefail
cd "$(dirname "$0")/.."

# Absolute: pytest runs from py/tests.
target="$(realpath -m "${CARGO_TARGET_DIR:-target}")"
export VPCTL_BIN="$(realpath -m "${VPCTL_BIN:-$target/debug/vpctl}")"
if [ "${VP_REQUIRE_VPCTL:-0}" = "1" ] && [ ! -x "$VPCTL_BIN" ]; then
  echo "test_python.sh: no vpctl binary at $VPCTL_BIN (run cargo test --workspace first)" >&2
  exit 1
fi

if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
py=.venv/bin/python
# dask[distributed]: the `dask` extra of py/pyproject.toml (vpctl.distributed,
# tested on a LocalCluster of 2 workers in py/tests/test_distributed.py);
# mypy: the stubs say what runs (below).
$py -m pip install --quiet --disable-pip-version-check numpy pytest "dask[distributed]>=2024.1" mypy
# The tests build the extension with cargo's dev profile (dependencies at
# opt-level 2, see Cargo.toml) into cargo's target folder: cold, that is
# about a third faster than the release profile a user's `pip install ./py`
# gets, and a re-run after a change to py/ relinks in seconds instead of a
# minute. After `cargo test --workspace` it reuses that build's artifacts
# and compiles only pyo3, numpy and the extension: py/Cargo.toml asks for
# the dependency features the workspace's dev-dependencies turn on, which
# a build of the one package would otherwise resolve without.
CARGO_TARGET_DIR="$target" MATURIN_PEP517_ARGS="--profile dev" \
  $py -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps ./py
# Not from the repo root: `import vpctl` must find the installed package.
(cd py/tests && ../../$py -m pytest -q -p no:cacheprovider .)
# The stubs say what runs: mypy on the package's stubs and Python modules,
# then stubtest, which imports the installed package and compares every
# stub with what runs (a property typed as a method, a missing parameter).
# (No cache left behind: MYPY_CACHE_DIR=/dev/null.)
MYPY_CACHE_DIR=/dev/null $py -m mypy py/python/vpctl
(cd py/tests && MYPY_CACHE_DIR=/dev/null ../../$py -m mypy.stubtest vpctl)
