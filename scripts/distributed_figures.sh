#!/usr/bin/env bash
# Figures of docs/distributed.md: (1) progressive passes' merged error against a path-traced
# reference for rs and pm, passes 1, 4, 16, 64, 256 (each count the merge of the parts before it
# plus one more range), fixed-bandwidth runs of 64 and 256 passes and the floor they tend to, and
# the reference's own noise; (2) makespan of a farm job of 1, 2
# and 4 tasks on a one-node Slurm started here (scripts/slurm-cluster.sh), with per-part costs.
# Usage: scripts/distributed_figures.sh [WORKDIR]   (needs target/release/raysplat; root for Slurm;
# PASSES_ONLY=1 for the first table only)
set -euo pipefail
cd "$(dirname "$0")/.."
B=$PWD/target/release/raysplat
W=$(realpath -m "${1:-/tmp/raysplat-distributed}")
mkdir -p "$W"
RES=${RES:-64x64}
PHOTONS=${PHOTONS:-10000}
AA_SPP=${AA_SPP:-16}
# relative MSE per pixel (block 1) or of 8x8-pixel block averages (block 8: the low-frequency
# error, where bias shows), and arithmetic on such numbers
rel() { "$B" compare "$1" "$2" --json --block "$3" | sed -E 's/.*"rel_mse":([^,]*).*/\1/'; }
calc() { awk "BEGIN { printf \"%.5f\", $1 }"; }
# The reference is the merge M of two independent halves A, B (pt passes of 4096 spp): its own
# noise is rel(A, M) (A − M = (A − B)/2, half the variance of a half). Every error below is
# against M less that noise: the error against the converged image.
noise() { rel "$ref_a" "$ref" "$1"; }
err1() { calc "$(rel "$1" "$ref" "$2") - $(noise "$2")"; }
err() { echo "$(err1 "$1" 1) / $(err1 "$1" 8)"; }
# The fixed-bandwidth floor (the error its passes tend to: its bias) from two independent halves
# A, B of its passes and their merge M: E mse(M) = var/2 + floor, E (mse(A) + mse(B))/2 = var +
# floor, so floor = 2 mse(M) − (mse(A) + mse(B))/2.
floor1() { calc "2 * $(err1 "$3" "$4") - ($(err1 "$1" "$4") + $(err1 "$2" "$4")) / 2"; }
floor() { echo "$(floor1 "$@" 1) / $(floor1 "$@" 8)"; }
echo "## progressive passes ($RES, $PHOTONS photons, 1 eye sample and $AA_SPP camera samples per pixel per pass; relative MSE against pt at 8192 spp less the reference's noise, per pixel / of 8x8 blocks)"
echo "| scene | method | 1 | 4 | 16 | 64 | 256 | fixed bandwidth, 64 | fixed bandwidth, 256 | fixed-bandwidth floor | reference's noise |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for scene in cornell-box secondary-light; do
  S=scenes/$scene.usda
  ref=$W/$scene-ref.exr ref_a=$W/$scene-ref-0:1.exr ref_b=$W/$scene-ref-1:2.exr
  for r in 0:1 1:2; do
    [ -f "$W/$scene-ref-$r.exr" ] || "$B" render $S --method pt --resolution $RES --spp 4096 --passes 2 --pass-range $r -o "$W/$scene-ref-$r.exr" 2>/dev/null
  done
  "$B" merge "$ref_a" "$ref_b" -o "$ref" 2>/dev/null
  for m in rs pm; do
    F="$S --method $m --resolution $RES --spp 1 --aa-spp $AA_SPP --photons $PHOTONS --passes 256"
    row="| $scene | $m |"
    prev=()
    for r in 0:1 1:4 4:16 16:64 64:256; do
      "$B" render $F --pass-range $r -o "$W/$scene-$m-$r.exr" 2>/dev/null
      prev+=("$W/$scene-$m-$r.exr")
      "$B" merge "${prev[@]}" -o "$W/$scene-$m-upto-${r#*:}.exr" 2>/dev/null
      row="$row $(err "$W/$scene-$m-upto-${r#*:}.exr") |"
    done
    fx=$W/$scene-$m-fixed
    for r in 0:64 64:128 128:256; do "$B" render $F --fixed-bandwidth --pass-range $r -o "$fx-$r.exr" 2>/dev/null; done
    "$B" merge "$fx-0:64.exr" "$fx-64:128.exr" -o "$fx-A.exr" 2>/dev/null
    "$B" merge "$fx-0:64.exr" "$fx-64:128.exr" "$fx-128:256.exr" -o "$fx-M.exr" 2>/dev/null
    echo "$row $(err "$fx-0:64.exr") | $(err "$fx-M.exr") | $(floor "$fx-A.exr" "$fx-128:256.exr" "$fx-M.exr") | $(calc "$(noise 1)") / $(calc "$(noise 8)") |"
  done
done

[ -n "${PASSES_ONLY:-}" ] && exit 0
echo
echo "## makespan on this machine's one-node Slurm (2 CPUs; 1 CPU per task)"
C=$W/cluster
export SLURM_CONF=$(scripts/slurm-cluster.sh start "$C")
trap 'scripts/slurm-cluster.sh stop "$C"' EXIT
FLAGS=(--method rs --resolution 256x256 --spp 4 --photons 200000)
echo "| split | tasks | makespan s (submit to merged) | per task: load + prepare, eye, light, splat s (mean) |"
echo "|---|---|---|---|"
for split in tiles passes; do
  for n in 1 2 4; do
    J=$W/job-$split-$n
    rm -rf "$J"
    extra=()
    [ $split = passes ] && extra=(--passes 4)
    "$B" farm plan scenes/cornell-box.usda --split $split --tasks $n -o "$J" -- "${FLAGS[@]}" "${extra[@]}" 2>/dev/null
    t0=$(date +%s.%N)
    "$B" farm submit "$J" 2>/dev/null
    until [ -f "$J/out.exr" ]; do sleep 0.1; done
    t1=$(date +%s.%N)
    phases=$(cat "$J"/logs/task-*.log | grep '^time:' | sed -E 's/.*prepare ([0-9.]+)s, eye ([0-9.]+)s, light ([0-9.]+)s, splat ([0-9.]+)s.*/\1 \2 \3 \4/' | awk '{p+=$1;e+=$2;l+=$3;s+=$4;n++} END {printf "%.2f, %.2f, %.2f, %.2f", p/n, e/n, l/n, s/n}')
    echo "| $split | $n | $(echo "$t1 - $t0" | bc) | $phases |"
  done
done
echo
t0=$(date +%s.%N); "$B" merge "$W"/job-passes-4/parts/*.exr -o "$W/m.exr" 2>/dev/null; t1=$(date +%s.%N)
echo "conversion: $(grep -o 'in [0-9.]*s' "$W"/job-tiles-1/logs/convert.log | head -1); part size (256x256, all AOVs): $(stat -c %s "$W"/job-tiles-1/parts/part-0000.exr) bytes; merge of 4 whole-image parts: $(echo "$t1 - $t0" | bc) s"
