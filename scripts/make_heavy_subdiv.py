#!/usr/bin/env python3
"""A heavy, production-like stage of Catmull-Clark subdivision surfaces, for measuring conversion and
scene builds (docs/units.md, "Geometry"; README "Subdivision surfaces"). Not test data: written to a
folder of your choice, never into the repository.

    .venv/bin/python3 scripts/make_heavy_subdiv.py OUT_DIR [--scale S]
    .venv/bin/python3 scripts/make_heavy_subdiv.py OUT_DIR --features

writes OUT_DIR/heavy_subdiv.usda (camera, lights, materials, the placements) over
OUT_DIR/heavy_subdiv_geometry.usdc (the meshes); with `--features`, OUT_DIR/subdiv_features.usda
instead: a small close-up of the features the renderer must keep (creases of sharpness 10 and 1.5,
an infinitely sharp corner, holes, boundaries under edgeAndCorner and edgeOnly, texture coordinates
with seams under a checker texture and three faceVaryingLinearInterpolation rules, a Loop surface),
for comparing images. At `--scale 1` (the default) the cages hold about
0.8 million triangles' worth of faces (400 000 quads) in 14 meshes: 8 turned pieces (surfaces of
revolution with sharp creases at their rims and face-varying texture coordinates with a seam),
4 knotted tubes (face-varying coordinates, seams both ways), a box with holes, infinitely sharp
corners and creased edges, and a creased board; 6 of the pieces are placed twice. Needs usd-core.
"""

import math
import os
import struct
import sys
import zlib

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt


def lathe(profile, around, crease_rows=(), sharp=10.0):
    """A closed surface of revolution of `profile` [(r, y)] about Y with `around` segments: (points,
    counts, indices, uv values, uv indices, crease indices, crease lengths, sharpnesses). The first
    and last profile points lie on the axis (poles: triangle fans)."""
    rows = len(profile)
    pts = [(0.0, profile[0][1], 0.0)]
    for r, y in profile[1:-1]:
        for k in range(around):
            a = 2 * math.pi * k / around
            pts.append((r * math.cos(a), y, -r * math.sin(a)))
    pts.append((0.0, profile[-1][1], 0.0))
    ring = lambda j, k: 1 + (j - 1) * around + (k % around)  # noqa: E731
    top = len(pts) - 1
    counts, idx = [], []
    # uv: u around (a seam at k = 0 / around: around + 1 columns), v along the profile
    uvs = [(k / around, j / (rows - 1)) for j in range(rows) for k in range(around + 1)]
    uv = lambda j, k: j * (around + 1) + k  # noqa: E731
    uv_idx = []
    for k in range(around):
        counts.append(3)
        idx += [0, ring(1, k), ring(1, k + 1)]
        uv_idx += [uv(0, k), uv(1, k), uv(1, k + 1)]
    for j in range(1, rows - 2):
        for k in range(around):
            counts.append(4)
            idx += [ring(j, k), ring(j + 1, k), ring(j + 1, k + 1), ring(j, k + 1)]
            uv_idx += [uv(j, k), uv(j + 1, k), uv(j + 1, k + 1), uv(j, k + 1)]
    for k in range(around):
        counts.append(3)
        idx += [top, ring(rows - 2, k + 1), ring(rows - 2, k)]
        uv_idx += [uv(rows - 1, k), uv(rows - 2, k + 1), uv(rows - 2, k)]
    ci, cl, cs = [], [], []
    for j in crease_rows:
        ci += [ring(j, k) for k in range(around + 1)]
        cl.append(around + 1)
        cs.append(sharp)
    return pts, counts, idx, uvs, uv_idx, ci, cl, cs


def piece_profile(kind, rows):
    """A chess-piece-like profile of `rows` points from the bottom pole to the top pole."""
    out = []
    for j in range(rows):
        t = j / (rows - 1)
        y = 2.0 * t
        if j == 0 or j == rows - 1:
            out.append((0.0, y))
            continue
        base = 0.55 * (1 - t) ** 3 + 0.18
        wave = 0.06 * math.sin((3 + kind) * math.pi * t) + 0.05 * math.sin(17 * t + kind)
        head = 0.25 * math.exp(-((t - 0.85) / (0.06 + 0.01 * kind)) ** 2)
        out.append((max(0.05, base + wave + head), y))
    return out


