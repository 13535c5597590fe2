#!/usr/bin/env python3
"""Material-binding audit: does every gprim (and geometry subset) render in the colour its bound
material says?

    .venv/bin/python3 scripts/material_audit.py [--scenes DIR] [--size 240x135] [--markdown OUT.md]
                                                [--raysplat BINARY]   # convert with another raysplat

For every asset under the shared scenes directory (`../shared/scenes` beside the repository or its
parent, or `$RAYSPLAT_SHARED_SCENES`; the StandardShaderBall also with its `example_material` variants), it
converts the stage with `raysplat convert`, traces 4 camera rays per pixel with the renderer
(`examples/material_audit.rs`: the albedo AOV at each prim–material pair's pixels), and reads the
stage itself with usd-core and MaterialX, independently of the converter, for the colour the bound
material gives: MaterialX first (an `outputs:mtlx:surface` network, or a material of a referenced
`.mtlx` document: `base · base_color`, the subsurface colour mixed in, the transmission colour for
transmissive looks), else UsdPreviewSurface `diffuseColor` (a texture's average · scale + bias),
else the inherited `displayColor`, else the spec's grey 0.18. Textures are averaged by the
renderer's own decoder in the colour space the material declares.

Each row: the asset, the prim (and its subset's material), the material's colour, the albedo AOV
there, their luminance ratio and a verdict: `ok` (the AOV is the material's colour scaled by
0.5–1.6 plus at most 0.25 of grey: it holds the whole albedo, the grey specular and coat
included), `GREY` (the material has a colour, less than 40 % of it is in the render), `check`
(anything else: a real difference, or a material whose albedo is not its base colour). Exit status
1 when any row is `GREY`.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

from pxr import Sdf, Usd, UsdGeom, UsdShade  # noqa: E402

try:
    import MaterialX as mx
except ImportError:  # the audit reads MaterialX looks itself
    sys.exit("material_audit: the MaterialX package is missing (make setup installs it)")

ASSETS = [
    "classic/cornell_box/CornellBox-Original.usda",
    "classic/cornell_box/CornellBox-Sphere.usda",
    "classic/cornell_box/CornellBox-Water.usda",
    "classic/crytek_sponza/sponza.usdc",
    "usd/MiniCarKit_scene.usda",
    "usd/RoughnessTest_scene.usda",
    "usd/usd-wg-assets/full_assets/StandardShaderBall/standard_shader_ball_scene.usda",
]
# the ShaderBall's example looks: (example_material, material_model)
SHADERBALL_VARIANTS = [("mtlx_gold", "standard_surface"), ("mtlx_bubblegum", "standard_surface"),
                       ("mtlx_plastic", "OpenPBRSurface"), ("mtlx_glass", "OpenPBRSurface"),
                       ("usdpreview_copper", "OpenPBRSurface")]


# ---- running the renderer ------------------------------------------------------------------------

def tool(name, example=False):
    path = REPO / "target" / "release" / ("examples" if example else "") / name
    if not path.exists():
        cmd = ["cargo", "build", "--release"] + (["--example", name] if example else [])
        subprocess.run(cmd, cwd=REPO, check=True)
    return str(path)


def run_json(cmd):
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, check=False)
    if out.returncode != 0:
        raise RuntimeError("%s failed: %s" % (" ".join(cmd), out.stderr.decode()[-2000:]))
    return [json.loads(l) for l in out.stdout.decode().splitlines() if l.strip()]


class Averages:
    """Mean linear RGB of image files as the renderer reads them (one call per batch)."""

    def __init__(self):
        self.known = {}

    def get(self, path, color_space):
        key = (path, color_space)
        if key not in self.known:
            rows = run_json([tool("material_audit", True), "average", path, color_space])
            self.known[key] = rows[0]["rgb"]
        return self.known[key]


AVG = Averages()


# ---- what the stage's materials say --------------------------------------------------------------

def vec3(v):
    if v is None:
        return None
    try:
        return [float(v[0]), float(v[1]), float(v[2])]
    except TypeError:
        return [float(v)] * 3


def resolve(inp):
    """('value', v) | ('output', shader prim, output name) | ('none',)."""
    attrs = inp.GetValueProducingAttributes(False)
    if not attrs:
        return ("none",)
    a = attrs[0]
    base, kind = UsdShade.Utils.GetBaseNameAndType(a.GetName())
    if kind == UsdShade.AttributeType.Output:
        return ("output", UsdShade.Shader(a.GetPrim()), str(base))
    return ("value", a.Get())


def input_of(shader, name):
    inp = shader.GetInput(name)
    return resolve(inp) if inp else ("none",)


def usd_texture_average(tex, output):
    """A UsdUVTexture's mean output (rgb), or None."""
    r = input_of(tex, "file")
    if r[0] != "value" or not r[1] or not r[1].resolvedPath:
        fb = input_of(tex, "fallback")
        return vec3(fb[1]) if fb[0] == "value" else [0.0, 0.0, 0.0]
    path = r[1].resolvedPath
    if "[" in path:  # inside a package: read out to a file of its own
        path = unpacked(path)
        if path is None:
            return None
    cs = input_of(tex, "sourceColorSpace")
    cs = str(cs[1]) if cs[0] == "value" else "auto"
    rgb = AVG.get(path, {"sRGB": "sRGB", "raw": "raw"}.get(cs, "auto"))
    if rgb is None:
        return None
    scale, bias = input_of(tex, "scale"), input_of(tex, "bias")
    s = list(scale[1]) if scale[0] == "value" else [1, 1, 1, 1]
    b = list(bias[1]) if bias[0] == "value" else [0, 0, 0, 0]
    v = [rgb[i] * s[i] + b[i] for i in range(3)]
    if output in ("r", "g", "b"):
        return [v["rgb".index(output)]] * 3
    return v


