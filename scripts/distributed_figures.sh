#!/usr/bin/env bash
# Figures of docs/distributed.md: (1) progressive passes' merged error against a path-traced
# reference for rs and pm, passes 1, 4, 16, 64 (each count the merge of the parts before it plus
# one more range), and the fixed-bandwidth floor of 64 passes; (2) makespan of a farm job of 1, 2
# and 4 tasks on a one-node Slurm started here (scripts/slurm-cluster.sh), with per-part costs.
# Usage: scripts/distributed_figures.sh [WORKDIR]   (needs target/release/raysplat; root for Slurm)
set -euo pipefail
cd "$(dirname "$0")/.."
B=$PWD/target/release/raysplat
W=$(realpath -m "${1:-/tmp/raysplat-distributed}")
mkdir -p "$W"
RES=${RES:-64x64}
PHOTONS=${PHOTONS:-10000}
# relative MSE per pixel / of 8x8-pixel block averages (the low-frequency error, where bias shows)
rel() { "$B" compare "$1" "$2" --json --block "$3" | sed -E 's/.*"rel_mse":([^,]*).*/\1/' | xargs printf %.5f; }
err() { echo "$(rel "$1" "$2" 1) / $(rel "$1" "$2" 8)"; }
echo "## progressive passes ($RES, $PHOTONS photons and 1 eye sample per pixel per pass; relative MSE against pt at 4096 spp, per pixel / of 8x8 blocks)"
echo "| scene | method | 1 | 4 | 16 | 64 | fixed bandwidth, 64 |"
echo "|---|---|---|---|---|---|---|"
for scene in cornell-box secondary-light; do
  S=scenes/$scene.usda
  ref=$W/$scene-ref.exr
  [ -f "$ref" ] || "$B" render $S --method pt --resolution $RES --spp 4096 -o "$ref" 2>/dev/null
  for m in rs pm; do
    F="$S --method $m --resolution $RES --spp 1 --photons $PHOTONS --passes 64"
    row="| $scene | $m |"
    prev=()
    for r in 0:1 1:4 4:16 16:64; do
      "$B" render $F --pass-range $r -o "$W/$scene-$m-$r.exr" 2>/dev/null
      prev+=("$W/$scene-$m-$r.exr")
      "$B" merge "${prev[@]}" -o "$W/$scene-$m-upto-${r#*:}.exr" 2>/dev/null
      row="$row $(err "$W/$scene-$m-upto-${r#*:}.exr" "$ref") |"
    done
    "$B" render $F --fixed-bandwidth -o "$W/$scene-$m-fixed.exr" 2>/dev/null
    echo "$row $(err "$W/$scene-$m-fixed.exr" "$ref") |"
  done
done

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
