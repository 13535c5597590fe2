#!/usr/bin/env python3
"""Texture filtering measured: a checkerboard plane to the horizon, rendered by the path tracer at
equal time with each `--texture-filter` (bilinear lookups, trilinear MIP lookups over the ray
cone's footprint, anisotropic ones), each against a converged bilinear reference.

    .venv/bin/python3 scripts/texture_filtering.py [--size 320x180] [--reference-spp 4096]
                                                   [--budgets 0.25,0.5,1,2,4]

The stage (written to a temporary directory): a 400 m square plane, its texture a 512² checkerboard
of 8-texel squares (linear 0.05 and 0.8) tiled 64 times, under a sun 40° from the zenith; the
camera 1.6 m above it looking 6° down, so that the texels shrink from several pixels wide at the
bottom of the image to far below one at the horizon. Prints, per budget and filter, the samples
per pixel reached and the RMSE and relative MSE (`raysplat compare`) against the reference, whose
own noise is estimated from a second reference of another seed. Needs the release binary
(`cargo build --release`).
"""

import argparse
import json
import struct
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
RAYSPLAT = REPO / "target" / "release" / "raysplat"

STAGE = """#usda 1.0
(
    metersPerUnit = 1
    upAxis = "Y"
)

def Camera "Cam"
{
    float focalLength = 24
    float horizontalAperture = 36
    float verticalAperture = 20.25
    float2 clippingRange = (0.01, 10000)
    double3 xformOp:translate = (0, 1.6, 0)
    float3 xformOp:rotateXYZ = (-6, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
}

def DistantLight "Sun"
{
    float inputs:intensity = 3
    float inputs:angle = 0
    float3 xformOp:rotateXYZ = (-50, 30, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}

def Mesh "Plane" (
    prepend apiSchemas = ["MaterialBindingAPI"]
)
{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-200, 0, 200), (200, 0, 200), (200, 0, -200), (-200, 0, -200)]
    normal3f[] normals = [(0, 1, 0), (0, 1, 0), (0, 1, 0), (0, 1, 0)] (interpolation = "vertex")
    texCoord2f[] primvars:st = [(0, 0), (64, 0), (64, 64), (0, 64)] (interpolation = "vertex")
    uniform token subdivisionScheme = "none"
    rel material:binding = </Looks/Checker>
}

def Scope "Looks"
{
    def Material "Checker"
    {
        token outputs:surface.connect = </Looks/Checker/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor.connect = </Looks/Checker/Tex.outputs:rgb>
            float inputs:roughness = 1
            token outputs:surface
        }
        def Shader "Tex"
        {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @./checker.png@
            token inputs:wrapS = "repeat"
            token inputs:wrapT = "repeat"
            token inputs:sourceColorSpace = "raw"
            float2 inputs:st.connect = </Looks/Checker/St.outputs:result>
            vector3f outputs:rgb
        }
        def Shader "St"
        {
            uniform token info:id = "UsdPrimvarReader_float2"
            string inputs:varname = "st"
            float2 outputs:result
        }
    }
}
"""


def checker_png(path, n=512, square=8, lo=13, hi=204):
    rows = b"".join(b"\0" + b"".join(bytes([lo if (x // square + y // square) % 2 else hi] * 3) for x in range(n))
                    for y in range(n))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", n, n, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def render(stage, out, size, filt, extra):
    cmd = [str(RAYSPLAT), "render", str(stage), "-o", str(out), "--method", "pt", "--resolution", size,
           "--texture-filter", filt, "--json"] + extra
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, check=True)
    stats = json.loads(p.stdout.decode().strip().splitlines()[-1])
    return stats


def compare(test, ref):
    p = subprocess.run([str(RAYSPLAT), "compare", str(test), str(ref), "--json"], stdout=subprocess.PIPE, check=True)
    return json.loads(p.stdout.decode().strip().splitlines()[-1])


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default="320x180")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--budgets", default="0.25,0.5,1,2,4")
    a = ap.parse_args(argv)
    if not RAYSPLAT.exists():
        sys.exit("texture_filtering: build the release binary first (cargo build --release)")
    with tempfile.TemporaryDirectory(prefix="raysplat-texfilter-") as d:
        d = Path(d)
        checker_png(d / "checker.png")
        stage = d / "horizon.usda"
        stage.write_text(STAGE)
        ref, ref2 = d / "ref.exr", d / "ref2.exr"
        render(stage, ref, a.size, "bilinear", ["--spp", str(a.reference_spp), "--seed", "1"])
        render(stage, ref2, a.size, "bilinear", ["--spp", str(a.reference_spp), "--seed", "2"])
        noise = compare(ref2, ref)
        print("reference: bilinear, %d spp at %s; a second reference of another seed differs by rmse %.5f, "
              "relative MSE %.6f" % (a.reference_spp, a.size, noise["rmse"], noise["rel_mse"]))
        print("| budget (s) | filter | spp | rmse | relative MSE |")
        print("|---|---|---|---|---|")
        for b in a.budgets.split(","):
            for filt in ("bilinear", "trilinear", "anisotropic"):
                out = d / ("%s_%s.exr" % (filt, b))
                stats = render(stage, out, a.size, filt, ["--time", b, "--seed", "7"])
                m = compare(out, ref)
                print("| %s | %s | %d | %.5f | %.6f |" % (b, filt, dict(stats["counters"])["spp"], m["rmse"], m["rel_mse"]))
                sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