def knot(p, q, around, along, radius):
    """A (p, q) torus-knot tube: (points, counts, indices, uvs, uv indices)."""
    def centre(s):
        a = 2 * math.pi * s
        r = 1.0 + 0.4 * math.cos(q * a)
        return (r * math.cos(p * a), 0.4 * math.sin(q * a), r * math.sin(p * a))
    pts = []
    for i in range(along):
        s = i / along
        c, c1 = centre(s), centre(s + 1e-4)
        t = [c1[k] - c[k] for k in range(3)]
        ln = math.sqrt(sum(x * x for x in t))
        t = [x / ln for x in t]
        up = (0.0, 1.0, 0.0)
        b = [t[1] * up[2] - t[2] * up[1], t[2] * up[0] - t[0] * up[2], t[0] * up[1] - t[1] * up[0]]
        lb = math.sqrt(sum(x * x for x in b)) or 1.0
        b = [x / lb for x in b]
        n = [b[1] * t[2] - b[2] * t[1], b[2] * t[0] - b[0] * t[2], b[0] * t[1] - b[1] * t[0]]
        for k in range(around):
            a = 2 * math.pi * k / around
            pts.append(tuple(c[m] + radius * (math.cos(a) * n[m] + math.sin(a) * b[m]) for m in range(3)))
    counts, idx, uv_idx = [], [], []
    uvs = [(i / along * 8, k / around) for i in range(along + 1) for k in range(around + 1)]
    for i in range(along):
        for k in range(around):
            counts.append(4)
            a, b2 = i, (i + 1) % along
            idx += [a * around + k, a * around + (k + 1) % around, b2 * around + (k + 1) % around, b2 * around + k]
            uv_idx += [i * (around + 1) + k, i * (around + 1) + k + 1, (i + 1) * (around + 1) + k + 1, (i + 1) * (around + 1) + k]
    return pts, counts, idx, uvs, uv_idx


def grid(n, size, y, bump):
    """An n × n grid of quads, bumpy: (points, counts, indices)."""
    m = n + 1
    pts = [((x / n - 0.5) * size, y + bump * math.sin(0.31 * x) * math.cos(0.27 * z), (z / n - 0.5) * size)
           for z in range(m) for x in range(m)]
    idx = []
    for z in range(n):
        for x in range(n):
            idx += [z * m + x, (z + 1) * m + x, (z + 1) * m + x + 1, z * m + x + 1]
    return pts, [4] * (n * n), idx


def boxy(n):
    """A cube of n × n quads per side (points shared along its edges), side 1.6: (points, counts,
    indices, its 8 corner points, its 12 edges as crease chains)."""
    key, pts = {}, []

    def pt(p):
        k = tuple(round(c, 9) for c in p)
        if k not in key:
            key[k] = len(pts)
            pts.append(k)
        return key[k]
    counts, idx = [], []
    for axis in range(3):
        for sign in (-1, 1):
            u_ax, v_ax = [a for a in range(3) if a != axis]
            for i in range(n):
                for j in range(n):
                    quad = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0] * 3
                        p[axis] = 0.8 * sign
                        p[u_ax] = 1.6 * ((i + di) / n - 0.5)
                        p[v_ax] = 1.6 * ((j + dj) / n - 0.5)
                        quad.append(pt(p))
                    if (sign > 0) == (axis != 1):
                        quad.reverse()
                    counts.append(4)
                    idx += quad
    corners = [key[tuple(round(0.8 * s, 9) for s in (sx, sy, sz))] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    return pts, counts, idx, corners


def material(stage, path, color, roughness=0.5, metallic=0.0):
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/Surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    sh.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(metallic)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def mesh(stage, path, pts, counts, idx, uvs=None, uv_idx=None, creases=None, corners=None, holes=None):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in pts]))
    m.CreateFaceVertexCountsAttr(Vt.IntArray(counts))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray(idx))
    m.CreateSubdivisionSchemeAttr("catmullClark")
    if uvs is not None:
        pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
        pv.Set(Vt.Vec2fArray([Gf.Vec2f(*u) for u in uvs]))
        pv.SetIndices(Vt.IntArray(uv_idx))
    if creases:
        ci, cl, cs = creases
        m.CreateCreaseIndicesAttr(Vt.IntArray(ci))
        m.CreateCreaseLengthsAttr(Vt.IntArray(cl))
        m.CreateCreaseSharpnessesAttr(Vt.FloatArray(cs))
    if corners:
        m.CreateCornerIndicesAttr(Vt.IntArray(corners))
        m.CreateCornerSharpnessesAttr(Vt.FloatArray([10.0] * len(corners)))
    if holes:
        m.CreateHoleIndicesAttr(Vt.IntArray(holes))
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(p[k] for p in pts) for k in range(3)]
    m.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*lo), Gf.Vec3f(*hi)]))
    return m


