#!/usr/bin/env python3
"""Render a USD stage with Mitsuba 3 through the workplace's converter, with a chosen pixel filter.

    PY scripts/mitsuba_filters.py CONVERTER STAGE OUTDIR VARIANT WIDTH HEIGHT FILTER NAME:SPP:SEED ...

CONVERTER is `../shared/peer/usd_to_mitsuba.py` (it reads USD as raysplat does; its film has a box
filter). This script uses its `Stage` and `Builder` with their defaults (plastic BSDF mapping with
the energy gain, power light weights, `path` integrator, max depth 1025, rr depth 5, independent
sampler) and replaces the film's reconstruction filter by FILTER: `box` (Mitsuba's box, radius 0.5)
or `gaussian` (Mitsuba's gaussian, stddev 0.5, radius 4 stddev = 2: the same shape as raysplat's
`--filter gaussian` at its default radius 2, σ = radius / 4, shifted down to zero at the radius).
Mitsuba splats each sample over the pixels within the radius and divides by the summed weights, as
raysplat does; samples stay inside the image (the film's `sample_border` is off), as raysplat's do.

Each job NAME:SPP:SEED renders SPP samples per pixel in passes of 64 (llvm/cuda variants; scalar:
one pass) with seeds SEED, SEED+1, ..., averages the passes, writes OUTDIR/NAME.exr and prints one
JSON line: name, spp, seed, seconds (the `mi.render` calls only, after warm-up renders of 1 spp and
of each pass size, which compile the kernels). `raysplat-bench pt --filter` runs it.
"""

import importlib.util
import json
import os
import sys
import time

FILTERS = {"box": {"type": "box"}, "gaussian": {"type": "gaussian", "stddev": 0.5}}


def load_converter(path):
    spec = importlib.util.spec_from_file_location("usd_to_mitsuba", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def parse_job(text):
    name, spp, seed = text.split(":")
    if not name or os.sep in name or int(spp) < 1 or int(seed) < 0:
        raise ValueError(f"bad job {text!r}: NAME:SPP:SEED with SPP >= 1, SEED >= 0")
    return name, int(spp), int(seed)


def main(argv):
    if len(argv) < 8 or argv[6] not in FILTERS:
        print(__doc__, file=sys.stderr)
        return 2
    converter, stage_path, outdir, variant = argv[0], argv[1], argv[2], argv[3]
    width, height, rfilter = int(argv[4]), int(argv[5]), argv[6]
    jobs = [parse_job(j) for j in argv[7:]]
    peer = load_converter(converter)
    import mitsuba as mi
    import numpy as np

    mi.set_variant(variant)
    os.makedirs(outdir, exist_ok=True)
    builder = peer.Builder(peer.Stage(stage_path), "plastic", compensate=True, light_weighting="power")
    scene_dict = builder.scene_dict(width, height)
    scene_dict["sensor"]["film"]["rfilter"] = dict(FILTERS[rfilter])
    scene_dict["sensor"]["film"]["sample_border"] = False
    scene = mi.load_dict(scene_dict)
    pass_spp = 64 if variant.startswith(("llvm", "cuda")) else 1 << 30
    # kernels are compiled per pass size: compile each one before the timed renders
    for n in sorted({1} | {min(pass_spp, spp) for _, spp, _ in jobs}):
        np.array(mi.render(scene, spp=n, seed=10**6))
    for name, spp, seed in jobs:
        t0 = time.time()
        acc, done, k = None, 0, 0
        while done < spp:
            n = min(pass_spp, spp - done)
            img = np.array(mi.render(scene, spp=n, seed=seed + k), dtype=np.float64) * n
            acc = img if acc is None else acc + img
            done, k = done + n, k + 1
        seconds = time.time() - t0
        img = np.ascontiguousarray((acc / spp)[:, :, :3], dtype=np.float32)
        mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(os.path.join(outdir, name + ".exr"))
        print(json.dumps({"name": name, "spp": spp, "seed": seed, "filter": rfilter, "seconds": round(seconds, 4)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