UNPACKED = {}


def unpacked(resolved):
    """A file inside a .usdz package ('/a/b.usdz[tex/c.png]') written out to a temporary file."""
    if resolved not in UNPACKED:
        import zipfile
        outer, inner = resolved[:resolved.index("[")], resolved[resolved.index("[") + 1:-1]
        try:
            with zipfile.ZipFile(outer) as z:
                data = z.read(inner)
        except (OSError, KeyError, zipfile.BadZipFile):
            UNPACKED[resolved] = None
            return None
        f = tempfile.NamedTemporaryFile(prefix="raysplat-audit-", suffix="_" + os.path.basename(inner), delete=False)
        f.write(data)
        f.close()
        UNPACKED[resolved] = f.name
    return UNPACKED[resolved]


def preview_colour(shader):
    r = input_of(shader, "diffuseColor")
    if r[0] == "value":
        c = vec3(r[1])
    elif r[0] == "output" and r[1].GetShaderId() == "UsdUVTexture":
        c = usd_texture_average(r[1], r[2])
        if c is None:
            return None, "texture in a package"
    elif r[0] == "output":
        return None, "diffuseColor from %s" % r[1].GetShaderId()
    else:
        c = [0.18] * 3
    op = input_of(shader, "opacity")
    th = input_of(shader, "opacityThreshold")
    if op[0] == "value" and float(op[1]) < 1.0 and not (th[0] == "value" and float(th[1]) > 0.0):
        o = float(op[1])
        c = [o * x + (1.0 - o) for x in c]  # the transparent part's albedo counts as white
    return c, "UsdPreviewSurface"


class MxLook:
    """Base colour of a MaterialX surface shader, from a document node or a USD shader prim."""

    def __init__(self, get, image_average):
        self.get, self.image_average = get, image_average

    def colour(self, category):
        g = self.get
        if category == "standard_surface":
            names = ("base", "base_color", "subsurface", "subsurface_color", "transmission", "transmission_color")
        elif category == "open_pbr_surface":
            names = ("base_weight", "base_color", "subsurface_weight", "subsurface_color", "transmission_weight",
                     "transmission_color")
        else:
            return None, "MaterialX %s" % category
        w, col, sw, scol, tw, tcol = (g(n) for n in names)
        w = w[0] if w else 1.0
        col = col or [0.8] * 3
        c = [w * x for x in col]
        sw = sw[0] if sw else 0.0
        if sw > 0 and scol:
            c = [a * (1 - sw) + b * sw for a, b in zip(c, scol)]
        tw = tw[0] if tw else 0.0
        if tw >= 0.5 and tcol:
            c = tcol  # a transmissive look: its albedo is the transmission colour
        return c, "MaterialX %s" % category


