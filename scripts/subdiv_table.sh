#!/usr/bin/env bash
# Subdivision surfaces from a USD stage to the first image, with two raysplat binaries: a Markdown
# table of the conversion (wall time, peak resident memory, .rss size) and of the scene build
# (`prepare` phase of a 1-sample path-traced render of the .rss, its wall time and peak memory).
#
#   scripts/subdiv_table.sh OLD_BIN NEW_BIN STAGE.usda [STAGE.usda ...]
#
# Each binary converts each stage at its default subdivision setting into a fresh cache folder
# (RAYSPLAT_CACHE_DIR), then renders the .rss once (--method pt --spp 1 --threads 2, the scene's
# resolution). Runs one command at a time: run it on an otherwise idle machine for figures to quote.
# Peak memory is GNU time's maximum resident set size. Exit status 2 for bad arguments.
set -euo pipefail

[ $# -ge 3 ] || { echo "usage: $0 OLD_BIN NEW_BIN STAGE.usda [STAGE.usda ...]" >&2; exit 2; }
OLD=$(readlink -f "$1"); NEW=$(readlink -f "$2"); shift 2
for b in "$OLD" "$NEW"; do [ -x "$b" ] || { echo "$b: not an executable" >&2; exit 2; }; done
[ -x /usr/bin/time ] || { echo "GNU time (/usr/bin/time) is needed" >&2; exit 2; }
ROOT=$(cd "$(dirname "$0")/.." && pwd)
[ -x "$ROOT/.venv/bin/python3" ] && export RAYSPLAT_PYTHON=${RAYSPLAT_PYTHON:-$ROOT/.venv/bin/python3}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/subdiv-table.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

mib() { awk -v k="$1" 'BEGIN { printf "%.0f", k / 1024 }'; }

echo "| stage | binary | convert (s) | convert peak (MiB) | .rss (MB) | scene build (s) | render 1 spp (s) | render peak (MiB) | geometry |"
echo "|---|---|---|---|---|---|---|---|---|"
for stage in "$@"; do
  [ -f "$stage" ] || { echo "$stage: no such file" >&2; exit 2; }
  for which in old new; do
    bin=$OLD; [ $which = new ] && bin=$NEW
    dir="$WORK/$which"; rm -rf "$dir"; mkdir -p "$dir/cache"
    export RAYSPLAT_CACHE_DIR="$dir/cache"
    /usr/bin/time -f "%e %M" -o "$dir/convert.time" "$bin" convert "$stage" "$dir/scene.rss" >"$dir/convert.log" 2>&1 \
      || { echo "$which: conversion failed:" >&2; tail -5 "$dir/convert.log" >&2; exit 1; }
    read -r conv_s conv_kb <"$dir/convert.time"
    size=$(stat -c %s "$dir/scene.rss")
    /usr/bin/time -f "%e %M" -o "$dir/render.time" "$bin" render "$dir/scene.rss" -o "$dir/out.exr" \
      --method pt --spp 1 --threads 2 --json >"$dir/render.json" 2>"$dir/render.log" \
      || { echo "$which: render failed:" >&2; tail -5 "$dir/render.log" >&2; exit 1; }
    read -r render_s render_kb <"$dir/render.time"
    read -r prepare_s geometry < <(python3 -c '
import json, sys
s = json.load(open(sys.argv[1]))
phases = dict(s["phases"])
print("%.2f" % phases.get("prepare", float("nan")), s.get("scene", "").split(";")[0])' "$dir/render.json")
    printf "| %s | %s | %.1f | %s | %.1f | %s | %.1f | %s | %s |\n" "$(basename "$stage")" "$which" "$conv_s" "$(mib "$conv_kb")" \
      "$(awk -v b="$size" 'BEGIN { print b / 1e6 }')" "$prepare_s" "$render_s" "$(mib "$render_kb")" "$geometry"
  done
done
