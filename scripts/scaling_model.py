#!/usr/bin/env python3
"""Scaling model of docs/distributed.md: makespan and speed-up of a farm job on 1..1024 nodes for
each split, from per-part costs measured on one machine (scripts/distributed_figures.sh).

Usage: scripts/scaling_model.py CONVERT PREPARE EYE LIGHT SPLAT PART_BYTES MERGE_PER_PART [SVG]
  seconds of: the scene's conversion, a task's load + prepare, the eye pass, the light pass and the
  splatting of the whole measured image (one CPU), the bytes of one whole-image part, the merge's
  seconds per whole-image part. Prints a markdown table and writes an SVG plot of speed-up.

The modelled job is the measured one scaled to a 3840x2160 image (pixels x SCALE_PIXELS: eye pass,
splatting, part size and merge grow with them) with 10x the photons (light pass x 10, splatting x 10):
  tiles   T(N) = convert + prepare + light + (eye + splat) / N + merge + transfer(one image)
  shared  T(N) = convert + light + prepare + read(photons) + (eye + splat) / N + merge + transfer
          (the photons traced once and read by every tile task from a file: 48 bytes a photon)
  passes  T(N) = convert + prepare + ceil(P / N) * (eye + light + splat) + N * (merge + transfer)
          (P = 1024 progressive passes, each the whole render; N parts merged on one node)
  frames  T(N) = ceil(F / N) * (convert + prepare + eye + light + splat), F = 240 frames
Transfer at 1 GB/s into the merging node; tasks start together (an idle farm).
"""
import math
import sys

MEASURED_PIXELS = 256 * 256
SCALE_PIXELS = 3840 * 2160 / MEASURED_PIXELS
SCALE_PHOTONS = 10.0
PHOTONS = 200_000 * SCALE_PHOTONS
BANDWIDTH = 1e9
PASSES = 1024
FRAMES = 240
NODES = [1, 2, 4, 16, 64, 256, 1024]


def model(convert, prepare, eye, light, splat, part_bytes, merge_part):
    eye *= SCALE_PIXELS
    splat *= SCALE_PIXELS * SCALE_PHOTONS
    light *= SCALE_PHOTONS
    image = part_bytes * SCALE_PIXELS
    merge_img = merge_part * SCALE_PIXELS
    xfer = image / BANDWIDTH
    photon_file = PHOTONS * 48 / BANDWIDTH

    def tiles(n):
        return convert + prepare + light + (eye + splat) / n + merge_img + xfer

    def shared(n):
        return convert + light + prepare + photon_file + (eye + splat) / n + merge_img + xfer

    def passes(n):
        # each pass is the whole render (its own eye samples and photons); the merge reads N parts
        return convert + prepare + math.ceil(PASSES / n) * (eye + light + splat) + n * (merge_img + xfer)

    def frames(n):
        return math.ceil(FRAMES / n) * (convert + prepare + eye + light + splat)

    return {"tiles": tiles, "tiles, shared photons": shared, "passes": passes, "frames": frames}


def stop(f):
    """The node count beyond which doubling gains less than 10 % (or 1024)."""
    n = 1
    while n < 1024 and f(n) / f(2 * n) >= 1.1:
        n *= 2
    return n


def svg(path, splits):
    w, h, m = 640, 420, 60
    lx = lambda n: m + (w - 2 * m) * math.log2(n) / 10
    ly = lambda s: h - m - (h - 2 * m) * math.log2(max(s, 1)) / 10
    colours = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd"]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<text x="{w/2}" y="20" text-anchor="middle" font-size="14">modelled speed-up against nodes (3840x2160, 2M photons)</text>']
    for k in range(11):
        n = 2 ** k
        out.append(f'<line x1="{lx(n)}" y1="{h-m}" x2="{lx(n)}" y2="{m}" stroke="#ddd"/><text x="{lx(n)}" y="{h-m+16}" text-anchor="middle">{n}</text>')
        out.append(f'<line x1="{m}" y1="{ly(n)}" x2="{w-m}" y2="{ly(n)}" stroke="#ddd"/><text x="{m-6}" y="{ly(n)+4}" text-anchor="end">{n}</text>')
    out.append(f'<line x1="{lx(1)}" y1="{ly(1)}" x2="{lx(1024)}" y2="{ly(1024)}" stroke="#999" stroke-dasharray="4 4"/>')
    out.append(f'<text x="{w/2}" y="{h-18}" text-anchor="middle">nodes</text><text x="16" y="{h/2}" transform="rotate(-90 16 {h/2})" text-anchor="middle">speed-up</text>')
    for (name, f), c in zip(splits.items(), colours):
        pts = " ".join(f"{lx(2**k):.1f},{ly(f(1)/f(2**k)):.1f}" for k in range(11))
        out.append(f'<polyline points="{pts}" fill="none" stroke="{c}" stroke-width="2"/>')
        y = m + 16 * (list(splits).index(name) + 1)
        out.append(f'<line x1="{m+10}" y1="{y-4}" x2="{m+30}" y2="{y-4}" stroke="{c}" stroke-width="2"/><text x="{m+36}" y="{y}">{name}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    if len(sys.argv) < 8:
        sys.exit(__doc__)
    args = [float(a) for a in sys.argv[1:8]]
    splits = model(*args)
    print("| split | " + " | ".join(f"{n} nodes" for n in NODES) + " | stops scaling at |")
    print("|---|" + "---|" * (len(NODES) + 1))
    for name, f in splits.items():
        cells = " | ".join(f"{f(n):.0f} s ({f(1)/f(n):.0f}x)" for n in NODES)
        print(f"| {name} | {cells} | {stop(f)} |")
    convert, prepare, eye, light, splat = args[:5]
    light_job = light * SCALE_PHOTONS
    work = (eye * SCALE_PIXELS + splat * SCALE_PIXELS * SCALE_PHOTONS)
    print()
    print(f"tiles: the photons ({light_job:.0f} s a task) outweigh a tile's eye pass and splatting "
          f"({work:.0f} s / N) beyond N = {work / light_job:.0f} nodes; re-traced on every node they cost "
          + ", ".join(f"{n * light_job / 3600:.1f} node-hours at {n}" for n in (16, 256, 1024))
          + f" nodes, once from a shared file {light_job / 3600:.3f} node-hours plus {PHOTONS * 48 / 1e6:.0f} MB read per node")
    if len(sys.argv) > 8:
        svg(sys.argv[8], splits)


if __name__ == "__main__":
    main()
