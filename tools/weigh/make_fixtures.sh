#!/usr/bin/env bash
# The truck files a study estimates on virtual-truck variants 0-3 (our protocol, the `truck`
# structure, seed 1), committed as crates/apps/tests/fixtures/study_truck_variant{0..3}.toml:
# the weighing tests weigh each variant with what its study estimated, never with its truth.
# Run from the repository root after changing the study: bash tools/weigh/make_fixtures.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --locked -p airsus
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for k in 0 1 2 3; do
  target/release/airsus generate --variant "$k" --seed 1 --out "$work/v$k" >/dev/null
  target/release/airsus study "$work/v$k/study_valve.toml" --models truck --out "$work/out$k" >/dev/null
  cp "$work/out$k/estimated/study_truck.toml" "crates/apps/tests/fixtures/study_truck_variant$k.toml"
  echo "variant $k: crates/apps/tests/fixtures/study_truck_variant$k.toml"
done
