#!/usr/bin/env bash
# The Python package in CI (called by .ci/run after `cargo test --workspace`, which leaves the
# `airsus` command in target/debug for the comparisons):
#   1. build the wheel the way `pip install ./python` does (maturin as the PEP 517 backend);
#   2. install it into a fresh virtual environment with no Rust toolchain on PATH;
#   3. run the pytest suite there, the quickstart notebook included (tests/test_notebook.py).
# MATURIN_PEP517_ARGS may be set by the caller (e.g. "--profile dev" to reuse the test build).
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

python3 -m venv "$work/build"
"$work/build/bin/python" -m pip install --quiet --upgrade pip
"$work/build/bin/python" -m pip wheel --no-deps --wheel-dir "$work/dist" ./python

wheels=("$work"/dist/airsus-*.whl)
if [ "${#wheels[@]}" -ne 1 ] || [ ! -f "${wheels[0]}" ]; then
  echo "expected one airsus wheel in $work/dist" >&2
  exit 1
fi
echo "built ${wheels[0]##*/}"

python3 -m venv "$work/venv"
# No cargo, rustc or rustup here: the wheel must install and import as it is.
clean_path="$work/venv/bin:/usr/local/bin:/usr/bin:/bin"
env PATH="$clean_path" "$work/venv/bin/python" -m pip install --quiet --upgrade pip
# [spark]: PySpark for the fleet jobs' tests in local mode (java comes from .ci/run).
env PATH="$clean_path" "$work/venv/bin/python" -m pip install --quiet "${wheels[0]}[test,spark]"
if env PATH="$clean_path" bash -c 'command -v cargo' >/dev/null; then
  echo "cargo is on the clean PATH; the no-toolchain install is not tested" >&2
  exit 1
fi

cd "$root/python"
env PATH="$clean_path" CI="${CI:-true}" AIRSUS_BIN="${AIRSUS_BIN:-$root/target/debug/airsus}" \
  "$work/venv/bin/python" -m pytest -q -p no:cacheprovider tests
