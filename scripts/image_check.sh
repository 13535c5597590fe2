#!/usr/bin/env bash
# Bit-identical images: render every method on every repository scene with two raysplat binaries
# and compare the pixels of every layer of the EXRs bit for bit.
#
#   scripts/image_check.sh OLD_BIN NEW_BIN [SCENE.usda ...]
#
# Each (scene, method) renders at a small size with a fixed seed, on one thread per render, two
# renders at a time. The EXR headers carry times, so the files differ; their pixel chunks (after
# the header and the offset table) must not: the same pixels compress to the same bytes with the
# same OpenEXR. A mismatch prints `raysplat compare --json` of the beauty and indirect layers.
# Exit status 0 when every pair matches, 1 when one differs or fails to render in one binary only,
# 2 for bad arguments. Environment: JOBS (parallel renders, default 2), KEEP=1 keeps the work
# folder, SIZE (default 48x36), AUTO_SIZE for auto (default 128x128, where its photon presets run).
set -euo pipefail

usage() { echo "usage: $0 OLD_BIN NEW_BIN [SCENE.usda ...]" >&2; exit 2; }
[ $# -ge 2 ] || usage
OLD=$(readlink -f "$1"); NEW=$(readlink -f "$2"); shift 2
[ -x "$OLD" ] || { echo "$OLD: not an executable" >&2; exit 2; }
[ -x "$NEW" ] || { echo "$NEW: not an executable" >&2; exit 2; }
ROOT=$(cd "$(dirname "$0")/.." && pwd)
if [ $# -gt 0 ]; then SCENES=("$@"); else SCENES=("$ROOT"/scenes/*.usda); fi
SIZE=${SIZE:-48x36}
AUTO_SIZE=${AUTO_SIZE:-128x128}
JOBS=${JOBS:-2}
PY=python3
[ -x "$ROOT/.venv/bin/python3" ] && export RAYSPLAT_PYTHON=${RAYSPLAT_PYTHON:-$ROOT/.venv/bin/python3}

WORK=$(mktemp -d "${TMPDIR:-/tmp}/image-check.XXXXXX")
if [ "${KEEP:-0}" != 1 ]; then trap 'rm -rf "$WORK"' EXIT; else echo "work folder: $WORK"; fi

# name|arguments: every method, and the variants whose settings take their own paths.
PHOTONS="--photons 20000 --spp 2"
CASES=(
  "pt|--method pt --spp 8"
  "rs|--method rs $PHOTONS"
  "pm|--method pm $PHOTONS"
  "pm-fg|--method pm-fg $PHOTONS --fg-rays 8"
  "rpm-fg|--method rpm-fg $PHOTONS --fg-rays 8"
  "rs-fg|--method rs-fg $PHOTONS --fg-rays 8"
  "he-fg|--method he-fg $PHOTONS --fg-rays 8 --explicit-rays 16"
  "rs-rc|--method rs-rc $PHOTONS"
  "auto|--method auto --quality draft --resolution $AUTO_SIZE"
  "pm-fg-cache|--method pm-fg $PHOTONS --fg-rays 8 --irradiance-cache"
  "he-fg-cache|--method he-fg $PHOTONS --fg-rays 8 --explicit-rays 16 --irradiance-cache --cache-error 0.3"
  "rpm-fg-radius|--method rpm-fg $PHOTONS --fg-rays 8 --gather-radius 0.05 --memory 1M --no-spill"
  "rs-options|--method rs $PHOTONS --glossy sh --filter-radius 2 --direct-photons --aa-spp 4 --smoothness 0.4"
)

# Convert every scene once per binary (the scene format may differ between them).
jobs_file="$WORK/jobs"
: > "$jobs_file"
for scene in "${SCENES[@]}"; do
  name=$(basename "$scene" .usda)
  for case in "${CASES[@]}"; do
    cname=${case%%|*}; args=${case#*|}
    size="--resolution $SIZE"
    [[ "$args" == *--resolution* ]] && size=""
    for side in old new; do
      echo "$side|$scene|$name.$cname|$size $args" >> "$jobs_file"
    done
  done
done

render_one() {
  IFS='|' read -r side scene label args <<< "$1"
  local bin=$OLD; [ "$side" = new ] && bin=$NEW
  mkdir -p "$WORK/$side"
  # shellcheck disable=SC2086
  if RAYSPLAT_CACHE_DIR="$WORK/cache-$side" "$bin" render "$scene" -o "$WORK/$side/$label.exr" \
      --seed 7 --threads 1 $args > "$WORK/$side/$label.log" 2>&1; then
    :
  else
    echo "render failed" >> "$WORK/$side/$label.log"
  fi
}
export -f render_one
export OLD NEW WORK

start=$(date +%s)
# Warm the conversion caches first (one conversion per scene and binary, not one per render).
for scene in "${SCENES[@]}"; do
  for side in old new; do
    bin=$OLD; [ "$side" = new ] && bin=$NEW
    RAYSPLAT_CACHE_DIR="$WORK/cache-$side" "$bin" convert "$scene" "$WORK/$side-$(basename "$scene" .usda).rss" > /dev/null 2>&1 &
  done
  wait
done
tr '\n' '\0' < "$jobs_file" | xargs -0 -P "$JOBS" -I{} bash -c 'render_one "$1"' _ {}
rendered=$(( $(date +%s) - start ))

# Compare the pixel chunks: everything after the header and the chunk offset table.
status=0
"$PY" - "$WORK" <<'EOF' || status=$?
import os, struct, sys
work = sys.argv[1]

def pixels(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError("not an OpenEXR file")
    flags = struct.unpack_from("<I", data, 4)[0]
    if flags & 0x1000:
        raise ValueError("multi-part files are not handled")
    i = 8
    while data[i] != 0:  # attributes: name\0 type\0 size value
        i = data.index(b"\0", i) + 1
        i = data.index(b"\0", i) + 1
        size = struct.unpack_from("<i", data, i)[0]
        i += 4 + size
    table = i + 1
    first = struct.unpack_from("<Q", data, table)[0]  # the first chunk starts after the table
    return data[first:]

bad = 0
labels = sorted(f[:-4] for f in os.listdir(os.path.join(work, "old")) if f.endswith(".log"))
for label in labels:
    o, n = (os.path.join(work, side, label + ".exr") for side in ("old", "new"))
    have = (os.path.exists(o), os.path.exists(n))
    if have == (False, False):
        print(f"both failed  {label}")  # the same bad input in both: not a difference
        continue
    if have != (True, True):
        side = "old" if not have[0] else "new"
        log = open(os.path.join(work, side, label + ".log")).read().strip().splitlines()
        print(f"DIFFERS      {label}: only the {'new' if side == 'old' else 'old'} binary rendered it ({side}: {log[-1] if log else ''})")
        bad += 1
        continue
    if pixels(o) == pixels(n):
        print(f"identical    {label}")
    else:
        print(f"DIFFERS      {label}")
        open(os.path.join(work, "differ"), "a").write(label + "\n")
        bad += 1
print(f"{len(labels) - bad} of {len(labels)} renders identical")
sys.exit(1 if bad else 0)
EOF
if [ -f "$WORK/differ" ]; then
  while read -r label; do
    for layer in "" indirect; do
      echo "  $label ${layer:-beauty}: $("$NEW" compare "$WORK/new/$label.exr" "$WORK/old/$label.exr" --json ${layer:+--layer $layer} 2>&1)"
    done
  done < "$WORK/differ"
fi
echo "rendered in ${rendered}s ($JOBS at a time)"
exit $status
