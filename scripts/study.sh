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
# docs/accuracy/denoise and the denoising section belong to `make study-denoise` and are kept.
mkdir -p docs/accuracy
find docs/accuracy -mindepth 1 -maxdepth 1 ! -name denoise -exec rm -rf {} +
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

- Each table ends with, for a few error targets, the render that reached it first, the path
  tracer's first rung that did, and the fastest photon method's. `--method auto` (the default)
  encodes the current reading of these tables: see `docs/auto.md`.
- With camera samples (1–4 eye samples and 8–32 camera samples per pixel) the photon methods reach
  every target from 0.02 down to 0.005 before the path tracer on all four scenes: 4.1× sooner at
  0.01 on the Cornell box (256²), 3.3× on the bumpy box, and on the glossy Cornell box (caustics
  through the glass sphere) and the secondary-light room the path tracer reaches none of those
  targets within 64 spp. Only at 0.05 on the bumpy box is the path tracer first (8 spp).
- `rs-rc` is the quickest to moderate errors on the diffuse scenes (0.01 in 0.57 s on the Cornell
  box, 0.20 s on the bumpy box) but flattens early (0.0031 on the bumpy box, 0.013–0.016
  on secondary-light at every budget). `rs` keeps improving with photons and samples and has the
  lowest error of the density-estimation methods at the top budgets (0.00075 and 0.00086 on the two
  boxes, 0.0033 on secondary-light). `pm` is the best on the glossy Cornell box, whose caustics it
  resolves with its k-NN estimate.
- The final-gathering methods (`pm-fg`, `rpm-fg`, `rs-fg`, `he-fg`) move the density estimate one
  bounce away from the eye: the lowest errors of the study on the boxes (`he-fg` 0.00047 in 18 s
  on the Cornell box, `rpm-fg` 0.00054 in 11 s). `rpm-fg` gives `pm-fg`'s image 5–8× faster
  (docs/final-gathering.md); `rs-fg` is the slowest by far (its larger budgets were skipped);
  `he-fg` is for scenes lit mostly by a small bright patch (docs/secondary-lights.md).
- `pt` is unbiased and keeps converging (error ∝ 1/samples): for errors below what a density
  estimate's bias allows at a budget, or when an unbiased image is the point, it is the method.
- Errors "against the converged image" subtract the reference's own error, measured from its two
  halves (0.00003 on the boxes, 0.0007 on the glossy box, 0.0073 on secondary-light).
MD
if [ -f docs/accuracy/denoise/section.md ]; then
  { echo; echo "<!-- denoise:begin (make study-denoise) -->"; echo; cat docs/accuracy/denoise/section.md; echo "<!-- denoise:end -->"; } >> "$out"
fi
echo "study: wrote $out"