def mx_doc_colour(file, name):
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, file)
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    doc.importLibrary(lib)
    mat = doc.getNode(name)
    if mat is None:
        return None, "no material %s in %s" % (name, file)
    inp = mat.getInput("surfaceshader")
    shader = inp.getConnectedNode() if inp else None
    if shader is None:
        return None, "no surface shader"

    def get(n):
        i = shader.getInput(n)
        if i is not None and i.getConnectedNode() is not None:
            node = i.getConnectedNode()
            if node.getCategory() in ("image", "tiledimage"):
                f = node.getInput("file")
                path = os.path.join(os.path.dirname(file), f.getResolvedValueString())
                cs = {"srgb_texture": "sRGB", "lin_rec709": "raw", "acescg": "ACEScg"}.get(f.getActiveColorSpace().lower(), "auto")
                return AVG.get(path, cs)
            return None
        if i is None:
            d = shader.getNodeDef().getActiveInput(n)
            return vec3(d.getValue()) if d is not None and d.hasValueString() else None
        return vec3(i.getValue())

    return MxLook(get, None).colour(shader.getCategory())


def usd_mtlx_colour(shader):
    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    nd = lib.getNodeDef(str(shader.GetShaderId()))
    if nd is None:
        return None, "unknown MaterialX node %s" % shader.GetShaderId()

    def get(n):
        r = input_of(shader, n)
        if r[0] == "value":
            return vec3(r[1])
        if r[0] == "output":
            node = r[1]
            if str(node.GetShaderId()).startswith("ND_image_"):
                f = input_of(node, "file")
                if f[0] == "value" and f[1] and f[1].resolvedPath:
                    return AVG.get(f[1].resolvedPath, "auto")
                return [0.0, 0.0, 0.0]
            return None
        d = nd.getActiveInput(n)
        return vec3(d.getValue()) if d is not None and d.hasValueString() else None

    return MxLook(get, None).colour(nd.getNodeString())


def mtlx_document_for(stage, path):
    """(file, material name) of a binding target that a `.mtlx` reference on it or an ancestor holds."""
    path = Sdf.Path(str(path))
    anc = path
    found = []
    while anc != Sdf.Path.absoluteRootPath:
        prim = stage.GetPrimAtPath(anc)
        if prim:
            for spec in prim.GetPrimStack():
                refs = spec.referenceList
                for ref in list(refs.prependedItems) + list(refs.appendedItems) + list(refs.explicitItems) + list(refs.addedItems):
                    if ref.assetPath.lower().endswith(".mtlx"):
                        file = spec.layer.ComputeAbsolutePath(ref.assetPath)
                        target = path.ReplacePrefix(anc, ref.primPath if not ref.primPath.isEmpty else Sdf.Path("/MaterialX"))
                        found.append((file, target.name))
        if found:
            break
        anc = anc.GetParentPath()
    for file, name in found:
        doc = mx.createDocument()
        mx.readFromXmlFile(doc, file)
        if doc.getNode(name) is not None:
            return file, name
    return None


def material_colour(stage, mat_path):
    """(rgb or None, how) of the material at `mat_path`."""
    prim = stage.GetPrimAtPath(mat_path)
    mat = UsdShade.Material(prim) if prim else None
    if mat:
        out = mat.GetSurfaceOutput("mtlx")
        if out:
            src = mat.ComputeSurfaceSource("mtlx")
            if src and src[0] and str(src[0].GetShaderId()).startswith("ND_"):
                return usd_mtlx_colour(src[0])
    ref = mtlx_document_for(stage, mat_path)
    if ref is not None and (not mat or not mat.GetSurfaceOutputs()):
        return mx_doc_colour(*ref)
    if mat:
        for ctx in ("", "mtlx", "glslfx", "ri"):
            src = mat.ComputeSurfaceSource(ctx)
            if src and src[0] and src[0].GetShaderId() == "UsdPreviewSurface":
                return preview_colour(src[0])
    return None, "no surface the audit reads"