def checker_png(path, n=256, squares=16):
    """An n × n checker of `squares` squares a side, with a thin dark grid, as an 8-bit PNG."""
    rows = []
    for y in range(n):
        row = bytearray(b"\0")
        for x in range(n):
            a = (x * squares // n + y * squares // n) % 2
            line = x % (n // squares) == 0 or y % (n // squares) == 0
            c = (30, 30, 40) if line else ((230, 200, 120) if a else (60, 110, 170))
            row += bytes(c)
        rows.append(bytes(row))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", n, n, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(b"".join(rows))) + chunk(b"IEND", b""))


def features(out):
    """The feature scene (see the module's docs)."""
    path = os.path.join(out, "subdiv_features.usda")
    checker_png(os.path.join(out, "checker.png"))
    st = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(st, 1.0)
    world = UsdGeom.Xform.Define(st, "/World")
    st.SetDefaultPrim(world.GetPrim())
    plain = material(st, "/World/Looks/Plain", (0.7, 0.7, 0.7), 0.35)
    tex = material(st, "/World/Looks/Checker", (0.5, 0.5, 0.5), 0.6)
    sh = UsdShade.Shader(st.GetPrimAtPath("/World/Looks/Checker/Surface"))
    t = UsdShade.Shader.Define(st, "/World/Looks/Checker/Tex")
    t.CreateIdAttr("UsdUVTexture")
    t.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("checker.png")
    rd = UsdShade.Shader.Define(st, "/World/Looks/Checker/St")
    rd.CreateIdAttr("UsdPrimvarReader_float2")
    rd.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
    t.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(rd.ConnectableAPI(), "result")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(t.ConnectableAPI(), "rgb")

    def place(m, pos, mat):
        UsdGeom.XformCommonAPI(m).SetTranslate(Gf.Vec3d(*pos))
        UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(mat)
    # a cube: one top edge loop infinitely sharp, one vertical edge at 1.5, a sharp and a semi-sharp
    # corner, one face a hole
    pts, c, i, corners = boxy(3)
    top = [p for p, q in enumerate(pts) if abs(q[1] - 0.8) < 1e-9 and (abs(abs(q[0]) - 0.8) < 1e-9 or abs(abs(q[2]) - 0.8) < 1e-9)]
    ring = sorted(top, key=lambda p: math.atan2(pts[p][2], pts[p][0]))
    vert = sorted((p for p, q in enumerate(pts) if abs(q[0] + 0.8) < 1e-9 and abs(q[2] + 0.8) < 1e-9), key=lambda p: pts[p][1])
    m = mesh(st, "/World/Cube", pts, c, i, creases=(ring + ring[:1] + vert, [len(ring) + 1, len(vert)], [10.0, 1.5]),
             corners=corners[:1], holes=[4])
    m.CreateCornerSharpnessesAttr(Vt.FloatArray([10.0]))
    place(m, (-2.2, 0.9, 0.0), plain)
    # a bumpy grid per boundary rule, a crease across, texture coordinates in four islands (seams)
    for k, (rule, fvar) in enumerate((("edgeAndCorner", "cornersPlus1"), ("edgeOnly", "cornersPlus1"), ("edgeAndCorner", "boundaries"))):
        gp, gc, gi = grid(6, 1.8, 0.0, 0.25)
        uvs = [((q[0] / 1.8 + 0.5) * 2, (q[2] / 1.8 + 0.5) * 2) for q in gp]
        uv_idx = []
        islands = []
        for f in range(len(gc)):
            quad = gi[4 * f:4 * f + 4]
            island = (f % 6 >= 3) + 2 * (f // 6 >= 3)
            for v in quad:
                uv_idx.append(island * len(gp) + v)
            islands.append(island)
        uv_vals = [(u + 0.15 * (isl % 2), v + 0.15 * (isl // 2)) for isl in range(4) for u, v in uvs]
        g = mesh(st, "/World/Grid%d" % k, gp, gc, gi, uv_vals, uv_idx,
                 creases=([7 * 3 + x for x in range(7)], [7], [10.0]), holes=[14])
        g.CreateInterpolateBoundaryAttr(rule)
        g.CreateFaceVaryingLinearInterpolationAttr(fvar)
        UsdGeom.XformCommonAPI(g).SetRotate(Gf.Vec3f(70, 0, 0))
        place(g, (0.0 + 2.1 * k, 1.0, -0.5), tex)
    # a textured knot (seams along and around) and a Loop surface
    kp, kc, ki, kuv, kuvi = knot(2, 3, 12, 96, 0.25)
    kn = mesh(st, "/World/Knot", kp, kc, ki, kuv, kuvi)
    kn.CreateFaceVaryingLinearInterpolationAttr("cornersOnly")
    UsdGeom.XformCommonAPI(kn).SetScale(Gf.Vec3f(0.6, 0.6, 0.6))
    place(kn, (-2.0, 2.9, -1.5), tex)
    tet = [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]
    lp = mesh(st, "/World/Loop", tet, [3] * 4, [0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2])
    lp.CreateSubdivisionSchemeAttr("loop")
    place(lp, (2.2, 3.0, -1.5), plain)
    floor = UsdGeom.Mesh.Define(st, "/World/Floor")
    floor.CreatePointsAttr([(-8, 0, -8), (8, 0, -8), (8, 0, 8), (-8, 0, 8)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    floor.CreateSubdivisionSchemeAttr("none")
    UsdShade.MaterialBindingAPI.Apply(floor.GetPrim()).Bind(plain)
    cam = UsdGeom.Camera.Define(st, "/World/Camera")
    cam.CreateFocalLengthAttr(30.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(24.0)
    xf = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0.5, 3.5, 7.5), Gf.Vec3d(0.3, 1.4, -0.5), Gf.Vec3d(0, 1, 0)).GetInverse()
    cam.AddTransformOp().Set(xf)
    key = UsdLux.RectLight.Define(st, "/World/Key")
    key.CreateWidthAttr(3.0)
    key.CreateHeightAttr(3.0)
    key.CreateIntensityAttr(12.0)
    kx = Gf.Matrix4d().SetLookAt(Gf.Vec3d(-4.0, 6.0, 5.0), Gf.Vec3d(0.0, 1.0, 0.0), Gf.Vec3d(0, 1, 0)).GetInverse()
    key.AddTransformOp().Set(kx)
    UsdLux.DomeLight.Define(st, "/World/Sky").CreateIntensityAttr(0.4)
    st.GetRootLayer().Save()
    print(path)
    return 0


def main(argv):
    if not argv or argv[0].startswith("-"):
        print(__doc__)
        return 2
    out = argv[0]
    if "--features" in argv:
        os.makedirs(out, exist_ok=True)
        return features(out)
    scale = float(argv[argv.index("--scale") + 1]) if "--scale" in argv else 1.0
    os.makedirs(out, exist_ok=True)
    geo_path = os.path.join(out, "heavy_subdiv_geometry.usdc")
    geo = Usd.Stage.CreateNew(geo_path)
    UsdGeom.SetStageUpAxis(geo, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(geo, 0.1)
    root = UsdGeom.Xform.Define(geo, "/Geometry")
    geo.SetDefaultPrim(root.GetPrim())
    s = math.sqrt(scale)
    quads = 0
    for kind in range(8):
        rows, around = int(160 * s), int(208 * s)
        rows_c = (int(rows * 0.1), int(rows * 0.5), int(rows * 0.8))
        pts, c, i, uvs, uvi, ci, cl, cs = lathe(piece_profile(kind, rows), around, rows_c)
        mesh(geo, "/Geometry/Piece%d" % kind, pts, c, i, uvs, uvi, (ci, cl, cs))
        quads += len(c)
    for kind in range(4):
        pts, c, i, uvs, uvi = knot(2 + kind % 2, 3 + kind, int(24 * s), int(800 * s), 0.18)
        mesh(geo, "/Geometry/Knot%d" % kind, pts, c, i, uvs, uvi)
        quads += len(c)
    n = int(64 * s)
    pts, c, i, corners = boxy(n)
    holes = list(range(0, len(c), 97))
    # the box's 12 edges creased (sharpness 2: semi-sharp after two levels)
    chains = []
    for a in corners:
        for b in corners:
            if a < b and sum(abs(pts[a][k] - pts[b][k]) > 1e-6 for k in range(3)) == 1:
                axis = next(k for k in range(3) if abs(pts[a][k] - pts[b][k]) > 1e-6)
                along = sorted((p for p, q in enumerate(pts) if all(abs(q[k] - pts[a][k]) < 1e-9 for k in range(3) if k != axis)),
                               key=lambda p: pts[p][axis])
                chains.append(along)
    ci = [v for ch in chains for v in ch]
    mesh(geo, "/Geometry/Box", pts, c, i, creases=(ci, [len(ch) for ch in chains], [2.0] * len(chains)), corners=corners, holes=holes)
    quads += len(c)
    pts, c, i = grid(int(200 * s), 12.0, 0.0, 0.03)
    m = int(200 * s) + 1
    ci = [m * (m // 2) + x for x in range(m)]
    mesh(geo, "/Geometry/Board", pts, c, i, creases=(ci, [len(ci)], [10.0]))
    quads += len(c)
    geo.GetRootLayer().Save()

    stage_path = os.path.join(out, "heavy_subdiv.usda")
    st = Usd.Stage.CreateNew(stage_path)
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(st, 0.1)
    world = UsdGeom.Xform.Define(st, "/World")
    st.SetDefaultPrim(world.GetPrim())
    mats = [material(st, "/World/Looks/M%d" % k, c, r, mt) for k, (c, r, mt) in enumerate(
        [((0.8, 0.75, 0.6), 0.4, 0.0), ((0.08, 0.07, 0.06), 0.3, 0.0), ((0.9, 0.6, 0.3), 0.25, 1.0), ((0.3, 0.5, 0.35), 0.7, 0.0)])]
    placements = []
    for kind in range(8):
        copies = 2 if kind < 6 else 1
        for c in range(copies):
            x, z = -4.5 + 1.3 * kind, -2.0 + 3.5 * c
            placements.append(("Piece%d" % kind, "Piece%d_%d" % (kind, c), (x, 0.0, z), mats[(kind + c) % 2]))
    for kind in range(4):
        placements.append(("Knot%d" % kind, "Knot%d" % kind, (-4.0 + 2.7 * kind, 3.6, -5.0), mats[2]))
    placements.append(("Box", "Box", (4.5, 0.8, 3.5), mats[2]))
    placements.append(("Board", "Board", (0.0, -0.02, 0.0), mats[3]))
    for src, name, pos, mat in placements:
        x = UsdGeom.Xform.Define(st, "/World/%s" % name)
        x.AddTranslateOp().Set(Gf.Vec3d(*pos))
        ref = st.DefinePrim("/World/%s/Mesh" % name)
        ref.GetReferences().AddReference(os.path.basename(geo_path), "/Geometry/%s" % src)
        ref.SetInstanceable(False)
        UsdShade.MaterialBindingAPI.Apply(ref).Bind(mat)
    cam = UsdGeom.Camera.Define(st, "/World/Camera")
    cam.CreateFocalLengthAttr(35.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(24.0)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 1000.0))
    xf = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0.0, 9.0, 16.0), Gf.Vec3d(0.0, 1.0, 0.0), Gf.Vec3d(0, 1, 0)).GetInverse()
    cam.AddTransformOp().Set(xf)
    key = UsdLux.RectLight.Define(st, "/World/Key")
    key.CreateWidthAttr(6.0)
    key.CreateHeightAttr(6.0)
    key.CreateIntensityAttr(30.0)
    kx = Gf.Matrix4d().SetLookAt(Gf.Vec3d(-6.0, 12.0, 8.0), Gf.Vec3d(0.0, 0.0, 0.0), Gf.Vec3d(0, 1, 0)).GetInverse()
    key.AddTransformOp().Set(kx)
    dome = UsdLux.DomeLight.Define(st, "/World/Sky")
    dome.CreateIntensityAttr(0.3)
    st.GetRootLayer().Save()
    print("%s: %d cage quads (%d triangles' worth) in 14 meshes, %d placements" % (stage_path, quads, 2 * quads, len(placements)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
