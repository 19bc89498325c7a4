#!/usr/bin/env bash
# The FMU checks of issue #18: build airsus and the FMU library, install FMPy into a venv,
# then validate the FMUs and compare them with `airsus simulate` (tools/fmu/test_fmu.py).
set -euo pipefail
cd "$(dirname "$0")/../.."
# AIRSUS_FMU_PROFILE=dev (as CI) reuses the test build; the default is the release build users run.
profile="${AIRSUS_FMU_PROFILE:-release}"
# In the dev profile (CI) the whole workspace, so that cargo resolves the same features as the
# test build did and reuses it; a release build asks only for what it needs.
case "$profile" in
dev | test) cargo build --profile "$profile" --locked --workspace ;;
*) cargo build --profile "$profile" --locked -p airsus -p airsus-fmu ;;
esac
case "$profile" in dev | test) dir=debug ;; *) dir="$profile" ;; esac
venv="${AIRSUS_FMU_VENV:-target/fmu-venv}"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r tools/fmu/requirements.txt
export AIRSUS_BIN="${AIRSUS_BIN:-$PWD/target/$dir/airsus}"
"$venv/bin/python" -m pytest tools/fmu -q -p no:cacheprovider
