#!/bin/bash
# Writes `linterpd plan --format json` documents for four courses under four settings into OUT,
# so that a change to the planner meant to keep every figure can be checked byte for byte:
#
#   scripts/plan_documents.sh BEFORE_BINARY /tmp/before
#   scripts/plan_documents.sh target/release/linterpd /tmp/after
#   for f in /tmp/before/*.json; do cmp "$f" "/tmp/after/$(basename "$f")"; done
#
# Courses: the seed's line, config/examples/pick-and-place.toml, the bench's ten-element zig-zag
# (benches/plan.rs) and a half circle of radius 100 mm from the seed's P1. Settings:
# bounded-error 0.05 mm, constant-period, bounded-error 0.1 mm `ideal`, constant-period 10 ms
# `ideal`.
set -euo pipefail
BIN=$1
OUT=$2
ROOT=$(cd "$(dirname "$0")/.." && pwd)
CONFIG=$ROOT/config/linterpd.toml
mkdir -p "$OUT"
PATHS=$(mktemp -d)
trap 'rm -rf "$PATHS"' EXIT
{
  echo 'linterpd_path = 1'
  echo 'start = [-800.0, 900.0, 100.0]'
  echo 'path_accel = "5000mm/s2"'
  for k in 1 2 3 4 5 6 7 8 9 10; do
    z=220.0; [ $((k % 2)) -eq 0 ] && z=100.0
    echo '[[element]]'
    echo "line = [$((-800 + 160 * k)).0, 900.0, $z]"
    [ "$k" -lt 10 ] && echo 'blend = "20mm"'
  done
} > "$PATHS/zigzag.toml"
cat > "$PATHS/arc.toml" <<'TOML'
linterpd_path = 1
start = [-926.57, 535.03, 50.0]
path_accel = "1000mm/s2"
[[element]]
arc = [-1126.57, 535.03, 50.0]
via = [-1026.57, 635.03, 50.0]
TOML
SETTINGS=(
  "--method bounded-error --tolerance 0.05mm"
  "--method constant-period"
  "--method bounded-error --tolerance 0.1mm --frequency-model ideal"
  "--method constant-period --period 10ms --frequency-model ideal"
)
for i in 0 1 2 3; do
  # shellcheck disable=SC2086 # the settings are words
  "$BIN" plan --config "$CONFIG" --from -926.57,535.03,50 --to -1144.43,659.60,186.60 \
    ${SETTINGS[$i]} --format json > "$OUT/seed-$i.json"
  for path in "$ROOT/config/examples/pick-and-place.toml" "$PATHS/zigzag.toml" "$PATHS/arc.toml"; do
    # shellcheck disable=SC2086
    "$BIN" plan --config "$CONFIG" --path "$path" ${SETTINGS[$i]} --format json \
      > "$OUT/$(basename "$path" .toml)-$i.json"
  done
done
echo "$(ls "$OUT" | wc -l) documents in $OUT"
