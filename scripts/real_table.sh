#!/usr/bin/env bash
# Regenerate the real-scene table of docs/accuracy.md (between its "real:begin" and "real:end"
# markers) from one run of `raysplat-bench real`: auto and each single method at equal times on
# the workplace's shared scenes (when present) and the repository's, against path-traced
# references kept in raysplat's cache folder (a rerun renders only the timed rows).
# REAL_TIMES (default 1,4,16), REAL_SIZE (200), REAL_REFERENCE_SPP (1024), REAL_SCENES (default:
# the benchmark's own list) and SHARED_SCENES (../shared/scenes) change the run; the run's
# Markdown is kept in docs/accuracy/real.md and spliced into docs/accuracy.md.
set -euo pipefail
cd "$(dirname "$0")/.."
BENCH=target/release/raysplat-bench
SHARED=${SHARED_SCENES:-../shared/scenes}
OUT=docs/accuracy/real.md
cargo build --release -p raysplat-bench
mkdir -p "$(dirname "$OUT")"
args=(--real-times "${REAL_TIMES:-1,4,16}" --real-size "${REAL_SIZE:-200}"
      --real-reference-spp "${REAL_REFERENCE_SPP:-1024}" --shared-scenes "$SHARED")
if [ -n "${REAL_SCENES:-}" ]; then args+=(--real-scenes "$REAL_SCENES"); fi
tmp=$(mktemp "$OUT.XXXXXX")
trap 'rm -f "$tmp"' EXIT
{
  echo "Produced by \`scripts/real_table.sh\` (\`make bench-real\`) on $(date -u +%Y-%m-%d) with"
  echo "$(nproc) cores; load average $(cut -d' ' -f1-3 /proc/loadavg) at the start (1, 5, 15 minutes)."
  echo
  $BENCH real "${args[@]}"
} > "$tmp"
mv "$tmp" "$OUT"
trap - EXIT

# Splice the run into docs/accuracy.md between the markers (appended the first time).
python3 scripts/splice_section.py real "make bench-real" docs/accuracy.md "$OUT" --trim
echo "real_table: wrote $OUT into docs/accuracy.md"
