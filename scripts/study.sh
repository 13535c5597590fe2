#!/usr/bin/env bash
# Regenerate docs/accuracy.md and its plots from scratch: `raysplat study` on the repository's scenes.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=target/release/raysplat
# Image size: each scene's own (its render settings) unless STUDY_RESOLUTION=WxH is given.
RES=${STUDY_RESOLUTION:-}
REF_SPP=${STUDY_REFERENCE_SPP:-4096}
BUDGETS=${STUDY_BUDGETS:-1,2,4,8,16}
# What the budgets scale for the photon methods (`raysplat study --ladder`): photons, spp, fg-rays.
LADDER=${STUDY_LADDER:-photons,spp}
# The photon methods' eye samples (density estimate) and camera samples (anti-aliasing, direct
# light) per pixel at the first rung, as `auto`'s presets take them (docs/auto.md).
EYE_SPP=${STUDY_EYE_SPP:-1}
AA_SPP=${STUDY_AA_SPP:-8}
# A method whose render takes longer than this skips its larger budgets.
MAX_SECONDS=${STUDY_MAX_SECONDS:-30}
rm -rf docs/accuracy
mkdir -p docs/accuracy
out=docs/accuracy.md
{
  echo "# Accuracy and speed of the methods"
  echo
  echo "Produced by \`make study\` ($(date -u +%Y-%m-%d), $(nproc) cores): for each scene a path-traced"
  echo "reference ($REF_SPP spp in two halves, ${RES:-each scene at its own resolution}), then every method at budgets ×{$BUDGETS} (pt: ×4 spp; photon"
  echo "methods: the ladder \`--ladder $LADDER\` from 25 000 photons, $EYE_SPP eye sample(s) and $AA_SPP camera samples per"
  echo "pixel; a method stops at the first budget that takes over $MAX_SECONDS s). Errors are relative MSE ="
  echo "mean((test − ref)² / (ref² + 0.01)) over RGB, as \`raysplat compare\` prints, against the reference and"
  echo "against the converged image (the first less the reference's own error, measured from its two halves)."
  echo "Times are wall-clock seconds on this machine; compare them as ratios within one table."
  echo
} > "$out"
for scene in cornell-box bumpy-box cornell-glossy secondary-light; do
  [ -f "scenes/$scene.usda" ] || continue
  $BIN study "scenes/$scene.usda" -o "docs/accuracy/$scene" ${RES:+--resolution "$RES"} \
      --reference-spp "$REF_SPP" --budgets "$BUDGETS" --ladder "$LADDER" \
      --eye-spp "$EYE_SPP" --aa-spp "$AA_SPP" --max-seconds "$MAX_SECONDS" > /dev/null
  rm -f "docs/accuracy/$scene/reference.exr"
  {
    echo "## $scene"
    echo
    cat "docs/accuracy/$scene/study.md"
    echo
    echo "![error against time, $scene](accuracy/$scene/error-vs-time.png)"
    echo
  } >> "$out"
done
cat >> "$out" <<'MD'
## What to pick

- The tables' last section lists, for each error target, the method that reached it first in this
  study. Use it: the answer depends on the scene and on the error you need. `--method auto` (the
  default) encodes the current reading of these tables: see `docs/auto.md`.
- `pt` is unbiased and converges to the reference; its error falls as 1/samples. It wins whenever
  the target error is low enough that the photon methods' bias (blur of the density estimate) and
  their noise from 4 eye samples per pixel (direct light, anti-aliasing) dominate.
- `rs`, `pm` and `rs-rc` reach a low-noise indirect illumination quickly; their error flattens at a
  floor set by the eye pass (4 eye samples per pixel) and the bandwidth.
- The final-gathering methods (`pm-fg`, `rpm-fg`, `rs-fg`, `he-fg`) move the density estimate one
  bounce away from the eye: less blur at the primary hits, more time per eye sample (64 gather rays;
  he-fg 48 + 230 explicit). `rpm-fg` gives `pm-fg`'s image faster (docs/final-gathering.md);
  `he-fg` is for scenes lit mostly by a small bright patch (docs/secondary-lights.md).
- The errors are against the path-traced reference as it is. On `secondary-light` the 4096-spp
  reference has a relative MSE of about 0.01 itself (measured from two halves), so no method can
  show less than ~0.01 in its table; `raysplat bench --target-table` subtracts the reference's
  measured noise and finds `rs` at 0.01 61× sooner than `pt` there (docs/auto.md).
MD
echo "study: wrote $out"