def binding_target(prim):
    api = UsdShade.MaterialBindingAPI(prim)
    for purpose in (UsdShade.Tokens.full, UsdShade.Tokens.preview):
        mat, rel = api.ComputeBoundMaterial(purpose)
        if mat:
            return str(mat.GetPath())
        if rel and rel.GetTargets():
            return str(rel.GetTargets()[0])
    return None


def display_colour(prim):
    pv = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("displayColor")
    if pv and pv.HasAuthoredValue():
        vals = pv.ComputeFlattened()
        if vals is not None and len(vals):
            n = len(vals)
            return [sum(float(v[c]) for v in vals) / n for c in range(3)], "displayColor"
    return [0.18] * 3, "unbound (grey 0.18)"


def expectations(stage, prim_path):
    """[(subset name or '', material path or None, rgb, how)] for a gprim."""
    prim = stage.GetPrimAtPath(prim_path)
    if not prim:
        return []
    out = []
    tgt = binding_target(prim)
    if tgt:
        c, how = material_colour(stage, tgt)
        out.append(("", tgt, c, how))
    else:
        c, how = display_colour(prim)
        out.append(("", None, c, how))
    if prim.IsA(UsdGeom.Mesh):
        for sub in UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets():
            t = binding_target(sub.GetPrim())
            if t:
                c, how = material_colour(stage, t)
                out.append((sub.GetPrim().GetName(), t, c, how))
    return out


# ---- comparing ------------------------------------------------------------------------------------

