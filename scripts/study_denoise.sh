#!/usr/bin/env bash
# Regenerate the denoising section of docs/accuracy.md (between its "denoise:begin" and
# "denoise:end" markers) and docs/accuracy/denoise/: `raysplat study --denoise both` of pt, rs and
# rs-rc on the Cornell box, Crytek Sponza at 200x200 (when the shared scenes are there) and the
# secondary-light room. Each scene is one run in which the methods alternate, budget by budget.
# STUDY_SCENES (default: all three) names the scenes to run again; the section is assembled from
# every scene's last run.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=target/release/raysplat
SHARED=${SHARED_SCENES:-../shared/scenes}
REF_SPP=${STUDY_REFERENCE_SPP:-2048}
BUDGETS=${STUDY_BUDGETS:-1,2,4,8,16,32}
QUALITIES=${STUDY_DENOISE_QUALITY:-fast,high}
MAX_SECONDS=${STUDY_MAX_SECONDS:-20}
RUN=${STUDY_SCENES:-cornell-box,sponza,secondary-light}
OUT=docs/accuracy/denoise
SECTION=$OUT/section.md
mkdir -p "$OUT"

# name, scene file, resolution (empty: the scene's own)
scenes=("cornell-box|scenes/cornell-box.usda|" "sponza|$SHARED/classic/crytek_sponza/sponza.usdc|200x200" "secondary-light|scenes/secondary-light.usda|")
for entry in "${scenes[@]}"; do
  IFS='|' read -r name scene res <<< "$entry"
  case ",$RUN," in *",$name,"*) ;; *) continue ;; esac
  rm -rf "${OUT:?}/$name"
  if [ ! -f "$scene" ]; then
    echo "study-denoise: $scene is absent: $name skipped" >&2
    continue
  fi
  mkdir -p "$OUT/$name"
  cut -d' ' -f1-3 /proc/loadavg > "$OUT/$name/load.txt"
  $BIN study "$scene" -o "$OUT/$name" ${res:+--resolution "$res"} --methods pt,rs,rs-rc \
      --reference-spp "$REF_SPP" --budgets "$BUDGETS" --ladder photons,spp --eye-spp 1 --aa-spp 8 \
      --max-seconds "$MAX_SECONDS" --denoise both --denoise-quality "$QUALITIES" > /dev/null
  rm -f "$OUT/$name/reference.exr"
  # the shared scenes' path as a checkout beside them sees it
  sed -i "s|$SHARED|../shared/scenes|g" "$OUT/$name/study.md"
done

{
  echo "## Denoising: pt, rs and rs-rc with and without Open Image Denoise"
  echo
  echo "Produced by \`make study-denoise\` ($(date -u +%Y-%m-%d), $(nproc) cores shared with other jobs:"
  echo "absolute times are noisy — each scene's table comes from one run in which the methods"
  echo "alternate budget by budget, and the load average near its start is given)."
  echo "\`raysplat study --denoise both --denoise-quality $QUALITIES\`: a path-traced reference ($REF_SPP spp"
  echo "in two halves), then pt at 4 spp × {$BUDGETS} and rs, rs-rc on the ladder \`photons,spp\` from 25 000"
  echo "photons, 1 eye sample and 8 camera samples per pixel (a method stops after a render over"
  echo "$MAX_SECONDS s), each render measured as rendered and after Open Image Denoise at each quality"
  echo "(seconds include the denoise). Errors are relative MSE against the converged image (the"
  echo "reference's own error, from its two halves, subtracted); the denoised error is measured against"
  echo "the same reference. \`docs/denoise.md\` says what the denoiser does and where it fails."
  echo
  for entry in "${scenes[@]}"; do
    IFS='|' read -r name scene res <<< "$entry"
    echo "### $name"
    echo
    if [ ! -f "$OUT/$name/denoise.md" ]; then
      echo "Not measured: \`$scene\` was absent."
      echo
      continue
    fi
    head -n 3 "$OUT/$name/study.md"
    echo
    echo "Load average (1, 5, 15 minutes) $(cat "$OUT/$name/load.txt" 2>/dev/null || echo unknown) near the start of the run${res:+; rendered at $res}."
    echo
    cat "$OUT/$name/denoise.md"
    echo
    echo "![error against time, $name, raw and denoised](accuracy/denoise/$name/error-vs-time.png)"
    echo
  done
  cat <<'MD'
### Reading

- **Cornell box** (diffuse, one small light): the path tracer's error is pixel noise, which OIDN
  removes: 33× lower at 4 spp (0.050 → 0.0015) and 23× at 32 spp; pt + OIDN has the lowest error
  at every time limit. The photon methods gain 14–20 % at their first rungs and 1–3 % at the top
  ones: their error is low-frequency (half of rs-rc's lies at scales above 8 pixels, against 2 %
  of pt's; `raysplat compare --block 8`), and OIDN leaves those blotches as they are.
- **Sponza** (sun through the arches, sky, textures): here the photon methods' raw error is mostly
  the eye pass's pixel noise (direct sun and sky light from 8 camera samples), so OIDN lowers it
  10× (rs-rc 0.020 → 0.0020) as it lowers the path tracer's 31× (4 spp: 0.083 → 0.0026). Within
  4 s: pt 0.083, pt + OIDN 0.0026, photon methods 0.020, photon methods + OIDN 0.0020 (rs-rc, 50k
  photons, 1 + 8 spp, 3.9 s) — the denoised photon methods lead until about 8 s (0.0015 against
  0.0018), the denoised path tracer after (16 s: 0.00069 against 0.0013). Within 1 s nothing
  finished: under this load the scene's preparation alone took 0.4–0.9 s and the first rungs
  2.4 s (pt, 4 spp) and 2.8 s (rs-rc).
- **Secondary-light** (a room lit by a small bright patch): the path tracer is fireflies
  (relative MSE 10 at 4 spp, 0.27 at 128). OIDN lowers that 66–290× but spreads each firefly
  into a blotch: pt + OIDN stays behind the photon methods as rendered at every time limit
  (1 s: 0.012 against rs-rc's 0.0095; 4 s: 0.0071 against 0.0042), and the photon methods, whose
  error is low-frequency, gain 1–12 % from it. rs-rc is first up to 4 s, rs after (denoised
  or not: OIDN changes them by 1–2 % there).
- `high` beats `fast` on the path tracer by up to 20 % on the Cornell box and Sponza, for twice
  the denoise time (still under a tenth of the render's); on secondary-light and on the photon
  methods the two are within 10 % either way (`fast` ahead on secondary-light's path tracer).
MD
} > "$SECTION"

# Splice the section into docs/accuracy.md between the markers (appended the first time).
python3 scripts/splice_section.py denoise "make study-denoise" docs/accuracy.md "$SECTION"
echo "study-denoise: wrote $SECTION into docs/accuracy.md"