def lum(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def fit(want, got):
    """(a, b, residual): `got ≈ a · want + b · white` by least squares — the albedo AOV holds the
    base colour's reflection plus a grey specular (and coat) part."""
    n = 3.0
    sw, sww, sg, swg = sum(want), sum(w * w for w in want), sum(got), sum(w * g for w, g in zip(want, got))
    det = sww * n - sw * sw
    if det <= 1e-12:  # a grey material: only the sum is known
        return (1.0, (sg - sw) / n, max(abs(g - sg / n) for g in got))
    a = (swg * n - sw * sg) / det
    b = (sww * sg - sw * swg) / det
    return a, b, max(abs(a * w + b - g) for w, g in zip(want, got))


def verdict(want, got):
    """`GREY`: the material's colour (its part above its own grey) is mostly missing; `ok`: the
    AOV is the colour, scaled by 0.5–1.6, plus at most 0.25 of grey, to within 0.03 + 5 %."""
    if want is None:
        return "check"
    cw = [w - min(want) for w in want]
    cg = [g - min(got) for g in got]
    norm = sum(c * c for c in cw)
    if math.sqrt(norm) > 0.02 and max(want) > 0 and (max(want) - min(want)) / max(want) > 0.2:
        kept = sum(a * b for a, b in zip(cw, cg)) / norm
        if kept < 0.4:
            return "GREY"
    a, b, res = fit(want, got)
    return "ok" if 0.5 <= a <= 1.6 and -0.02 <= b <= 0.25 and res <= 0.03 + 0.05 * max(got) else "check"


def fmt(c):
    return "—" if c is None else "(%.3f, %.3f, %.3f)" % tuple(c)


CONVERTER = [None]  # the `raysplat` binary that converts (--raysplat), else the repository's


def audit(stage_path, label, size, workdir):
    rss = Path(workdir) / (label.replace("/", "_") + ".rss")
    subprocess.run([CONVERTER[0] or tool("raysplat"), "convert", str(stage_path), str(rss)], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    rows = run_json([tool("material_audit", True), "pixels", str(rss), size])
    stage = Usd.Stage.Open(str(stage_path))
    cache = {}
    table = []
    for r in rows:
        prim = r["prim"].split("[")[0]
        if prim not in cache:
            cache[prim] = expectations(stage, prim)
        exp = cache[prim]
        # the subset whose material the converter gave these pixels, else the prim's own
        match = next((e for e in exp if e[1] and e[1] == r["material"]), None) or (exp[0] if exp else None)
        if match is None:
            table.append((label, r["prim"], "", r["material"], None, "not a USD prim", r["albedo"], r["pixels"], "check"))
            continue
        sub, mpath, want, how = match
        v = verdict(want, r["albedo"])
        table.append((label, r["prim"], sub, mpath or "(unbound)", want, how, r["albedo"], r["pixels"], v))
    return table


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    # beside the repository (../shared/scenes), or beside a worktree's parent
    near = next((str(d / "shared" / "scenes") for d in (REPO.parent, REPO.parent.parent) if (d / "shared" / "scenes").is_dir()),
                str(REPO.parent / "shared" / "scenes"))
    ap.add_argument("--scenes", default=os.environ.get("RAYSPLAT_SHARED_SCENES", near))
    ap.add_argument("--size", default="240x135")
    ap.add_argument("--min-pixels", type=float, default=4.0)
    ap.add_argument("--markdown", help="also write the table there")
    ap.add_argument("--raysplat", help="convert with this raysplat binary (e.g. another version's)")
    a = ap.parse_args(argv)
    CONVERTER[0] = a.raysplat
    root = Path(a.scenes)
    if not root.is_dir():
        print("material_audit: %s is absent; nothing to audit" % root)
        return 2
    rows = []
    with tempfile.TemporaryDirectory(prefix="raysplat-audit-") as work:
        for rel in ASSETS:
            p = root / rel
            if not p.exists():
                print("material_audit: SKIPPED %s (absent)" % rel)
                continue
            rows += audit(p, Path(rel).stem, a.size, work)
            if "StandardShaderBall" in rel:
                for look, model in SHADERBALL_VARIANTS:
                    wrapper = Path(work) / ("shaderball_%s_%s.usda" % (look, model))
                    wrapper.write_text(SHADERBALL_WRAPPER % {"scene": p, "look": look, "model": model})
                    rows += audit(wrapper, "shaderball %s (%s)" % (look, model), a.size, work)
    rows = [r for r in rows if r[7] >= a.min_pixels]
    lines = ["| asset | prim | subset | material | material's colour | from | albedo AOV | luminance ratio | pixels | verdict |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for (label, prim, sub, mat, want, how, got, px, v) in rows:
        ratio = "%.2f" % (lum(got) / lum(want)) if want and lum(want) > 1e-6 else "—"
        lines.append("| %s | %s | %s | %s | %s | %s | %s | %s | %d | %s |" % (
            label, prim, sub, mat, fmt(want), how, fmt(got), ratio, round(px), v))
    counts = {}
    for r in rows:
        counts[r[8]] = counts.get(r[8], 0) + 1
    summary = "%d prim–material pairs seen: %s" % (len(rows), ", ".join("%s %d" % kv for kv in sorted(counts.items())))
    text = "\n".join(lines) + "\n\n" + summary + "\n"
    print(text)
    if a.markdown:
        Path(a.markdown).write_text(text)
    return 1 if counts.get("GREY") else 0


SHADERBALL_WRAPPER = """#usda 1.0
(
    defaultPrim = "standard_shader_ball_scene"
    metersPerUnit = 0.01
    upAxis = "Y"
    startTimeCode = 3
    endTimeCode = 3
    subLayers = [@%(scene)s@]
)

over "standard_shader_ball_scene" (
    variants = {
        string example_material = "%(look)s"
    }
)
{
    over "materials" (
        variants = {
            string material_model = "%(model)s"
        }
    )
    {
        over "examples" (
            variants = {
                string material_model = "%(model)s"
            }
        )
        {
        }
    }
}
"""

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
