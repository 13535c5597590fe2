"""Tests of the USD -> .rss converter (python/raysplat_usd.py).

Run with `python3 -m unittest discover -s python/tests -v` (needs usd-core). Every test builds a tiny
stage with usd-core in a temporary directory, runs the converter the way the Rust binary does
(`python3 - INPUT OUTPUT` with the source on stdin), reads the .rss back with the small reader below and
checks numbers. The header is also checked against the serde shapes of `src/scene` (field names, types,
enum tags), so a converter change that the Rust loader would reject fails here first.
"""

import hashlib
import json
import math
import os
import re
import struct
import subprocess
import sys
import tempfile
import time
import unittest
import zlib
from pathlib import Path

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, UsdSkel, UsdUtils, UsdVol, Vt

HERE = Path(__file__).resolve().parent
# the converter's parts, in the order `usd::CONVERTER` concatenates them
PARTS = [HERE.parent / n for n in ("raysplat_subdiv.py", "raysplat_curves.py", "raysplat_usd_common.py",
                                   "raysplat_usd_materials.py", "raysplat_usd_meshes.py",
                                   "raysplat_usd_lights.py", "raysplat_usd.py")]
REPO = HERE.parent.parent
SHARED = Path(os.environ.get("RAYSPLAT_SHARED_SCENES", str(REPO.parent / "shared" / "scenes")))


# ----------------------------------------------------------------------------------------------------
# Running the converter and reading its output
# ----------------------------------------------------------------------------------------------------


class Result:
    def __init__(self, proc, out):
        self.rc = proc.returncode
        self.stdout = proc.stdout.decode("utf-8", "replace")
        self.stderr = proc.stderr.decode("utf-8", "replace")
        self.out = out

    @property
    def summary(self):
        lines = [l for l in self.stdout.splitlines() if l.strip()]
        return json.loads(lines[-1])

    @property
    def stderr_warnings(self):
        return [l for l in self.stderr.splitlines() if l.startswith("warning: ")]


def convert(inp, out, extra=("--json-summary",)):
    """Run the converter exactly as the Rust binary does: source on stdin."""
    src = b"".join(p.read_bytes() for p in PARTS)  # as `usd::CONVERTER` concatenates them
    proc = subprocess.run([sys.executable, "-", str(inp), str(out), *extra], input=src,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tempfile.gettempdir(), timeout=600)
    return Result(proc, out)


ELEM = {"f32x3": ("f", 3), "u32x3": ("I", 3), "f32x2": ("f", 2), "u32": ("I", 1), "f32": ("f", 1)}


class Rss:
    """A .rss file: the JSON header and typed access to the blob's arrays."""

    def __init__(self, path):
        data = Path(path).read_bytes()
        assert data[:8] == b"RAYSPLAT", "bad magic"
        self.version, reserved = struct.unpack_from("<II", data, 8)
        assert self.version == 1 and reserved == 0
        (hlen,) = struct.unpack_from("<Q", data, 16)
        self.header = json.loads(data[24:24 + hlen].decode("utf-8"))
        start = (24 + hlen + 15) & ~15
        assert all(b == 0 for b in data[24 + hlen:start]), "padding must be zero"
        self.blob = data[start:]
        check_shapes(self.header)
        for m in self.header["meshes"]:
            for key in ("positions", "indices", "normals", "uvs", "material_ids"):
                if m[key] is not None:
                    self.array(m[key])  # bounds and alignment

    def __getitem__(self, k):
        return self.header[k]

    def array(self, ref):
        fmt, width = ELEM[ref["type"]]
        off, count = ref["offset"], ref["count"]
        assert off % 16 == 0, "array offset %d not 16-byte aligned" % off
        assert off + 4 * width * count <= len(self.blob), "array runs past the end"
        flat = struct.unpack_from("<%d%s" % (width * count, fmt), self.blob, off)
        if width == 1:
            return list(flat)
        return [tuple(flat[i:i + width]) for i in range(0, len(flat), width)]

    def mesh(self, i):
        m = self.header["meshes"][i]
        out = {"name": m["name"], "double_sided": m["double_sided"]}
        for key in ("positions", "indices", "normals", "uvs", "colors", "material_ids"):
            out[key] = self.array(m[key]) if m.get(key) is not None else None
        return out

    def mesh_named(self, name):
        for i, m in enumerate(self.header["meshes"]):
            if m["name"] == name:
                return self.mesh(i)
        raise KeyError(name)

    def instances_of(self, name_prefix):
        return [i for i in self.header["instances"] if i["name"].startswith(name_prefix)]

    def light(self, name):
        return next(l for l in self.header["lights"] if l["name"] == name)

    def material(self, name):
        return next(m for m in self.header["materials"] if m["name"] == name)

    def warnings_for(self, prim_substring=""):
        return [w for w in self.header["warnings"] if prim_substring in w["prim"]]

    def triangles(self):
        return sum(self.header["meshes"][i["mesh"]]["indices"]["count"] for i in self.header["instances"])


# --- the serde shapes of src/scene/mod.rs and src/scene/format.rs -----------------------------------


def _is_num(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _f32s(x, n):
    return isinstance(x, list) and len(x) == n and all(_is_num(v) for v in x)


def _mat4(x):
    return isinstance(x, list) and len(x) == 4 and all(_f32s(c, 4) for c in x)


def _opt_u32(x):
    return x is None or (isinstance(x, int) and not isinstance(x, bool) and x >= 0)


def check_shapes(h):
    """What serde would require of the header (struct field names and types, enum tags)."""
    assert h["format"] == "raysplat-scene" and h["version"] == 1
    assert isinstance(h["source"], str) and isinstance(h["converter_version"], str)
    for d in h["dependencies"]:
        # a dependency that is missing at conversion time (a texture not yet written) has no hash
        assert set(d) >= {"path", "sha256"} and isinstance(d["path"], str)
        assert d["sha256"] is None or re.fullmatch(r"[0-9a-f]{64}", d["sha256"])
    assert h["resolution"] is None or (isinstance(h["resolution"], list) and len(h["resolution"]) == 2
                                       and all(isinstance(v, int) and v >= 0 for v in h["resolution"]))
    cam = h["camera"]
    if cam is not None:
        assert isinstance(cam["name"], str) and _mat4(cam["transform"])
        assert cam["projection"] in ("perspective", "orthographic")
        for k in ("focal_length", "horizontal_aperture", "vertical_aperture"):
            assert _is_num(cam[k]), k
        assert _f32s(cam["clipping"], 2)
    for m in h["materials"]:
        assert m["kind"] in ("preview_surface", "error"), m
        assert isinstance(m["name"], str)
        if m["kind"] == "preview_surface":
            for k in ("diffuse_color", "emissive_color", "specular_color"):
                if k in m:
                    assert _f32s(m[k]["value"], 3) and _opt_u32(m[k].get("texture")), (k, m[k])
            for k in ("metallic", "roughness", "clearcoat", "clearcoat_roughness", "opacity"):
                if k in m:
                    assert _is_num(m[k]["value"]) and _opt_u32(m[k].get("texture")), (k, m[k])
            if "use_specular_workflow" in m:
                assert isinstance(m["use_specular_workflow"], bool)
            for k in ("opacity_threshold", "ior"):
                if k in m:
                    assert _is_num(m[k]), k
            assert _opt_u32(m.get("normal_map"))
    for t in h["textures"]:
        assert isinstance(t["path"], str)
        assert t["wrap_s"] in ("repeat", "mirror", "clamp", "black") and t["wrap_t"] in ("repeat", "mirror", "clamp", "black")
        assert _f32s(t["scale"], 4) and _f32s(t["bias"], 4) and _f32s(t["fallback"], 4)
        assert t["color_space"] in ("sRGB", "raw", "auto") and t["output"] in ("rgb", "r", "g", "b", "a")
    for l in h["lights"]:
        ty = l["type"]
        assert isinstance(l["name"], str)
        if ty == "rect":
            assert _mat4(l["transform"]) and _is_num(l["width"]) and _is_num(l["height"]) and _f32s(l["radiance"], 3)
            assert _opt_u32(l.get("texture"))
        elif ty == "disk":
            assert _mat4(l["transform"]) and _is_num(l["radius"]) and _f32s(l["radiance"], 3)
        elif ty == "sphere":
            assert _mat4(l["transform"]) and _is_num(l["radius"]) and _f32s(l["radiance"], 3)
            c = l.get("cone")
            assert c is None or (_is_num(c["angle_deg"]) and _is_num(c["softness"]) and _is_num(c.get("focus", 0)))
        elif ty == "distant":
            assert _f32s(l["direction"], 3) and _is_num(l["angle_deg"]) and _f32s(l["irradiance"], 3)
        elif ty == "dome":
            assert _mat4(l["transform"]) and _f32s(l["radiance"], 3) and _opt_u32(l.get("texture"))
        else:
            raise AssertionError("unknown light type %r" % ty)
    for m in h["meshes"]:
        assert isinstance(m["name"], str) and isinstance(m.get("double_sided", False), bool)
        for key, ty in (("positions", "f32x3"), ("indices", "u32x3"), ("material_ids", "u32")):
            assert m[key]["type"] == ty and m[key]["offset"] >= 0 and m[key]["count"] >= 0
        for key, ty in (("normals", "f32x3"), ("uvs", "f32x2")):
            assert m[key] is None or (m[key]["type"] == ty and m[key]["count"] == m["positions"]["count"])
    for i in h["instances"]:
        assert isinstance(i["mesh"], int) and 0 <= i["mesh"] < len(h["meshes"]) and _mat4(i["transform"])
        assert isinstance(i["name"], str)
    for w in h["warnings"]:
        assert isinstance(w["prim"], str) and isinstance(w["message"], str)
    assert isinstance(h["stage"], dict)


# ----------------------------------------------------------------------------------------------------
# Building stages
# ----------------------------------------------------------------------------------------------------


def new_stage(path, up="Y", mpu=1.0):
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, up)
    if mpu is not None:
        UsdGeom.SetStageMetersPerUnit(stage, mpu)
    return stage


def add_mesh(stage, path, points, counts, indices, **kw):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    m.CreateFaceVertexCountsAttr(Vt.IntArray(list(counts)))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray(list(indices)))
    m.CreateSubdivisionSchemeAttr(kw.get("scheme", "none"))
    if "orientation" in kw:
        m.CreateOrientationAttr(kw["orientation"])
    return m


def quad(stage, path, z=0.0, size=1.0, **kw):
    s = size
    return add_mesh(stage, path, [(0, 0, z), (s, 0, z), (s, s, z), (0, s, z)], [4], [0, 1, 2, 3], **kw)


def preview(stage, path, **inputs):
    """A Material with a UsdPreviewSurface; returns (material, shader)."""
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/Surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    types = {"diffuseColor": Sdf.ValueTypeNames.Color3f, "emissiveColor": Sdf.ValueTypeNames.Color3f,
             "specularColor": Sdf.ValueTypeNames.Color3f, "useSpecularWorkflow": Sdf.ValueTypeNames.Int,
             "normal": Sdf.ValueTypeNames.Normal3f}
    for k, v in inputs.items():
        sh.CreateInput(k, types.get(k, Sdf.ValueTypeNames.Float)).Set(v)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat, sh


def bind(prim_or_schema, mat):
    prim = prim_or_schema.GetPrim() if hasattr(prim_or_schema, "GetPrim") else prim_or_schema
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(mat)


def camera(stage, path="/Cam", z=5.0):
    cam = UsdGeom.Camera.Define(stage, path)
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, z))
    return cam


def png_bytes(w=2, h=2, rgb=(255, 0, 0)):
    raw = b"".join(b"\0" + bytes(rgb) * w for _ in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def apply(m, p):
    """Column-major 4x4 [[c0],[c1],[c2],[c3]] applied to a point."""
    return tuple(m[0][i] * p[0] + m[1][i] * p[1] + m[2][i] * p[2] + m[3][i] for i in range(3))


def tri_normal(a, b, c):
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    ln = math.sqrt(sum(x * x for x in n))
    return tuple(x / ln for x in n)


class Case(unittest.TestCase):
    def setUp(self):
        self._tmp = tempfile.TemporaryDirectory(prefix="raysplat-usd-test-")
        self.dir = Path(self._tmp.name)

    def tearDown(self):
        self._tmp.cleanup()

    def stage(self, name="scene.usda", up="Y", mpu=1.0):
        self.path = self.dir / name
        return new_stage(self.path, up, mpu)

    def convert(self, stage=None, expect_ok=True, args=()):
        if stage is not None:
            stage.GetRootLayer().Save()
        out = self.dir / "out.rss"
        r = convert(self.path, out, extra=("--json-summary", *args))
        if expect_ok:
            self.assertEqual(r.rc, 0, r.stderr)
            self.assertNotIn("Traceback", r.stderr)
            rss = Rss(out)
            # every warning in the header is also printed
            self.assertEqual(len(r.stderr_warnings), len(rss["warnings"]), r.stderr)
            self.result = r
            return rss
        return r

    def result_warnings(self):
        """The messages of the last conversion's warnings, as printed."""
        return [l.split(": ", 2)[2] for l in self.result.stderr_warnings if l.count(": ") >= 2]

    def assertVec(self, a, b, tol=1e-5, msg=None):
        self.assertEqual(len(a), len(b), msg)
        for x, y in zip(a, b):
            self.assertAlmostEqual(x, y, delta=tol, msg="%s vs %s %s" % (a, b, msg or ""))


# ----------------------------------------------------------------------------------------------------
# Meshes
# ----------------------------------------------------------------------------------------------------


class MeshTests(Case):
    def test_ngon_triangulation_counts_and_shared_vertices(self):
        st = self.stage()
        pts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0), (3, 0, 0), (3, 1, 0), (2.5, 2, 0)]
        # a triangle, a quad, a pentagon: 1 + 2 + 3 triangles
        add_mesh(st, "/M", pts, [3, 4, 5], [0, 1, 2, 1, 4, 5, 2, 4, 6, 7, 8, 5])
        camera(st)
        rss = self.convert(st)
        m = rss.mesh_named("/M")
        self.assertEqual(len(m["indices"]), 6)
        self.assertEqual(len(m["positions"]), 9, "vertex-interpolated data shares vertices")
        self.assertEqual(m["normals"], None)
        self.assertEqual(m["uvs"], None)
        # fan triangulation keeps the winding: all triangles face +Z
        for t in m["indices"]:
            self.assertVec(tri_normal(*[m["positions"][i] for i in t]), (0, 0, 1))
        self.assertEqual(self.result.summary["triangles"], 6)

    def test_hole_faces_are_skipped(self):
        st = self.stage()
        m = add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)], [4, 4],
                     [0, 1, 2, 3, 1, 4, 5, 2])
        m.CreateHoleIndicesAttr([1])
        rss = self.convert(st)
        self.assertEqual(len(rss.mesh_named("/M")["indices"]), 2)

    def test_degenerate_faces_warn(self):
        st = self.stage()
        add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [3, 2], [0, 1, 2, 0, 1])
        rss = self.convert(st)
        self.assertEqual(len(rss.mesh_named("/M")["indices"]), 1)
        self.assertTrue(any("fewer than 3" in w["message"] for w in rss.warnings_for("/M")))

    def test_geomsubset_material_ids_per_triangle(self):
        st = self.stage()
        mesh = add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0), (3, 0, 0)],
                        [3, 4, 3, 3], [0, 1, 2, 1, 4, 5, 2, 4, 6, 5, 0, 2, 3])
        red, _ = preview(st, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
        green, _ = preview(st, "/Looks/Green", diffuseColor=Gf.Vec3f(0, 1, 0))
        grey, _ = preview(st, "/Looks/Grey")
        bind(mesh, grey)
        api = UsdShade.MaterialBindingAPI(mesh.GetPrim())
        a = api.CreateMaterialBindSubset("A", Vt.IntArray([0, 2]))
        b = api.CreateMaterialBindSubset("B", Vt.IntArray([1]))
        bind(a, red)
        bind(b, green)
        rss = self.convert(st)
        mats = [m["name"] for m in rss["materials"]]
        m = rss.mesh_named("/M")
        ids = [mats[i] for i in m["material_ids"]]
        # faces: tri(0)=A, quad(1)=B (two triangles), tri(2)=A, tri(3) unassigned -> mesh binding
        self.assertEqual(ids, ["/Looks/Red", "/Looks/Green", "/Looks/Green", "/Looks/Red", "/Looks/Grey"])
        self.assertEqual(rss.material("/Looks/Red")["diffuse_color"]["value"], [1.0, 0.0, 0.0])

    def _normals_mesh(self, interp, values, indices=None, use_attr=False):
        st = self.stage()
        # two quads sharing an edge: points 0..5, faces (0 1 4 3) and (1 2 5 4)
        pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
        m = add_mesh(st, "/M", pts, [4, 4], [0, 1, 4, 3, 1, 2, 5, 4])
        vals = Vt.Vec3fArray([Gf.Vec3f(*v) for v in values])
        if use_attr:
            m.CreateNormalsAttr(vals)
            m.SetNormalsInterpolation(interp)
        else:
            pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray, interp)
            pv.Set(vals)
            if indices is not None:
                pv.SetIndices(Vt.IntArray(indices))
        rss = self.convert(st)
        return rss.mesh_named("/M")

    def corner_normals(self, m):
        """Normals per triangle corner, in triangle order."""
        return [[m["normals"][i] for i in t] for t in m["indices"]]

    def test_normals_constant(self):
        m = self._normals_mesh("constant", [(0, 0, 1)])
        self.assertEqual(len(m["positions"]), 6)
        for tri in self.corner_normals(m):
            for n in tri:
                self.assertVec(n, (0, 0, 1))

    def test_normals_uniform(self):
        m = self._normals_mesh("uniform", [(1, 0, 0), (0, 1, 0)])
        cn = self.corner_normals(m)
        self.assertEqual(len(cn), 4)
        for tri in cn[:2]:
            for n in tri:
                self.assertVec(n, (1, 0, 0))
        for tri in cn[2:]:
            for n in tri:
                self.assertVec(n, (0, 1, 0))
        # the shared edge's points are split: 8 vertices
        self.assertEqual(len(m["positions"]), 8)

    def test_normals_vertex_and_varying(self):
        vals = [(i, 0, 1) for i in range(6)]
        for interp in ("vertex", "varying"):
            m = self._normals_mesh(interp, vals)
            self.assertEqual(len(m["positions"]), 6)
            pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
            for p, n in zip(m["positions"], m["normals"]):
                self.assertVec(n, vals[pts.index(tuple(p))], msg=interp)

    def test_normals_vertex_indexed(self):
        m = self._normals_mesh("vertex", [(0, 0, 1), (0, 1, 0)], indices=[0, 1, 0, 1, 0, 1])
        pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
        for p, n in zip(m["positions"], m["normals"]):
            k = pts.index(tuple(p))
            self.assertVec(n, (0, 0, 1) if k % 2 == 0 else (0, 1, 0))

    def test_normals_facevarying(self):
        vals = [(c, 0, 1) for c in range(8)]  # corner c of the face-vertex list
        m = self._normals_mesh("faceVarying", vals)
        fvi = [0, 1, 4, 3, 1, 2, 5, 4]
        pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
        # every triangle corner carries the normal of its face-vertex
        for t in m["indices"]:
            for i in t:
                c = int(round(m["normals"][i][0]))
                self.assertEqual(tuple(m["positions"][i]), pts[fvi[c]])

    def test_normals_facevarying_indexed_dedupes(self):
        m = self._normals_mesh("faceVarying", [(0, 0, 1), (1, 0, 0)], indices=[0, 0, 0, 0, 1, 1, 1, 1])
        self.assertEqual(len(m["positions"]), 8)  # shared edge split by differing normals
        cn = self.corner_normals(m)
        for tri in cn[:2]:
            for n in tri:
                self.assertVec(n, (0, 0, 1))
        for tri in cn[2:]:
            for n in tri:
                self.assertVec(n, (1, 0, 0))
        m = self._normals_mesh("faceVarying", [(0, 0, 1)], indices=[0] * 8)
        self.assertEqual(len(m["positions"]), 6, "equal face-varying values share vertices")

    def test_normals_attribute_without_primvar(self):
        m = self._normals_mesh("uniform", [(1, 0, 0), (0, 1, 0)], use_attr=True)
        cn = self.corner_normals(m)
        self.assertVec(cn[0][0], (1, 0, 0))
        self.assertVec(cn[3][2], (0, 1, 0))

    def test_bad_primvar_length_warns(self):
        st = self.stage()
        m = quad(st, "/M")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray, "vertex").Set(
            Vt.Vec3fArray([Gf.Vec3f(0, 0, 1)] * 3))
        rss = self.convert(st)
        self.assertIsNone(rss.mesh_named("/M")["normals"])
        self.assertTrue(any("normals" in w["message"] for w in rss.warnings_for("/M")))

    def test_uv_facevarying_indexed_expansion(self):
        st = self.stage()
        pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
        m = add_mesh(st, "/M", pts, [4, 4], [0, 1, 4, 3, 1, 2, 5, 4])
        uvs = [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0.5)]
        pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "faceVarying")
        pv.Set(Vt.Vec2fArray([Gf.Vec2f(*u) for u in uvs]))
        # face 0 maps 0..3; face 1 reuses (1,0)->corner of point 1 but (0.5,0.5) elsewhere
        pv.SetIndices(Vt.IntArray([0, 1, 2, 3, 1, 4, 4, 2]))
        rss = self.convert(st)
        mm = rss.mesh_named("/M")
        fvi = [0, 1, 4, 3, 1, 2, 5, 4]
        uvi = [0, 1, 2, 3, 1, 4, 4, 2]
        expected = {}  # (point, uv) pairs that must exist
        for c in range(8):
            expected[(pts[fvi[c]], uvs[uvi[c]])] = True
        got = {(tuple(p), tuple(u)) for p, u in zip(mm["positions"], mm["uvs"])}
        self.assertEqual(got, {(p, tuple(float(x) for x in u)) for p, u in expected})
        # corners (point 1, uv 1) and (point 4, uv 2) are shared by both faces: 8 corners -> 6 vertices
        self.assertEqual(len(mm["positions"]), 6)
        self.assertEqual(len(mm["indices"]), 4)

    def test_uv_vertex_and_uniform(self):
        st = self.stage()
        m = quad(st, "/M")
        pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex")
        pv.Set(Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
        m2 = quad(st, "/U", z=1)
        pv = UsdGeom.PrimvarsAPI(m2).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "uniform")
        pv.Set(Vt.Vec2fArray([Gf.Vec2f(0.25, 0.75)]))
        rss = self.convert(st)
        mm = rss.mesh_named("/M")
        for p, u in zip(mm["positions"], mm["uvs"]):
            self.assertVec(u, (p[0], p[1]))
        for u in rss.mesh_named("/U")["uvs"]:
            self.assertVec(u, (0.25, 0.75))

    def test_uv_primvar_named_by_the_material(self):
        st = self.stage()
        m = quad(st, "/M")
        api = UsdGeom.PrimvarsAPI(m)
        api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(Vt.Vec2fArray([Gf.Vec2f(9, 9)] * 4))
        api.CreatePrimvar("uvmap", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
        (self.dir / "t.png").write_bytes(png_bytes())
        mat, sh = preview(st, "/Looks/T")
        tex = UsdShade.Shader.Define(st, "/Looks/T/Tex")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("t.png")
        rd = UsdShade.Shader.Define(st, "/Looks/T/Reader")
        rd.CreateIdAttr("UsdPrimvarReader_float2")
        rd.CreateInput("varname", Sdf.ValueTypeNames.String).Set("uvmap")
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(rd.ConnectableAPI(), "result")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        # a second mesh without that primvar: warned, falls back to st
        m2 = quad(st, "/N", z=1)
        UsdGeom.PrimvarsAPI(m2).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(7, 7)] * 4))
        bind(m2, mat)
        rss = self.convert(st)
        mm = rss.mesh_named("/M")
        for p, u in zip(mm["positions"], mm["uvs"]):
            self.assertVec(u, (p[0], p[1]))
        self.assertEqual(rss.mesh_named("/N")["uvs"][0], (7.0, 7.0))
        self.assertTrue(any("uvmap" in w["message"] for w in rss.warnings_for("/N")))

    def test_left_handed_winding_is_flipped(self):
        st = self.stage()
        add_mesh(st, "/R", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
        add_mesh(st, "/L", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2], orientation="leftHanded")
        q = add_mesh(st, "/LQ", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4], [0, 1, 2, 3], orientation="leftHanded")
        rss = self.convert(st)
        r, l, lq = rss.mesh_named("/R"), rss.mesh_named("/L"), rss.mesh_named("/LQ")
        self.assertVec(tri_normal(*[r["positions"][i] for i in r["indices"][0]]), (0, 0, 1))
        self.assertVec(tri_normal(*[l["positions"][i] for i in l["indices"][0]]), (0, 0, -1))
        for t in lq["indices"]:
            self.assertVec(tri_normal(*[lq["positions"][i] for i in t]), (0, 0, -1))

    def test_double_sided(self):
        st = self.stage()
        quad(st, "/S")
        quad(st, "/D", z=1).CreateDoubleSidedAttr(True)
        rss = self.convert(st)
        self.assertFalse(rss.mesh_named("/S")["double_sided"])
        self.assertTrue(rss.mesh_named("/D")["double_sided"])

    def test_subdivision_level_0_is_the_cage_with_warning_and_smooth_normals(self):
        st = self.stage()
        quad(st, "/Sub", scheme="catmullClark")
        rss = self.convert(st, args=("--subdivision-level", "0"))
        m = rss.mesh_named("/Sub")
        self.assertEqual(len(m["indices"]), 2)
        self.assertTrue(any("control cage" in w["message"] for w in rss.warnings_for("/Sub")))
        for n in m["normals"]:
            self.assertVec(n, (0, 0, 1))

    # A cube of side 2 about the origin, faces outward.
    CUBE_PTS = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
    CUBE_IDX = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3]

    def cube(self, st, path="/Cube", **kw):
        return add_mesh(st, path, self.CUBE_PTS, [4] * 6, self.CUBE_IDX, scheme="catmullClark", **kw)

    def test_catmull_clark_points_lie_on_the_limit_surface(self):
        # one level on a cube (the rules themselves: test_subdiv.py), its points then moved onto the
        # limit surface: a corner of valence 3 to (9 v + 4 Σ e + Σ d) / 24 = v / 2, a face centre
        # (regular: the bicubic B-spline's mask) to 68/81 of the half side; the points of level 1
        # are points of level 2 too (a limit point is where every further level puts it)
        st = self.stage()
        self.cube(st)
        rss = self.convert(st, args=("--subdivision-level", "1"))
        m = rss.mesh_named("/Cube")
        self.assertEqual(len(m["indices"]), 6 * 4 * 2)
        pts = {tuple(round(c, 5) for c in p) for p in m["positions"]}
        self.assertEqual(len(pts), 8 + 12 + 6)
        self.assertIn((0.5, 0.5, 0.5), pts)
        self.assertIn((-0.5, 0.5, -0.5), pts)
        self.assertIn((round(68 / 81, 5), 0.0, 0.0), pts)
        self.assertFalse(rss.warnings_for("/Cube"), rss.warnings_for("/Cube"))
        level2 = {tuple(round(c, 5) for c in p) for p in self.convert(st).mesh_named("/Cube")["positions"]}
        self.assertLessEqual(pts, level2)
        # winding kept: every triangle faces away from the centre; normals are smooth and outward
        for t in m["indices"]:
            a, b, c = (m["positions"][i] for i in t)
            centre = [(a[k] + b[k] + c[k]) / 3 for k in range(3)]
            self.assertGreater(sum(x * y for x, y in zip(tri_normal(a, b, c), centre)), 0)
        for p, n in zip(m["positions"], m["normals"]):
            self.assertGreater(sum(x * y for x, y in zip(p, n)), 0.5)

    def test_catmull_clark_converges_toward_the_limit_surface(self):
        # the default level (2): 96 quads, every point between the cube's limit surface bounds
        st = self.stage()
        self.cube(st)
        m = self.convert(st).mesh_named("/Cube")
        self.assertEqual(len(m["indices"]), 6 * 16 * 2)
        for p in m["positions"]:
            r = math.sqrt(sum(c * c for c in p))
            self.assertGreater(r, 0.6)
            self.assertLess(r, 1.0)

    def test_subdivision_normals_are_the_limit_surfaces(self):
        # the converted cube's points lie on its limit surface, and their normals are the surface's:
        # against the area-weighted normals of the same points refined four levels further (they
        # are points of every finer level too), within 0.02° (area-weighted normals of level 2
        # itself: up to 1.8°)
        from test_subdiv import Refinement, angle, area_normals, flat
        st = self.stage()
        self.cube(st)
        m = self.convert(st).mesh_named("/Cube")
        deep = Refinement(8, [4] * 6, self.CUBE_IDX, 6)
        dp = deep.points(flat(self.CUBE_PTS), 3, limit=True)
        want = dict(zip((tuple(round(c, 4) for c in dp[3 * i:3 * i + 3]) for i in range(deep.npts)), area_normals(deep, dp)))
        worst = max(angle(n, want[tuple(round(c, 4) for c in q)]) for q, n in zip(m["positions"], m["normals"]))
        self.assertLess(worst, 0.02)

    def test_boundaries_and_sharp_creases_keep_their_shape(self):
        st = self.stage()
        # a flat 2x1 grid of quads: edgeAndCorner keeps the corners and the boundary on its lines
        add_mesh(st, "/Grid", [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)], [4, 4],
                 [0, 1, 4, 3, 1, 2, 5, 4], scheme="catmullClark")
        # a cube whose every edge is infinitely sharp stays a cube
        c = self.cube(st, "/Sharp")
        chain = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
        c.CreateCreaseIndicesAttr([v for e in chain for v in e])
        c.CreateCreaseLengthsAttr([2] * 12)
        c.CreateCreaseSharpnessesAttr([10.0] * 12)
        # a cube with one infinitely sharp corner
        k = self.cube(st, "/Corner")
        k.CreateCornerIndicesAttr([6])
        k.CreateCornerSharpnessesAttr([10.0])
        rss = self.convert(st, args=("--subdivision-level", "3"))
        g = rss.mesh_named("/Grid")["positions"]
        self.assertTrue(all(abs(p[2]) < 1e-6 for p in g))
        for corner in [(0, 0), (2, 0), (0, 1), (2, 1)]:
            self.assertTrue(any(abs(p[0] - corner[0]) < 1e-6 and abs(p[1] - corner[1]) < 1e-6 for p in g), corner)
        self.assertAlmostEqual(min(p[0] for p in g), 0.0, places=6)
        self.assertAlmostEqual(max(p[0] for p in g), 2.0, places=6)
        sharp = rss.mesh_named("/Sharp")["positions"]
        self.assertTrue(all(abs(max(abs(c) for c in p) - 1.0) < 1e-5 for p in sharp))
        self.assertIn((1.0, 1.0, 1.0), {tuple(round(c, 5) for c in p) for p in sharp})
        # the sharp cube's shading is flat on each face, hard at its edges (smooth normals would
        # tilt toward the neighbouring faces there)
        sm = rss.mesh_named("/Sharp")
        for t in sm["indices"]:
            a, b, c = (sm["positions"][i] for i in t)
            face = tri_normal(a, b, c)
            for i in t:
                self.assertVec(sm["normals"][i], face, tol=1e-4)
        corner = rss.mesh_named("/Corner")["positions"]
        self.assertIn((1.0, 1.0, 1.0), {tuple(round(c, 5) for c in p) for p in corner})
        self.assertNotIn((-1.0, -1.0, -1.0), {tuple(round(c, 5) for c in p) for p in corner})

    def test_refined_holes_subsets_and_face_varying_uvs(self):
        st = self.stage()
        m = add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0), (3, 0, 0), (3, 1, 0)],
                     [4, 4, 4], [0, 1, 2, 3, 1, 4, 5, 2, 4, 6, 7, 5], scheme="catmullClark")
        m.CreateHoleIndicesAttr([2])
        uv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
        uv.Set(Vt.Vec2fArray([Gf.Vec2f(*c) for c in [(0, 0), (1, 0), (1, 1), (0, 1)] * 3]))
        red, _ = preview(st, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
        grey, _ = preview(st, "/Looks/Grey")
        bind(m, grey)
        bind(UsdShade.MaterialBindingAPI(m.GetPrim()).CreateMaterialBindSubset("A", Vt.IntArray([1])), red)
        rss = self.convert(st, args=("--subdivision-level", "1"))
        out = rss.mesh_named("/M")
        # the hole's four children are dropped; face 1's children keep its subset's material
        self.assertEqual(len(out["indices"]), 2 * 4 * 2)
        mats = [x["name"] for x in rss["materials"]]
        self.assertEqual([mats[i] for i in out["material_ids"]], ["/Looks/Grey"] * 8 + ["/Looks/Red"] * 8)
        # the face points carry the centre of each face's texture square
        uvs = {tuple(round(c, 5) for c in u) for u in out["uvs"]}
        self.assertIn((0.5, 0.5), uvs)
        self.assertIn((0.5, 0.0), uvs)
        self.assertFalse(rss.warnings_for("/M"), rss.warnings_for("/M"))

    def test_face_varying_primvars_follow_the_smooth_rules_inside_their_islands(self):
        # a 3x3 grid of quads whose texture coordinates are its own x, y (one island, face-varying):
        # refined smoothly (cornersPlus1, USD's default) they stay the refined points' x, y, where
        # refined linearly ("all") they do not
        st = self.stage()
        pts = [(x + 0.3 * (x == 1 and y == 1), y - 0.2 * (x == 2), 0.1 * ((x * 7 + y * 3) % 4))
               for y in range(4) for x in range(4)]
        faces = [(y * 4 + x, y * 4 + x + 1, (y + 1) * 4 + x + 1, (y + 1) * 4 + x) for y in range(3) for x in range(3)]
        for name, rule in (("/Smooth", None), ("/Linear", "all")):
            m = add_mesh(st, name, pts, [4] * 9, [i for f in faces for i in f], scheme="catmullClark")
            if rule:
                m.CreateFaceVaryingLinearInterpolationAttr(rule)
            uv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
            uv.Set(Vt.Vec2fArray([Gf.Vec2f(pts[i][0], pts[i][1]) for f in faces for i in f]))
        rss = self.convert(st, args=("--subdivision-level", "2"))
        smooth, linear = rss.mesh_named("/Smooth"), rss.mesh_named("/Linear")
        for p, u in zip(smooth["positions"], smooth["uvs"]):
            self.assertAlmostEqual(p[0], u[0], places=5)
            self.assertAlmostEqual(p[1], u[1], places=5)
        worst = max(abs(p[0] - u[0]) + abs(p[1] - u[1]) for p, u in zip(linear["positions"], linear["uvs"]))
        self.assertGreater(worst, 0.01)

    def test_varying_primvars_are_refined_linearly(self):
        # a 4x4 grid of quads with one texture coordinate 1 at an interior vertex, 0 elsewhere:
        # varying, it is interpolated bilinearly over the faces (its peak stays 1, every refined
        # value a multiple of 1/16 at level 2); vertex, it follows the smooth rules and the limit
        st = self.stage()
        pts = [(x, y, 0.1 * ((x * 7 + y * 3) % 4)) for y in range(5) for x in range(5)]
        faces = [(y * 5 + x, y * 5 + x + 1, (y + 1) * 5 + x + 1, (y + 1) * 5 + x) for y in range(4) for x in range(4)]
        for name, interp in (("/Varying", UsdGeom.Tokens.varying), ("/Vertex", UsdGeom.Tokens.vertex)):
            m = add_mesh(st, name, pts, [4] * 16, [i for f in faces for i in f], scheme="catmullClark")
            uv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, interp)
            uv.Set(Vt.Vec2fArray([Gf.Vec2f(1.0 if i == 13 else 0.0, 0.0) for i in range(len(pts))]))
        rss = self.convert(st, args=("--subdivision-level", "2"))
        varying = [u[0] for u in rss.mesh_named("/Varying")["uvs"]]
        self.assertEqual(max(varying), 1.0)
        for x in varying:
            self.assertAlmostEqual(x * 16, round(x * 16), places=4)
        self.assertLess(max(u[0] for u in rss.mesh_named("/Vertex")["uvs"]), 0.5)
        self.assertFalse(rss.warnings_for("/Varying"), rss.warnings_for("/Varying"))

    def test_loop_and_bilinear_schemes(self):
        st = self.stage()
        tet = [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]
        add_mesh(st, "/Loop", tet, [3] * 4, [0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2], scheme="loop")
        add_mesh(st, "/Bilinear", self.CUBE_PTS, [4] * 6, self.CUBE_IDX, scheme="bilinear")
        add_mesh(st, "/LoopQuads", self.CUBE_PTS, [4] * 6, self.CUBE_IDX, scheme="loop")
        rss = self.convert(st, args=("--subdivision-level", "1"))
        loop = rss.mesh_named("/Loop")
        self.assertEqual(len(loop["indices"]), 16)
        # a tip's limit (valence 3, χ = 1/5): (1 - 3/5) v + (sum of the others) / 5 = v / 5
        self.assertIn((0.2, 0.2, 0.2), {tuple(round(c, 5) for c in p) for p in loop["positions"]})
        bil = rss.mesh_named("/Bilinear")
        self.assertEqual(len(bil["indices"]), 48)
        self.assertTrue(all(abs(max(abs(c) for c in p) - 1.0) < 1e-6 for p in bil["positions"]))
        self.assertEqual(len(rss.mesh_named("/LoopQuads")["indices"]), 12)
        self.assertTrue(any("loop scheme needs triangles" in w["message"] for w in rss.warnings_for("/LoopQuads")))

    def test_faces_no_subdivision_rule_covers_leave_the_cage_unrefined(self):
        # no subdivision rule covers a face that names a vertex twice (Loop's edge rule has no
        # opposite vertex for it): the cage is rendered, with a warning naming the prim and the face
        st = self.stage()
        add_mesh(st, "/Loop", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)], [3, 3], [0, 1, 2, 1, 1, 3], scheme="loop")
        add_mesh(st, "/CC", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4, 4], [0, 1, 2, 3, 0, 1, 1, 2], scheme="catmullClark")
        # nor a face of fewer than three vertices (a face of none divided by zero for its centroid)
        add_mesh(st, "/Small", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4, 0, 2], [0, 1, 2, 3, 0, 1], scheme="bilinear")
        rss = self.convert(st)
        self.assertEqual(len(rss.mesh_named("/Small")["indices"]), 2)
        self.assertTrue(any("face 1 has 0 vertices" in w["message"] and "control cage" in w["message"]
                            for w in rss.warnings_for("/Small")), rss.warnings_for("/Small"))
        # the cages' triangles (the loader drops the zero-area ones, with a warning of its own)
        self.assertEqual(len(rss.mesh_named("/Loop")["indices"]), 2)
        self.assertEqual(len(rss.mesh_named("/CC")["indices"]), 4)
        for path, face in (("/Loop", "face 1 names a vertex twice (1 1 3)"), ("/CC", "face 1 names a vertex twice (0 1 1 2)")):
            self.assertTrue(any(face in w["message"] and "control cage" in w["message"] for w in rss.warnings_for(path)),
                            rss.warnings_for(path))

    def test_negative_sharpness_reads_as_smooth_with_a_warning(self):
        # a negative sharpness is no sharpness (OpenSubdiv's reading): the same surface as untagged
        st = self.stage()
        self.cube(st, "/Plain")
        k = self.cube(st, "/Negative")
        k.CreateCreaseIndicesAttr([0, 1])
        k.CreateCreaseLengthsAttr([2])
        k.CreateCreaseSharpnessesAttr([-3.0])
        k.CreateCornerIndicesAttr([6])
        k.CreateCornerSharpnessesAttr([-1.0])
        rss = self.convert(st)
        self.assertEqual(rss.mesh_named("/Plain")["positions"], rss.mesh_named("/Negative")["positions"])
        self.assertTrue(any("2 crease or corner sharpnesses are negative (the least -3)" in w["message"]
                            for w in rss.warnings_for("/Negative")), rss.warnings_for("/Negative"))
        self.assertFalse(rss.warnings_for("/Plain"))

    def test_bad_subdivision_tags_and_levels(self):
        st = self.stage()
        self.cube(st).CreateCornerIndicesAttr([42])
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Cube", r.stderr)
        self.assertIn("out of range", r.stderr)
        # a NaN crease sharpness (which the edge table's max with 0 used to swallow)
        st = self.stage("nan.usda")
        c = self.cube(st)
        c.CreateCreaseIndicesAttr([0, 1])
        c.CreateCreaseLengthsAttr([2])
        c.CreateCreaseSharpnessesAttr([float("nan")])
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Cube", r.stderr)
        self.assertIn("non-finite sharpnesses", r.stderr)
        # crease arrays that do not fit together (they raised IndexError, a traceback)
        for name, lengths, sharp, what in (("short.usda", [2, 2], [], "0 creaseSharpnesses for 2 creases"),
                                           ("long.usda", [2, 3], [1.0, 1.0], "add up to 5 where creaseIndices has 4")):
            st = self.stage(name)
            c = self.cube(st)
            c.CreateCreaseIndicesAttr([0, 1, 2, 3])
            c.CreateCreaseLengthsAttr(lengths)
            c.CreateCreaseSharpnessesAttr(sharp)
            r = self.convert(st, expect_ok=False)
            self.assertEqual(r.rc, 2, r.stderr)
            self.assertIn("/Cube", r.stderr)
            self.assertIn(what, r.stderr)
            self.assertNotIn("Traceback", r.stderr)
        r = self.convert(expect_ok=False, args=("--subdivision-level", "99"))
        self.assertEqual(r.rc, 2, r.stderr)
        r = self.convert(expect_ok=False, args=("--subdivision-level", "-1"))
        self.assertEqual(r.rc, 2, r.stderr)

    def curves(self, st, path, points, counts, **kw):
        c = UsdGeom.BasisCurves.Define(st, path)
        c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
        c.CreateCurveVertexCountsAttr(Vt.IntArray(list(counts)))
        for name in ("type", "basis", "wrap"):
            if name in kw:
                c.GetPrim().GetAttribute(name).Set(kw[name])
        if "widths" in kw:
            c.CreateWidthsAttr(Vt.FloatArray(kw["widths"]))
            c.SetWidthsInterpolation(kw.get("interp", "vertex"))
        return c

    def ring_centres(self, m, sides=6, capped=True):
        """The centres of a one-curve tube's rings (an open tube's two end discs left out)."""
        p = m["positions"]
        if capped:
            p = p[:len(p) - 2 * (sides + 1)]
        return [tuple(sum(p[i + j][k] for j in range(sides)) / sides for k in range(3)) for i in range(0, len(p), sides)]

    def test_linear_curves_become_tubes_of_their_width(self):
        st = self.stage()
        self.curves(st, "/Hair", [(0, 0, 0), (1, 0, 0), (2, 0, 0)], [3], type="linear", widths=[0.2], interp="constant")
        self.curves(st, "/Loop", [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)], [4], type="linear", wrap="periodic",
                    widths=[0.1, 0.1, 0.3, 0.3], interp="vertex")
        rss = self.convert(st)
        m = rss.mesh_named("/Hair")
        # three rings, then a disc (centre and ring) at each end
        self.assertEqual(len(m["positions"]), 3 * 6 + 2 * 7)
        self.assertEqual(len(m["indices"]), 2 * 6 * 2 + 2 * 6)
        for p, n in zip(m["positions"][:18], m["normals"][:18]):
            self.assertAlmostEqual(math.hypot(p[1], p[2]), 0.1, places=5)
            self.assertGreater(n[1] * p[1] + n[2] * p[2], 0.09)
        for t in m["indices"][:24]:
            a, b, c = (m["positions"][i] for i in t)
            centre = [(a[k] + b[k] + c[k]) / 3 for k in range(3)]
            self.assertGreater(tri_normal(a, b, c)[1] * centre[1] + tri_normal(a, b, c)[2] * centre[2], 0)
        # the discs close the ends at x = 0 and x = 2, facing out of the tube, flat-shaded
        for t in m["indices"][24:]:
            a, b, c = (m["positions"][i] for i in t)
            x = a[0]
            self.assertTrue(abs(x) < 1e-6 or abs(x - 2) < 1e-6, t)
            self.assertTrue(all(abs(q[0] - x) < 1e-6 for q in (b, c)))
            self.assertVec(tri_normal(a, b, c), (1 if x > 1 else -1, 0, 0))
            for i in t:
                self.assertVec(m["normals"][i], (1 if x > 1 else -1, 0, 0))
        loop = rss.mesh_named("/Loop")
        self.assertEqual(len(loop["indices"]), 4 * 6 * 2, "a periodic curve's tube closes, without discs")
        radii = [max(math.dist(p, c) for p in loop["positions"][6 * i:6 * i + 6]) for i, c in enumerate(self.ring_centres(loop, capped=False))]
        self.assertEqual([round(r, 4) for r in radii], [0.05, 0.05, 0.15, 0.15])

    def test_cubic_curves_follow_their_basis(self):
        st = self.stage()
        cv = [(0, 0, 0), (1, 2, 0), (3, 2, 0), (4, 0, 0)]
        self.curves(st, "/Bezier", cv, [4], widths=[0.01], interp="constant")
        self.curves(st, "/Pinned", cv, [4], basis="bspline", wrap="pinned", widths=[0.01, 0.02, 0.03], interp="varying")
        self.curves(st, "/Open", cv, [4], basis="catmullRom", widths=[0.01], interp="constant")
        rss = self.convert(st)
        bez = self.ring_centres(rss.mesh_named("/Bezier"))
        self.assertEqual(len(bez), 5)
        self.assertVec(bez[0], cv[0])
        self.assertVec(bez[2], (2.0, 1.5, 0.0))  # (P0 + 3 P1 + 3 P2 + P3) / 8
        self.assertVec(bez[4], cv[3])
        pinned = self.ring_centres(rss.mesh_named("/Pinned"))
        self.assertEqual(len(pinned), 3 * 4 + 1)
        self.assertVec(pinned[0], cv[0])  # pinned: the ends interpolated
        self.assertVec(pinned[-1], cv[3])
        # catmullRom, nonperiodic: one segment from P1 to P2
        cr = self.ring_centres(rss.mesh_named("/Open"))
        self.assertVec(cr[0], cv[1])
        self.assertVec(cr[-1], cv[2])

    def test_points_become_spheres_and_curves_take_vertex_colours(self):
        st = self.stage()
        pts = UsdGeom.Points.Define(st, "/Dots")
        pts.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(5, 0, 0)]))
        pts.CreateWidthsAttr(Vt.FloatArray([0.2, 0.4]))
        pts.SetWidthsInterpolation("vertex")
        c = self.curves(st, "/Hair", [(0, 0, 0), (0, 1, 0)], [2], type="linear", widths=[0.1], interp="constant")
        c.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 0, 1)]))
        rss = self.convert(st)
        dots = rss.mesh_named("/Dots")
        self.assertEqual(len(dots["indices"]), 2 * 80)
        half = len(dots["positions"]) // 2
        for k, (centre, r) in enumerate((((0, 0, 0), 0.1), ((5, 0, 0), 0.2))):
            for p in dots["positions"][k * half:(k + 1) * half]:
                self.assertAlmostEqual(math.dist(p, centre), r, places=5)
        hair = rss.mesh_named("/Hair")
        self.assertEqual(hair["colors"][:6], [(1.0, 0.0, 0.0)] * 6)
        self.assertEqual(hair["colors"][6:12], [(0.0, 0.0, 1.0)] * 6)
        # the end discs take their end's colour
        self.assertEqual(hair["colors"][12:], [(1.0, 0.0, 0.0)] * 7 + [(0.0, 0.0, 1.0)] * 7)
        self.assertFalse(rss.warnings_for("/Hair"), rss.warnings_for("/Hair"))

    def test_nurbs_curves_and_patches_are_tessellated(self):
        st = self.stage()
        # a rational quadratic quarter circle of radius 1
        c = UsdGeom.NurbsCurves.Define(st, "/Arc")
        c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(1, 1, 0), Gf.Vec3f(0, 1, 0)]))
        c.CreateCurveVertexCountsAttr(Vt.IntArray([3]))
        c.CreateOrderAttr(Vt.IntArray([3]))
        c.CreateKnotsAttr(Vt.DoubleArray([0, 0, 0, 1, 1, 1]))
        c.CreatePointWeightsAttr(Vt.DoubleArray([1, math.sqrt(0.5), 1]))
        c.CreateWidthsAttr(Vt.FloatArray([0.02]))
        c.SetWidthsInterpolation("constant")
        # a bicubic Bezier patch: a 4 x 4 grid on z = 0 with the inner four points raised to 1
        p = UsdGeom.NurbsPatch.Define(st, "/Patch")
        p.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(i, j, 1.0 if 0 < i < 3 and 0 < j < 3 else 0.0)
                                          for j in range(4) for i in range(4)]))
        p.CreateUVertexCountAttr(4)
        p.CreateVVertexCountAttr(4)
        p.CreateUOrderAttr(4)
        p.CreateVOrderAttr(4)
        p.CreateUKnotsAttr(Vt.DoubleArray([0, 0, 0, 0, 1, 1, 1, 1]))
        p.CreateVKnotsAttr(Vt.DoubleArray([0, 0, 0, 0, 1, 1, 1, 1]))
        rss = self.convert(st)
        for centre in self.ring_centres(rss.mesh_named("/Arc")):
            self.assertAlmostEqual(math.hypot(centre[0], centre[1]), 1.0, places=5)
        m = rss.mesh_named("/Patch")
        self.assertEqual(len(m["indices"]), 8 * 8 * 2)
        top = max(m["positions"], key=lambda q: q[2])
        self.assertVec(top, (1.5, 1.5, 0.5625))  # (B1 + B2)(1/2)^2 = (3/4)^2
        self.assertIn((0.5, 0.5), {tuple(round(x, 5) for x in u) for u in m["uvs"]})
        for q, n in zip(m["positions"], m["normals"]):
            self.assertGreater(n[2], 0.3)  # dP/du x dP/dv: +z
        # a knot vector of the wrong length is an error naming the prim
        p.CreateUKnotsAttr(Vt.DoubleArray([0, 0, 1, 1]))
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Patch", r.stderr)
        self.assertIn("4 knots", r.stderr)

    def test_nurbs_ranges_outside_the_knots_are_errors(self):
        # a range must lie within [knots[order - 1], knots[count]] (the schema's rule); below it the
        # span search found no span and never returned
        for kind in ("curve", "patch"):
            st = self.stage("%s.usda" % kind)
            if kind == "curve":
                c = UsdGeom.NurbsCurves.Define(st, "/Bad")
                c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(i, i % 2, 0) for i in range(5)]))
                c.CreateCurveVertexCountsAttr(Vt.IntArray([5]))
                c.CreateOrderAttr(Vt.IntArray([3]))
                c.CreateKnotsAttr(Vt.DoubleArray([0, 0, 1, 2, 2, 3, 3, 3]))
                c.CreateRangesAttr(Vt.Vec2dArray([Gf.Vec2d(-0.1, 1.1)]))
                c.CreateWidthsAttr(Vt.FloatArray([0.02]))
                c.SetWidthsInterpolation("constant")
            else:
                p = UsdGeom.NurbsPatch.Define(st, "/Bad")
                p.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(i, j, 0) for j in range(2) for i in range(2)]))
                p.CreateUVertexCountAttr(2)
                p.CreateVVertexCountAttr(2)
                p.CreateUOrderAttr(2)
                p.CreateVOrderAttr(2)
                p.CreateUKnotsAttr(Vt.DoubleArray([0, 0, 1, 1]))
                p.CreateVKnotsAttr(Vt.DoubleArray([0, 0, 1, 1]))
                p.CreateURangeAttr(Gf.Vec2d(0, 1.5))
            r = self.convert(st, expect_ok=False)
            self.assertEqual(r.rc, 2, (kind, r.stderr))
            self.assertIn("/Bad", r.stderr)
            self.assertIn("outside the knots' domain", r.stderr)

    def test_tet_meshes_render_their_surface(self):
        # two tetrahedra sharing a face: the shared face is inside, the other six outside, facing out
        st = self.stage()
        m = UsdGeom.TetMesh.Define(st, "/Tets")
        pts = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)]
        m.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in pts]))
        m.CreateTetVertexIndicesAttr(Vt.Vec4iArray([Gf.Vec4i(0, 1, 2, 3), Gf.Vec4i(1, 2, 3, 4)]))
        out = self.convert(st).mesh_named("/Tets")
        self.assertEqual(len(out["indices"]), 6)
        centre = [sum(p[k] for p in pts) / len(pts) for k in range(3)]
        for t in out["indices"]:
            a, b, c = (out["positions"][i] for i in t)
            mid = [(a[k] + b[k] + c[k]) / 3 - centre[k] for k in range(3)]
            self.assertGreater(sum(x * y for x, y in zip(tri_normal(a, b, c), mid)), 0)

    def test_hermite_curves_follow_their_tangents(self):
        st = self.stage()
        h = UsdGeom.HermiteCurves.Define(st, "/Hermite")
        h.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0)]))
        h.CreateTangentsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 2, 0), Gf.Vec3f(0, 2, 0)]))
        h.CreateCurveVertexCountsAttr(Vt.IntArray([2]))
        h.CreateWidthsAttr(Vt.FloatArray([0.01]))
        h.SetWidthsInterpolation("constant")
        centres = self.ring_centres(self.convert(st).mesh_named("/Hermite"))
        self.assertEqual(len(centres), 5)
        # t = 1/4: h01 = 5/32 along x, (h10 + h11) · 2 = 3/16 along y
        self.assertVec(centres[1], (0.15625, 0.1875, 0.0))
        self.assertVec(centres[2], (0.5, 0.0, 0.0))
        h.CreateTangentsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 2, 0)]))
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Hermite", r.stderr)
        self.assertIn("1 tangents for 2 points", r.stderr)

    def test_bad_curves_are_errors_naming_the_prim(self):
        for case, (kw, msg) in enumerate((({"points": [(0, 0, 0), (1, 0, 0)], "counts": [3]}, "curveVertexCounts sum to 3"),
                        ({"points": [(0, 0, 0)] * 5, "counts": [5]}, "nonperiodic cubic bezier"),
                        ({"points": [(0, 0, 0), (1, 0, 0)], "counts": [2], "type": "linear", "widths": [-1],
                          "interp": "constant"}, "negative"))):
            with self.subTest(msg=msg):
                st = self.stage("bad%d.usda" % case)
                args = dict(kw)
                self.curves(st, "/Bad", args.pop("points"), args.pop("counts"), **args)
                r = self.convert(st, expect_ok=False)
                self.assertEqual(r.rc, 2, r.stderr)
                self.assertIn("/Bad", r.stderr)
                self.assertIn(msg, r.stderr)

    def test_nan_points_still_convert(self):
        st = self.stage()
        add_mesh(st, "/Tri", [(0, 0, 0), (1, 0, 0), (0, float("nan"), 0)], [3], [0, 1, 2])
        rss = self.convert(st)
        p = rss.mesh_named("/Tri")["positions"]
        self.assertTrue(math.isnan(p[2][1]))

    def test_out_of_range_index_is_exit_2(self):
        st = self.stage()
        add_mesh(st, "/Tri", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 7])
        st.GetRootLayer().Save()
        r = self.convert(expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Tri", r.stderr)
        self.assertIn(str(self.path), r.stderr)
        self.assertFalse(r.out.exists())

    def test_gprims_are_tessellated(self):
        st = self.stage()
        c = UsdGeom.Cube.Define(st, "/Cube")
        c.CreateSizeAttr(2.0)
        s = UsdGeom.Sphere.Define(st, "/Sphere")
        s.CreateRadiusAttr(0.5)
        cy = UsdGeom.Cylinder.Define(st, "/Cyl")
        cy.CreateAxisAttr("Y")
        UsdGeom.Cone.Define(st, "/Cone")
        UsdGeom.Capsule.Define(st, "/Capsule")
        UsdGeom.Plane.Define(st, "/Plane")
        UsdVol.Volume.Define(st, "/Curves")
        UsdGeom.BasisCurves.Define(st, "/Empty")
        rss = self.convert(st)
        cube = rss.mesh_named("/Cube")
        self.assertEqual(len(cube["indices"]), 12)
        for k in range(3):
            self.assertAlmostEqual(max(p[k] for p in cube["positions"]), 1.0)
            self.assertAlmostEqual(min(p[k] for p in cube["positions"]), -1.0)
        for t in cube["indices"]:  # outward winding
            a, b, cc = [cube["positions"][i] for i in t]
            n = tri_normal(a, b, cc)
            centre = [(a[i] + b[i] + cc[i]) / 3 for i in range(3)]
            self.assertGreater(sum(n[i] * centre[i] for i in range(3)), 0)
        sph = rss.mesh_named("/Sphere")
        for p in sph["positions"]:
            self.assertAlmostEqual(math.sqrt(sum(x * x for x in p)), 0.5, places=5)
        for t in sph["indices"]:
            a, b, cc = [sph["positions"][i] for i in t]
            n = tri_normal(a, b, cc)
            centre = [(a[i] + b[i] + cc[i]) / 3 for i in range(3)]
            self.assertGreater(sum(n[i] * centre[i] for i in range(3)), 0)
        cyl = rss.mesh_named("/Cyl")
        self.assertAlmostEqual(max(p[1] for p in cyl["positions"]), 1.0)  # height 2 along Y
        self.assertAlmostEqual(max(p[0] for p in cyl["positions"]), 1.0)
        for name in ("/Cone", "/Capsule", "/Plane"):
            self.assertGreater(len(rss.mesh_named(name)["indices"]), 1)
        self.assertTrue(any("not supported" in w["message"] for w in rss.warnings_for("/Curves")))
        self.assertTrue(any("has no points" in w["message"] for w in rss.warnings_for("/Empty")))


# ----------------------------------------------------------------------------------------------------
# Stage metrics, transforms and instancing
# ----------------------------------------------------------------------------------------------------


class TransformTests(Case):
    def test_zero_scale_hides_a_prim_with_a_warning(self):
        st = self.stage()
        add_mesh(st, "/Shown", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [3], [0, 1, 2])
        hidden = UsdGeom.Xform.Define(st, "/Hidden")
        hidden.AddScaleOp().Set(Gf.Vec3f(0, 0, 0))
        add_mesh(st, "/Hidden/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [3], [0, 1, 2])
        flat = UsdGeom.Xform.Define(st, "/Flat")
        flat.AddScaleOp().Set(Gf.Vec3f(1, 0, 1))
        add_mesh(st, "/Flat/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [3], [0, 1, 2])
        camera(st)
        rss = self.convert(st)
        names = [i["name"] for i in rss["instances"]]
        self.assertIn("/Shown", names)
        self.assertNotIn("/Hidden/M", names)
        self.assertNotIn("/Flat/M", names)
        for p in ("/Hidden/M", "/Flat/M"):
            self.assertTrue(any("zero scale" in w["message"] for w in rss.warnings_for(p)), rss["warnings"])

    def test_zero_scale_instances_of_a_point_instancer_warn_once(self):
        st = self.stage()
        camera(st)
        pi = UsdGeom.PointInstancer.Define(st, "/PI")
        proto = add_mesh(st, "/PI/Protos/T", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [3], [0, 1, 2])
        pi.CreatePrototypesRel().SetTargets([proto.GetPath()])
        pi.CreateProtoIndicesAttr(Vt.IntArray([0] * 10))
        pi.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(2 * i, 0, 0) for i in range(10)]))
        pi.CreateScalesAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0) if i % 2 else Gf.Vec3f(1, 1, 1) for i in range(10)]))
        rss = self.convert(st)
        self.assertEqual(len(rss["instances"]), 5)
        zero = [w for w in rss["warnings"] if "zero scale" in w["message"]]
        self.assertEqual(len(zero), 1, zero)
        self.assertEqual(zero[0]["prim"], "/PI/Protos/T")
        self.assertIn("5 instances", zero[0]["message"])

    def test_zero_scale_hides_a_light_with_a_warning(self):
        st = self.stage()
        add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [3], [0, 1, 2])
        camera(st)
        shown = UsdLux.SphereLight.Define(st, "/Shown")
        shown.CreateIntensityAttr(5.0)
        for path, scale in (("/Hidden", (0, 0, 0)), ("/Flat", (1, 0, 1))):
            hidden = UsdLux.RectLight.Define(st, path)
            hidden.CreateIntensityAttr(5.0)
            UsdGeom.Xformable(hidden.GetPrim()).AddScaleOp().Set(Gf.Vec3f(*scale))
        rss = self.convert(st)
        self.assertEqual([l["name"] for l in rss["lights"]], ["/Shown"])
        for p in ("/Hidden", "/Flat"):
            self.assertTrue(any("zero scale" in w["message"] for w in rss.warnings_for(p)), rss["warnings"])

    def test_meters_per_unit_scales_transforms_lights_and_camera(self):
        st = self.stage(mpu=0.01)
        x = UsdGeom.Xform.Define(st, "/X")
        x.AddTranslateOp().Set(Gf.Vec3d(100, 0, 0))
        quad(st, "/X/M")
        light = UsdLux.RectLight.Define(st, "/L")
        light.CreateWidthAttr(200.0)
        light.CreateHeightAttr(50.0)
        light.AddTranslateOp().Set(Gf.Vec3d(0, 300, 0))
        sph = UsdLux.SphereLight.Define(st, "/S")
        sph.CreateRadiusAttr(10.0)
        cam = camera(st, z=500)
        cam.CreateClippingRangeAttr(Gf.Vec2f(1, 10000))
        rss = self.convert(st)
        inst = rss.instances_of("/X/M")[0]
        self.assertVec(apply(inst["transform"], (1, 1, 0)), (1.01, 0.01, 0))
        l = rss.light("/L")
        self.assertAlmostEqual(l["width"], 2.0)
        self.assertAlmostEqual(l["height"], 0.5)
        self.assertVec(l["transform"][3], (0, 3, 0, 1))
        self.assertAlmostEqual(rss.light("/S")["radius"], 0.1)
        c = rss["camera"]
        self.assertVec(c["clipping"], (0.01, 100.0), tol=1e-6)
        self.assertVec(c["transform"][3], (0, 0, 5, 1))
        self.assertEqual(rss["stage"], {"meters_per_unit": 0.01, "up_axis": "Y", "time": None, "time_range": None,
                                        "cameras": ["/Cam"]})

    def test_unauthored_meters_per_unit_warns_and_uses_centimetres(self):
        st = self.stage(mpu=None)
        quad(st, "/M", size=100)
        rss = self.convert(st)
        self.assertVec(apply(rss["instances"][0]["transform"], (100, 0, 0)), (1, 0, 0))
        self.assertTrue(any("metersPerUnit" in w["message"] for w in rss["warnings"]))

    def test_up_axis_z_is_rotated_to_y(self):
        st = self.stage(up="Z")
        add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (0, 0, 1)], [3], [0, 1, 2])
        d = UsdLux.DistantLight.Define(st, "/Sun")  # default: shines along local -Z = straight down in Z-up
        cam = camera(st, z=10)
        rss = self.convert(st)
        t = rss["instances"][0]["transform"]
        self.assertVec(apply(t, (0, 0, 1)), (0, 1, 0))
        self.assertVec(apply(t, (0, 1, 0)), (0, 0, -1))
        self.assertVec(apply(t, (1, 0, 0)), (1, 0, 0))
        self.assertVec(rss.light("/Sun")["direction"], (0, -1, 0))
        self.assertVec(rss["camera"]["transform"][3], (0, 10, 0, 1))
        self.assertEqual(rss["stage"]["up_axis"], "Z")

    def test_native_instancing_shares_one_mesh(self):
        proto = self.dir / "proto.usda"
        ps = new_stage(proto)
        root = UsdGeom.Xform.Define(ps, "/P")
        ps.SetDefaultPrim(root.GetPrim())
        quad(ps, "/P/Geo")
        ps.GetRootLayer().Save()
        st = self.stage()
        for i, name in enumerate(("A", "B")):
            x = UsdGeom.Xform.Define(st, "/" + name)
            x.GetPrim().GetReferences().AddReference(str(proto))
            x.GetPrim().SetInstanceable(True)
            x.AddTranslateOp().Set(Gf.Vec3d(10 * i, 0, 0))
        rss = self.convert(st)
        self.assertEqual(len(rss["meshes"]), 1)
        self.assertEqual(len(rss["instances"]), 2)
        names = sorted(i["name"] for i in rss["instances"])
        self.assertEqual(names, ["/A/Geo", "/B/Geo"])
        xs = sorted(apply(i["transform"], (0, 0, 0))[0] for i in rss["instances"])
        self.assertVec(xs, (0, 10))
        self.assertEqual(self.result.summary["triangles"], 4)

    def test_payloads_are_loaded_and_variant_selection_is_honoured(self):
        asset = self.dir / "asset.usda"
        a = new_stage(asset)
        root = UsdGeom.Xform.Define(a, "/Asset")
        a.SetDefaultPrim(root.GetPrim())
        vs = root.GetPrim().GetVariantSets().AddVariantSet("shape")
        for name, n in (("tri", 3), ("quad", 4)):
            vs.AddVariant(name)
            vs.SetVariantSelection(name)
            with vs.GetVariantEditContext():
                pts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)][:n]
                add_mesh(a, "/Asset/" + name.capitalize(), pts, [n], list(range(n)))
        vs.SetVariantSelection("tri")
        a.GetRootLayer().Save()
        st = self.stage()
        p = UsdGeom.Xform.Define(st, "/P")
        p.GetPrim().GetPayloads().AddPayload(str(asset))
        p.GetPrim().GetVariantSets().GetVariantSet("shape").SetVariantSelection("quad")
        rss = self.convert(st)
        self.assertEqual([i["name"] for i in rss["instances"]], ["/P/Quad"])
        self.assertEqual(rss.triangles(), 2)

    def test_point_instancer(self):
        st = self.stage()
        pi = UsdGeom.PointInstancer.Define(st, "/PI")
        UsdGeom.Scope.Define(st, "/PI/Protos")
        quad(st, "/PI/Protos/Q")
        add_mesh(st, "/PI/Protos/T", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
        pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Q", "/PI/Protos/T"])
        pi.CreateProtoIndicesAttr([0, 1, 0])
        pi.CreatePositionsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(5, 0, 0), Gf.Vec3f(0, 5, 0)]))
        rot = Gf.Quath(Gf.Rotation(Gf.Vec3d(0, 0, 1), 90).GetQuat())
        pi.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(1), Gf.Quath(1), rot]))
        pi.CreateScalesAttr(Vt.Vec3fArray([Gf.Vec3f(1), Gf.Vec3f(2), Gf.Vec3f(1)]))
        rss = self.convert(st)
        self.assertEqual(len(rss["meshes"]), 2, "one mesh per prototype")
        self.assertEqual(len(rss["instances"]), 3)
        by_name = {i["name"]: i for i in rss["instances"]}
        self.assertEqual(set(by_name), {"/PI/Protos/Q[0]", "/PI/Protos/T[1]", "/PI/Protos/Q[2]"})
        self.assertVec(apply(by_name["/PI/Protos/T[1]"]["transform"], (1, 0, 0)), (7, 0, 0))
        self.assertVec(apply(by_name["/PI/Protos/Q[2]"]["transform"], (1, 0, 0)), (0, 6, 0), tol=1e-3)
        self.assertEqual(self.result.summary["triangles"], 2 + 1 + 2)
        # invisibleIds hide instance 1
        pi.CreateInvisibleIdsAttr([1])
        rss = self.convert(st)
        self.assertEqual(sorted(i["name"] for i in rss["instances"]), ["/PI/Protos/Q[0]", "/PI/Protos/Q[2]"])

    def test_visibility_and_purpose(self):
        st = self.stage()
        quad(st, "/Visible")
        quad(st, "/Invisible").CreateVisibilityAttr("invisible")
        x = UsdGeom.Xform.Define(st, "/Hidden")
        x.CreateVisibilityAttr("invisible")
        quad(st, "/Hidden/Child")
        quad(st, "/Guide").CreatePurposeAttr("guide")
        quad(st, "/Proxy").CreatePurposeAttr("proxy")
        quad(st, "/Render").CreatePurposeAttr("render")
        g = UsdGeom.Xform.Define(st, "/GuideGroup")
        g.CreatePurposeAttr("guide")
        quad(st, "/GuideGroup/Inherits")
        rss = self.convert(st)
        names = sorted(i["name"] for i in rss["instances"])
        self.assertEqual(names, ["/Render", "/Visible"])

    def test_transform_time_samples_use_the_first_sample(self):
        st = self.stage()
        x = UsdGeom.Xform.Define(st, "/X")
        op = x.AddTranslateOp()
        op.Set(Gf.Vec3d(3, 0, 0), 1.0)
        op.Set(Gf.Vec3d(9, 0, 0), 2.0)
        quad(st, "/X/M")
        rss = self.convert(st)
        self.assertVec(apply(rss["instances"][0]["transform"], (0, 0, 0)), (3, 0, 0))


# ----------------------------------------------------------------------------------------------------
# Lights
# ----------------------------------------------------------------------------------------------------


class LightTests(Case):
    def light_scene(self, **kw):
        st = self.stage(**kw)
        quad(st, "/Floor")
        return st

    def test_intensity_with_and_without_inputs_prefix(self):
        st = self.light_scene()
        a = UsdLux.RectLight.Define(st, "/New")
        a.CreateIntensityAttr(3.0)
        b = UsdLux.RectLight.Define(st, "/Old")
        b.GetPrim().CreateAttribute("intensity", Sdf.ValueTypeNames.Float).Set(5.0)
        b.GetPrim().CreateAttribute("color", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 0.5, 0.25))
        b.GetPrim().CreateAttribute("width", Sdf.ValueTypeNames.Float).Set(2.0)
        c = UsdLux.RectLight.Define(st, "/Both")
        c.CreateIntensityAttr(7.0)
        c.GetPrim().CreateAttribute("intensity", Sdf.ValueTypeNames.Float).Set(11.0)
        rss = self.convert(st)
        self.assertVec(rss.light("/New")["radiance"], (3, 3, 3))
        self.assertVec(rss.light("/Old")["radiance"], (5, 2.5, 1.25))
        self.assertAlmostEqual(rss.light("/Old")["width"], 2.0)
        self.assertVec(rss.light("/Both")["radiance"], (7, 7, 7), msg="inputs: wins when both are authored")

    def test_an_exposure_beyond_float_range_is_an_error_naming_the_light(self):
        # 2^exposure overflows for exposure > ~1024 stops (it raised OverflowError, a traceback)
        st = self.light_scene()
        a = UsdLux.RectLight.Define(st, "/Blinding")
        a.CreateExposureAttr(1e30)
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Blinding", r.stderr)
        self.assertIn("NaN or infinite", r.stderr)
        self.assertNotIn("Traceback", r.stderr)

    def test_a_non_finite_color_temperature_is_an_error_naming_the_light(self):
        # NaN reached usd-core's blackbody table, which crashed the converter (SIGSEGV)
        for name, temp in (("nan.usda", float("nan")), ("inf.usda", float("inf"))):
            st = self.light_scene(name=name)
            a = UsdLux.DiskLight.Define(st, "/Warm")
            a.CreateEnableColorTemperatureAttr(True)
            a.CreateColorTemperatureAttr(temp)
            r = self.convert(st, expect_ok=False)
            self.assertEqual(r.rc, 2, r.stderr)
            self.assertIn("/Warm", r.stderr)
            self.assertIn("not a finite temperature", r.stderr)

    def test_normalize_divides_by_world_area_in_square_metres(self):
        st = self.light_scene(mpu=0.5)
        r = UsdLux.RectLight.Define(st, "/Rect")
        r.CreateWidthAttr(2.0)
        r.CreateHeightAttr(3.0)
        r.CreateIntensityAttr(6.0)
        r.CreateNormalizeAttr(True)
        r.AddScaleOp().Set(Gf.Vec3f(2, 1, 1))
        d = UsdLux.DiskLight.Define(st, "/Disk")
        d.CreateRadiusAttr(1.0)
        d.CreateNormalizeAttr(True)
        s = UsdLux.SphereLight.Define(st, "/Sphere")
        s.CreateRadiusAttr(2.0)
        s.CreateNormalizeAttr(True)
        u = UsdLux.RectLight.Define(st, "/Unnormalized")
        u.CreateWidthAttr(4.0)
        u.CreateIntensityAttr(6.0)
        rss = self.convert(st)
        rect = rss.light("/Rect")
        # world size: 2*2*0.5 = 2 m by 3*0.5 = 1.5 m -> area 3 m^2
        self.assertAlmostEqual(rect["width"], 2.0)
        self.assertAlmostEqual(rect["height"], 1.5)
        self.assertVec(rect["radiance"], (2, 2, 2))
        self.assertVec(rss.light("/Disk")["radiance"], [1 / (math.pi * 0.25)] * 3)
        self.assertVec(rss.light("/Sphere")["radiance"], [1 / (4 * math.pi * 1.0)] * 3)
        self.assertVec(rss.light("/Unnormalized")["radiance"], (6, 6, 6))

    def test_exposure(self):
        st = self.light_scene()
        l = UsdLux.SphereLight.Define(st, "/L")
        l.CreateIntensityAttr(3.0)
        l.CreateExposureAttr(2.0)
        l.CreateColorAttr(Gf.Vec3f(1, 0.5, 0))
        rss = self.convert(st)
        self.assertVec(rss.light("/L")["radiance"], (12, 6, 0))

    def test_color_temperature(self):
        st = self.light_scene()
        for name, k in (("/K6500", 6500.0), ("/K3000", 3000.0)):
            l = UsdLux.DiskLight.Define(st, name)
            l.CreateEnableColorTemperatureAttr(True)
            l.CreateColorTemperatureAttr(k)
        off = UsdLux.DiskLight.Define(st, "/Off")
        off.CreateColorTemperatureAttr(3000.0)
        rss = self.convert(st)
        w = rss.light("/K6500")["radiance"]
        warm = rss.light("/K3000")["radiance"]
        lum = lambda c: 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
        self.assertAlmostEqual(lum(w), 1.0, places=4)
        self.assertAlmostEqual(lum(warm), 1.0, places=4)
        self.assertLess(max(w) / min(w), 1.1, "6500 K is close to white")
        self.assertTrue(warm[0] > warm[1] > warm[2], "3000 K is reddish: %s" % (warm,))
        self.assertVec(rss.light("/Off")["radiance"], (1, 1, 1))

    def test_spot_cone(self):
        st = self.light_scene()
        l = UsdLux.SphereLight.Define(st, "/Spot")
        l.CreateRadiusAttr(0.1)
        sh = UsdLux.ShapingAPI.Apply(l.GetPrim())
        sh.CreateShapingConeAngleAttr(30.0)
        sh.CreateShapingConeSoftnessAttr(0.2)
        sh.CreateShapingFocusAttr(2.0)
        UsdLux.SphereLight.Define(st, "/Bulb")
        rss = self.convert(st)
        self.assertEqual(rss.light("/Spot")["cone"], {"angle_deg": 30.0, "softness": 0.20000000298023224, "focus": 2.0})
        self.assertIsNone(rss.light("/Bulb")["cone"])

    def test_treat_as_point_keeps_intensity(self):
        st = self.light_scene()
        l = UsdLux.SphereLight.Define(st, "/P")
        l.CreateRadiusAttr(0.5)
        l.CreateTreatAsPointAttr(True)
        l.CreateIntensityAttr(2.0)
        rss = self.convert(st)
        p = rss.light("/P")
        self.assertLessEqual(p["radius"], 1e-3)
        # radiant intensity L * pi r^2 equals the authored sphere's 2 * pi * 0.25
        self.assertAlmostEqual(p["radiance"][0] * math.pi * p["radius"] ** 2, 2 * math.pi * 0.25, places=6)

    def test_distant_light_direction_and_irradiance(self):
        st = self.light_scene()
        d = UsdLux.DistantLight.Define(st, "/Sun")
        d.AddRotateXOp().Set(-90.0)  # local -Z turned to -Y: shining straight down
        d.CreateIntensityAttr(3.0)
        d.CreateAngleAttr(1.0)
        d.CreateColorAttr(Gf.Vec3f(1, 0.5, 1))
        e = UsdLux.DistantLight.Define(st, "/Slanted")
        e.AddRotateYOp().Set(90.0)  # local -Z -> -X
        rss = self.convert(st)
        sun = rss.light("/Sun")
        self.assertVec(sun["direction"], (0, -1, 0))
        self.assertVec(sun["irradiance"], (3, 1.5, 3))
        self.assertAlmostEqual(sun["angle_deg"], 1.0)
        self.assertVec(rss.light("/Slanted")["direction"], (-1, 0, 0))
        self.assertVec(rss.light("/Slanted")["irradiance"], (50000, 50000, 50000), tol=1e-2)

    def test_dome_texture_and_orientation(self):
        st = self.light_scene()
        (self.dir / "sky.png").write_bytes(png_bytes(4, 2, (10, 20, 30)))
        dome = UsdLux.DomeLight.Define(st, "/Dome")
        dome.CreateTextureFileAttr("sky.png")
        dome.CreateIntensityAttr(0.5)
        rss = self.convert(st)
        d = rss.light("/Dome")
        tex = rss["textures"][d["texture"]]
        self.assertEqual(tex["path"], str((self.dir / "sky.png").resolve()))
        self.assertVec(d["radiance"], (0.5, 0.5, 0.5))
        # the renderer's map follows OpenEXR like USD's (local +Z at the centre, +Y up): no turn
        self.assertVec(apply(d["transform"], (0, 0, 1)), (0, 0, 1))
        self.assertVec(apply(d["transform"], (0, 1, 0)), (0, 1, 0))
        deps = {x["path"]: x["sha256"] for x in rss["dependencies"]}
        self.assertEqual(deps[tex["path"]], hashlib.sha256((self.dir / "sky.png").read_bytes()).hexdigest())

    def test_dome_light_1_pole_axis_follows_z_up_stage(self):
        st = self.light_scene(up="Z")
        UsdLux.DomeLight_1.Define(st, "/Dome")
        rss = self.convert(st)
        d = rss.light("/Dome")
        # the pole (+Y of the dome) is the stage's up axis, which is +Y after conversion
        self.assertVec(apply(d["transform"], (0, 1, 0)), (0, 1, 0))

    def test_unsupported_lights_warn(self):
        st = self.light_scene()
        UsdLux.CylinderLight.Define(st, "/Cyl")
        m = quad(st, "/Glow", z=1)
        UsdLux.MeshLightAPI.Apply(m.GetPrim())
        rss = self.convert(st)
        self.assertTrue(rss.warnings_for("/Cyl"))
        self.assertTrue(rss.warnings_for("/Glow"))
        self.assertEqual([l["name"] for l in rss["lights"]], [])

    def test_nan_light_is_exit_2(self):
        st = self.light_scene()
        UsdLux.RectLight.Define(st, "/Bad").CreateIntensityAttr(float("nan"))
        st.GetRootLayer().Save()
        r = self.convert(expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Bad", r.stderr)


# ----------------------------------------------------------------------------------------------------
# Materials and textures
# ----------------------------------------------------------------------------------------------------


class MaterialTests(Case):
    def test_texture_connection_scale_bias_wrap(self):
        st = self.stage()
        m = quad(st, "/M")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
        (self.dir / "tex").mkdir()
        (self.dir / "tex" / "albedo.png").write_bytes(png_bytes())
        mat, sh = preview(st, "/Looks/T", roughness=0.25, ior=1.33, clearcoat=0.5)
        tex = UsdShade.Shader.Define(st, "/Looks/T/Tex")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("./tex/albedo.png")
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("mirror")
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
        tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2, 2, 2, 1))
        tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1, -1, -1, 0))
        tex.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(0.5, 0.5, 0.5, 1))
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
        rd = UsdShade.Shader.Define(st, "/Looks/T/Reader")
        rd.CreateIdAttr("UsdPrimvarReader_float2")
        rd.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(rd.ConnectableAPI(), "result")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        sh.CreateInput("metallic", Sdf.ValueTypeNames.Float).ConnectToSource(tex.ConnectableAPI(), "b")
        sh.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        rss = self.convert(st)
        mm = rss.material("/Looks/T")
        self.assertEqual(mm["kind"], "preview_surface")
        t = rss["textures"][mm["diffuse_color"]["texture"]]
        self.assertEqual(t["path"], str((self.dir / "tex" / "albedo.png").resolve()))
        self.assertEqual((t["wrap_s"], t["wrap_t"]), ("mirror", "clamp"))
        self.assertEqual(t["scale"], [2, 2, 2, 1])
        self.assertEqual(t["bias"], [-1, -1, -1, 0])
        self.assertEqual(t["fallback"], [0.5, 0.5, 0.5, 1])
        self.assertEqual((t["color_space"], t["output"]), ("raw", "rgb"))
        # the renderer's warnings about the file name the shader that reads it
        self.assertEqual(t["prim"], "/Looks/T/Tex")
        tb = rss["textures"][mm["metallic"]["texture"]]
        self.assertEqual(tb["output"], "b")
        self.assertEqual(mm["normal_map"], mm["diffuse_color"]["texture"])
        self.assertAlmostEqual(mm["roughness"]["value"], 0.25)
        self.assertIsNone(mm["roughness"]["texture"])
        self.assertAlmostEqual(mm["ior"], 1.33, places=5)
        self.assertAlmostEqual(mm["clearcoat"]["value"], 0.5)
        self.assertIsNotNone(rss.mesh_named("/M")["uvs"])
        self.assertIn(t["path"], [d["path"] for d in rss["dependencies"]])

    def test_wrap_use_metadata_is_black_and_missing_texture_warns(self):
        st = self.stage()
        m = quad(st, "/M")
        mat, sh = preview(st, "/Looks/T")
        tex = UsdShade.Shader.Define(st, "/Looks/T/Tex")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("missing.png")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        rss = self.convert(st)
        t = rss["textures"][rss.material("/Looks/T")["diffuse_color"]["texture"]]
        self.assertEqual((t["wrap_s"], t["wrap_t"]), ("black", "black"))
        self.assertEqual(t["path"], str(self.dir / "missing.png"))
        self.assertTrue(any("missing.png" in w["message"] for w in rss.warnings_for("/Looks/T/Tex")))
        # recorded as a dependency without a hash, so the cache converts again once the file appears
        deps = {x["path"]: x["sha256"] for x in rss["dependencies"]}
        self.assertIsNone(deps[str(self.dir / "missing.png")])

    def test_texture_without_file_is_its_constant_fallback(self):
        st = self.stage()
        m = quad(st, "/M")
        mat, sh = preview(st, "/Looks/T")
        tex = UsdShade.Shader.Define(st, "/Looks/T/Tex")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(0.2, 0.3, 0.4, 0.9))
        sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        sh.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(tex.ConnectableAPI(), "a")
        bind(m, mat)
        rss = self.convert(st)
        mm = rss.material("/Looks/T")
        self.assertVec(mm["emissive_color"]["value"], (0.2, 0.3, 0.4))
        self.assertIsNone(mm["emissive_color"]["texture"])
        self.assertAlmostEqual(mm["opacity"]["value"], 0.9, places=6)
        self.assertEqual(rss["textures"], [])
        self.assertTrue(rss.warnings_for("/Looks/T/Tex"))

    def transform2d_material(self, nodes):
        """A textured quad whose texture's st passes through UsdTransform2d nodes (outermost first:
        `nodes` of (rotation, scale, translation)) from the `st` primvar reader."""
        st = self.stage()
        m = quad(st, "/M")
        (self.dir / "t.png").write_bytes(png_bytes())
        mat, sh = preview(st, "/Looks/T")
        tex = UsdShade.Shader.Define(st, "/Looks/T/Tex")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("t.png")
        rd = UsdShade.Shader.Define(st, "/Looks/T/Reader")
        rd.CreateIdAttr("UsdPrimvarReader_float2")
        rd.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
        outer = tex
        for k, (rot, scale, tr) in enumerate(nodes):
            xf = UsdShade.Shader.Define(st, "/Looks/T/Xf%d" % k)
            xf.CreateIdAttr("UsdTransform2d")
            xf.CreateInput("rotation", Sdf.ValueTypeNames.Float).Set(rot)
            xf.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*scale))
            xf.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*tr))
            name = "st" if outer is tex else "in"
            outer.CreateInput(name, Sdf.ValueTypeNames.Float2).ConnectToSource(xf.ConnectableAPI(), "result")
            outer = xf
        outer.CreateInput("st" if outer is tex else "in", Sdf.ValueTypeNames.Float2).ConnectToSource(
            rd.ConnectableAPI(), "result")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        return st

    def test_transform2d_maps_the_texture_coordinates(self):
        # scale, then rotate counter-clockwise, then translate (the spec's order)
        rss = self.convert(self.transform2d_material([(90.0, (4.0, 2.0), (0.5, 0.25))]))
        (t,) = rss["textures"]
        m = t["st_transform"]
        apply2 = lambda m, p: (m[0][0] * p[0] + m[0][1] * p[1] + m[0][2], m[1][0] * p[0] + m[1][1] * p[1] + m[1][2])
        self.assertVec(apply2(m, (1, 0)), (0.5, 4.25))  # (4, 0) turned to (0, 4), moved
        self.assertVec(apply2(m, (0, 1)), (-1.5, 0.25))  # (0, 2) turned to (-2, 0), moved
        self.assertFalse(rss.warnings_for("/Looks/T/Xf0"))
        # a chain applies the node nearest the reader first
        rss = self.convert(self.transform2d_material([(0.0, (1.0, 1.0), (1.0, 0.0)), (0.0, (3.0, 3.0), (0.0, 0.0))]))
        self.assertVec(apply2(rss["textures"][0]["st_transform"], (1, 1)), (4.0, 3.0))  # scaled, then moved
        # the identity leaves the texture as it was (no st_transform written)
        rss = self.convert(self.transform2d_material([(0.0, (1.0, 1.0), (0.0, 0.0))]))
        self.assertNotIn("st_transform", rss["textures"][0])

    def test_transform2d_non_finite_is_an_error(self):
        st = self.transform2d_material([(float("nan"), (1.0, 1.0), (0.0, 0.0))])
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Looks/T/Xf0: UsdTransform2d has a non-finite value", r.stderr)

    def test_material_interface_inputs_through_nodegraph(self):
        st = self.stage()
        m = quad(st, "/M")
        mat, sh = preview(st, "/Looks/T")
        mat.CreateInput("tint", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.1, 0.2, 0.3))
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(mat.GetInput("tint"))
        bind(m, mat)
        rss = self.convert(st)
        self.assertVec(rss.material("/Looks/T")["diffuse_color"]["value"], (0.1, 0.2, 0.3))

    def test_opacity_threshold_and_emission(self):
        st = self.stage()
        m = quad(st, "/M")
        mat, sh = preview(st, "/Looks/Cut", opacity=0.3, opacityThreshold=0.5, emissiveColor=Gf.Vec3f(2, 3, 4),
                          useSpecularWorkflow=1, specularColor=Gf.Vec3f(0.5, 0.5, 0.5))
        bind(m, mat)
        rss = self.convert(st)
        mm = rss.material("/Looks/Cut")
        self.assertAlmostEqual(mm["opacity"]["value"], 0.3, places=6)
        self.assertAlmostEqual(mm["opacity_threshold"], 0.5)
        self.assertEqual(mm["emissive_color"]["value"], [2, 3, 4])
        self.assertIs(mm["use_specular_workflow"], True)
        self.assertEqual(mm["specular_color"]["value"], [0.5, 0.5, 0.5])

    def test_materialx_and_unknown_shaders_are_error_materials(self):
        st = self.stage()
        a = quad(st, "/A")
        b = quad(st, "/B", z=1)
        c = quad(st, "/C", z=2)
        mx = UsdShade.Material.Define(st, "/Looks/Mtlx")
        s = UsdShade.Shader.Define(st, "/Looks/Mtlx/SS")
        s.CreateIdAttr("ND_standard_surface_surfaceshader")
        mx.CreateSurfaceOutput("mtlx").ConnectToSource(s.ConnectableAPI(), "out")
        bind(a, mx)
        mdl = UsdShade.Material.Define(st, "/Looks/Mdl")
        s2 = UsdShade.Shader.Define(st, "/Looks/Mdl/S")
        s2.SetSourceAsset(Sdf.AssetPath("OmniPBR.mdl"), "mdl")
        mdl.CreateSurfaceOutput("mdl").ConnectToSource(s2.ConnectableAPI(), "out")
        bind(b, mdl)
        both = UsdShade.Material.Define(st, "/Looks/Both")
        s3 = UsdShade.Shader.Define(st, "/Looks/Both/Custom")
        s3.CreateIdAttr("MyRendererSurface")
        both.CreateSurfaceOutput().ConnectToSource(s3.ConnectableAPI(), "out")
        s4 = UsdShade.Shader.Define(st, "/Looks/Both/Preview")
        s4.CreateIdAttr("UsdPreviewSurface")
        s4.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 1))
        both.CreateSurfaceOutput("glslfx").ConnectToSource(s4.ConnectableAPI(), "surface")
        bind(c, both)
        rss = self.convert(st)
        self.assertEqual(rss.material("/Looks/Mtlx"), {"kind": "error", "name": "/Looks/Mtlx"})
        self.assertEqual(rss.material("/Looks/Mdl")["kind"], "error")
        self.assertTrue(any("ND_standard_surface" in w["message"] for w in rss.warnings_for("/Looks/Mtlx")))
        self.assertTrue(any("OmniPBR.mdl" in w["message"] for w in rss.warnings_for("/Looks/Mdl")))
        fb = rss.material("/Looks/Both")
        self.assertEqual(fb["kind"], "preview_surface")
        self.assertEqual(fb["diffuse_color"]["value"], [0, 0, 1])
        self.assertTrue(rss.warnings_for("/Looks/Both"))

    def test_unbound_geometry_uses_display_color_or_grey(self):
        st = self.stage()
        quad(st, "/Grey")
        q = quad(st, "/Red", z=1)
        q.CreateDisplayColorPrimvar("constant").Set(Vt.Vec3fArray([Gf.Vec3f(0.8, 0.1, 0.1)]))
        rss = self.convert(st)
        mats = rss["materials"]
        grey = mats[rss.mesh_named("/Grey")["material_ids"][0]]
        red = mats[rss.mesh_named("/Red")["material_ids"][0]]
        self.assertEqual(grey["kind"], "preview_surface")
        self.assertNotIn("diffuse_color", grey)  # the spec default 0.18 applies
        self.assertVec(red["diffuse_color"]["value"], (0.8, 0.1, 0.1))

    def colours_at_corners(self, mesh):
        """The colour at each (x, y) corner of a quad mesh's vertices."""
        return {(round(p[0], 3), round(p[1], 3)): c for p, c in
                ((mesh["positions"][i], mesh["colors"][i]) for i in range(len(mesh["positions"])))}

    def test_per_vertex_display_color_becomes_vertex_colours(self):
        st = self.stage()
        q = quad(st, "/Painted")
        q.CreateDisplayColorPrimvar("vertex").Set(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0),
                                                                 Gf.Vec3f(0, 0, 1), Gf.Vec3f(1, 1, 1)]))
        f = quad(st, "/Faces", z=1)  # per face (uniform): every corner of a face takes its colour
        f.CreateDisplayColorPrimvar("uniform").Set(Vt.Vec3fArray([Gf.Vec3f(0.25, 0.5, 0.75)]))
        rss = self.convert(st)
        m = rss.mesh_named("/Painted")
        mat = rss["materials"][m["material_ids"][0]]
        self.assertTrue(mat["diffuse_color"]["vertex"])
        self.assertEqual(self.colours_at_corners(m), {(0, 0): (1, 0, 0), (1, 0): (0, 1, 0), (1, 1): (0, 0, 1), (0, 1): (1, 1, 1)})
        f = rss.mesh_named("/Faces")  # one value (all the same): a constant colour, no vertex colours
        self.assertIsNone(f["colors"])
        self.assertVec(rss["materials"][f["material_ids"][0]]["diffuse_color"]["value"], (0.25, 0.5, 0.75))
        self.assertFalse(rss.warnings_for("/Painted"))

    def test_primvar_reader_drives_the_diffuse_colour_per_vertex(self):
        st = self.stage()
        a = quad(st, "/A")
        UsdGeom.PrimvarsAPI(a).CreatePrimvar("paint", Sdf.ValueTypeNames.Color3fArray, "faceVarying").Set(
            Vt.Vec3fArray([Gf.Vec3f(0.1, 0, 0), Gf.Vec3f(0.2, 0, 0), Gf.Vec3f(0.3, 0, 0), Gf.Vec3f(0.4, 0, 0)]))
        b = quad(st, "/B", z=1)  # no primvar: the reader's fallback
        mat, sh = preview(st, "/Looks/P")
        rd = UsdShade.Shader.Define(st, "/Looks/P/Paint")
        rd.CreateIdAttr("UsdPrimvarReader_float3")
        rd.CreateInput("varname", Sdf.ValueTypeNames.String).Set("paint")
        rd.CreateInput("fallback", Sdf.ValueTypeNames.Float3).Set(Gf.Vec3f(0.5, 0.6, 0.7))
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(rd.ConnectableAPI(), "result")
        bind(a, mat)
        bind(b, mat)
        rss = self.convert(st)
        p = rss.material("/Looks/P")
        self.assertVec(p["diffuse_color"]["value"], (0.5, 0.6, 0.7))
        self.assertEqual((p["diffuse_color"]["texture"], p["diffuse_color"]["vertex"]), (None, True))
        corners = self.colours_at_corners(rss.mesh_named("/A"))
        for (x, y), want in (((0, 0), 0.1), ((1, 0), 0.2), ((1, 1), 0.3), ((0, 1), 0.4)):
            self.assertVec(corners[(x, y)], (want, 0, 0))
        self.assertIsNone(rss.mesh_named("/B")["colors"])
        self.assertTrue(any("has no primvars:paint" in w["message"] for w in rss.warnings_for("/B")))
        self.assertFalse(rss.warnings_for("/Looks/P/Paint"))

    def test_usdz_texture_is_extracted(self):
        asset_dir = self.dir / "asset"
        asset_dir.mkdir()
        (asset_dir / "tex.png").write_bytes(png_bytes(2, 2, (1, 2, 3)))
        a = new_stage(asset_dir / "asset.usda")
        root = UsdGeom.Xform.Define(a, "/Asset")
        a.SetDefaultPrim(root.GetPrim())
        m = quad(a, "/Asset/M")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(0, 0)] * 4))
        mat, sh = preview(a, "/Asset/Looks/T")
        tex = UsdShade.Shader.Define(a, "/Asset/Looks/T/Tex")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("tex.png")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        a.GetRootLayer().Save()
        usdz = self.dir / "asset.usdz"
        self.assertTrue(UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(asset_dir / "asset.usda")), str(usdz)))
        st = self.stage()
        ref = UsdGeom.Xform.Define(st, "/Ref")
        ref.GetPrim().GetReferences().AddReference(str(usdz))
        rss = self.convert(st)
        t = rss["textures"][rss.material("/Ref/Looks/T")["diffuse_color"]["texture"]]
        self.assertTrue(t["path"].startswith(str(self.dir / "out.rss.textures")), t["path"])
        self.assertEqual(Path(t["path"]).read_bytes(), (asset_dir / "tex.png").read_bytes())
        self.assertIn(str(usdz.resolve()), [d["path"] for d in rss["dependencies"]])


# ----------------------------------------------------------------------------------------------------
# Camera, render settings, errors, dependencies, summary
# ----------------------------------------------------------------------------------------------------


class SkelTests(Case):
    """UsdSkel: skinned prims posed at the conversion's time code."""

    def skinned_arm(self, rigid):
        """Joint b, one metre up joint a, turns 90° about Z between time codes 1 and 10; a quad above
        it bound to b alone (`rigid`: one constant influence) or its lower edge to a and its upper
        edge to b (per-vertex influences, a deforming mesh)."""
        st = self.stage()
        st.SetStartTimeCode(1)
        st.SetEndTimeCode(10)
        UsdSkel.Root.Define(st, "/Char")
        skel = UsdSkel.Skeleton.Define(st, "/Char/Skel")
        skel.CreateJointsAttr(["a", "a/b"])
        up = Gf.Matrix4d(1).SetTranslate(Gf.Vec3d(0, 1, 0))
        skel.CreateBindTransformsAttr([Gf.Matrix4d(1), up])
        skel.CreateRestTransformsAttr([Gf.Matrix4d(1), up])
        anim = UsdSkel.Animation.Define(st, "/Char/Skel/Anim")
        anim.CreateJointsAttr(["a", "a/b"])
        anim.CreateTranslationsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(0, 1, 0)])
        anim.CreateScalesAttr([Gf.Vec3h(1, 1, 1), Gf.Vec3h(1, 1, 1)])
        rot = anim.CreateRotationsAttr()
        h = math.sqrt(0.5)
        rot.Set([Gf.Quatf(1, 0, 0, 0), Gf.Quatf(1, 0, 0, 0)], 1)
        rot.Set([Gf.Quatf(1, 0, 0, 0), Gf.Quatf(h, 0, 0, h)], 10)
        UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
        m = add_mesh(st, "/Char/Arm", [(1, 1, 0), (2, 1, 0), (2, 2, 0), (1, 2, 0)], [4], [0, 1, 2, 3])
        m.CreateNormalsAttr([(0, 0, 1)] * 4)
        m.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        b = UsdSkel.BindingAPI.Apply(m.GetPrim())
        b.CreateSkeletonRel().SetTargets([skel.GetPath()])
        if rigid:
            b.CreateJointIndicesPrimvar(True, 1).Set([1])
            b.CreateJointWeightsPrimvar(True, 1).Set([1.0])
        else:
            b.CreateJointIndicesPrimvar(False, 1).Set([0, 0, 1, 1])
            b.CreateJointWeightsPrimvar(False, 1).Set([1.0, 1.0, 1.0, 1.0])
        b.CreateGeomBindTransformAttr(Gf.Matrix4d(1))
        return st

    def test_blend_shapes_follow_their_animated_weights(self):
        st = self.skinned_arm(rigid=True)
        anim = UsdSkel.Animation(st.GetPrimAtPath("/Char/Skel/Anim"))
        anim.CreateBlendShapesAttr(["lift"])
        w = anim.CreateBlendShapeWeightsAttr()
        w.Set([0.0], 1)
        w.Set([1.0], 10)
        shape = UsdSkel.BlendShape.Define(st, "/Char/Arm/Lift")
        shape.CreateOffsetsAttr([Gf.Vec3f(0, 0, 2), Gf.Vec3f(0, 0, 2)])
        shape.CreatePointIndicesAttr([2, 3])  # the upper edge
        b = UsdSkel.BindingAPI(st.GetPrimAtPath("/Char/Arm"))
        b.CreateBlendShapesAttr(["lift"])
        b.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])
        # at 5.5 the weight is 0.5: the upper edge is lifted by 1 along z, then turned 45° with joint b
        rss = self.convert(st, args=("--frame", "5.5"))
        c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
        for got, (x, y, z) in zip(self.world_points(rss), [(1, 1, 0), (2, 1, 0), (2, 2, 1), (1, 2, 1)]):
            y -= 1
            self.assertVec(got, (c * x - s * y, s * x + c * y + 1, z))
        self.assertFalse([w for w in self.result_warnings() if "blend" in w])

    def world_points(self, rss):
        (inst,) = rss["instances"]
        return [apply(inst["transform"], p) for p in rss.array(rss["meshes"][inst["mesh"]]["positions"])]

    def test_rigidly_bound_prim_follows_its_joint(self):
        st = self.skinned_arm(rigid=True)
        rest = self.world_points(self.convert(st))  # the start time: the rest pose
        for got, want in zip(rest, [(1, 1, 0), (2, 1, 0), (2, 2, 0), (1, 2, 0)]):
            self.assertVec(got, want)
        # at 10 the quad turned 90° about (0, 1, 0); at 5.5 by 45° (the joint's rotations slerped)
        turned = self.world_points(self.convert(args=("--frame", "10")))
        for got, want in zip(turned, [(0, 2, 0), (0, 3, 0), (-1, 3, 0), (-1, 2, 0)]):
            self.assertVec(got, want)
        c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
        half = self.world_points(self.convert(args=("--frame", "5.5")))
        for got, (x, y, z) in zip(half, [(1, 1, 0), (2, 1, 0), (2, 2, 0), (1, 2, 0)]):
            y -= 1  # about the joint at (0, 1, 0)
            self.assertVec(got, (c * x - s * y, s * x + c * y + 1, z))
        self.assertEqual(self.result_warnings(), ["the stage has no camera; the renderer frames the scene with a default camera"])

    def test_deforming_mesh_is_skinned_and_its_normals_recomputed(self):
        st = self.skinned_arm(rigid=False)
        rss = self.convert(st, args=("--frame", "10"))
        # the lower edge stays with joint a; the upper one turns with b about (0, 1, 0)
        for got, want in zip(self.world_points(rss), [(1, 1, 0), (2, 1, 0), (-1, 3, 0), (-1, 2, 0)]):
            self.assertVec(got, want)
        mesh = rss["meshes"][0]
        self.assertIsNotNone(mesh["normals"])
        for n in rss.array(mesh["normals"]):  # the skinned quad still lies in z = 0
            self.assertVec([abs(x) for x in n], (0, 0, 1))
        self.assertIn("authored normals are not skinned", " ".join(self.result_warnings()))


class StageTests(Case):
    def test_camera_and_render_settings(self):
        st = self.stage(mpu=0.1)
        quad(st, "/M")
        first = camera(st, "/First", z=1)
        cam = UsdGeom.Camera.Define(st, "/Rig/Chosen")
        cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 30))
        cam.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
        cam.CreateFocalLengthAttr(35.0)
        cam.CreateHorizontalApertureAttr(36.0)
        cam.CreateVerticalApertureAttr(24.0)
        cam.CreateClippingRangeAttr(Gf.Vec2f(1, 100))
        rs = UsdRender.Settings.Define(st, "/Render/Settings")
        rs.CreateResolutionAttr(Gf.Vec2i(320, 240))
        rs.CreateCameraRel().SetTargets(["/Rig/Chosen"])
        rss = self.convert(st)
        c = rss["camera"]
        self.assertEqual(c["name"], "/Rig/Chosen")
        self.assertEqual(rss["resolution"], [320, 240])
        self.assertEqual((c["focal_length"], c["horizontal_aperture"], c["vertical_aperture"]), (35.0, 36.0, 24.0))
        self.assertVec(c["transform"][3], (0, 0, 3, 1))
        for k in range(3):  # orthonormal: scale removed
            self.assertAlmostEqual(sum(x * x for x in c["transform"][k][:3]), 1.0)
        self.assertVec(c["clipping"], (0.2, 20.0), tol=1e-5)  # scale 2 and 0.1 m per unit

    def test_pixel_aspect_and_conform_policy_of_the_render_settings(self):
        st = self.stage()
        quad(st, "/M")
        camera(st, "/Cam", z=5)
        rs = UsdRender.Settings.Define(st, "/Render/Settings")
        rs.CreateResolutionAttr(Gf.Vec2i(960, 540))
        rs.CreatePixelAspectRatioAttr(2.0)
        rs.CreateAspectRatioConformPolicyAttr("adjustApertureWidth")
        prod = UsdRender.Product.Define(st, "/Render/Beauty")
        rs.CreateProductsRel().SetTargets(["/Render/Beauty"])
        rss = self.convert(st)
        c = rss["camera"]
        self.assertEqual((c["pixel_aspect"], c["aspect_conform"]), (2.0, "adjustApertureWidth"))
        self.assertFalse(rss.warnings_for("/Render"), rss.warnings_for("/Render"))
        # a product's values win; an unknown policy is warned about and expandAperture used
        prod.CreateAspectRatioConformPolicyAttr("stretch")
        prod.CreatePixelAspectRatioAttr(1.5)
        rss = self.convert(st)
        self.assertEqual((rss["camera"]["pixel_aspect"], rss["camera"]["aspect_conform"]), (1.5, "expandAperture"))
        self.assertTrue(any("stretch" in w["message"] for w in rss.warnings_for("/Render")))
        # no pixels of zero width
        prod.CreatePixelAspectRatioAttr(0.0)
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("pixelAspectRatio 0 must be between", r.stderr)

    def test_first_camera_without_render_settings_and_no_camera(self):
        st = self.stage()
        quad(st, "/M")
        camera(st, "/A/Cam1", z=1)
        camera(st, "/B/Cam2", z=2)
        rss = self.convert(st)
        self.assertEqual(rss["camera"]["name"], "/A/Cam1")
        self.assertIsNone(rss["resolution"])
        st.RemovePrim("/A")
        st.RemovePrim("/B")
        rss = self.convert(st)
        self.assertIsNone(rss["camera"])
        self.assertTrue(any("camera" in w["message"] for w in rss["warnings"]))

    def test_camera_option_overrides_the_render_settings_camera(self):
        st = self.stage()
        quad(st, "/M")
        camera(st, "/First", z=1)
        camera(st, "/Rig/Chosen", z=7)
        rs = UsdRender.Settings.Define(st, "/Render/Settings")
        rs.CreateResolutionAttr(Gf.Vec2i(320, 240))
        rs.CreateCameraRel().SetTargets(["/Rig/Chosen"])
        rss = self.convert(st)
        self.assertEqual(rss["camera"]["name"], "/Rig/Chosen")
        self.assertEqual(rss["stage"]["cameras"], ["/First", "/Rig/Chosen"])
        rss = self.convert(st, args=("--camera", "/First"))
        self.assertEqual(rss["camera"]["name"], "/First")
        self.assertVec(rss["camera"]["transform"][3], (0, 0, 1, 1))
        self.assertEqual(rss["resolution"], [320, 240])  # the settings' other values still apply
        self.assertEqual(self.result.summary["camera"], "/First")

    def test_depth_of_field_and_aperture_offsets(self):
        st = self.stage(mpu=0.01)  # centimetres: focal length and apertures in millimetres
        quad(st, "/M")
        cam = camera(st, "/Cam", z=100)
        cam.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
        cam.CreateFocalLengthAttr(50.0)
        cam.CreateFStopAttr(2.0)
        cam.CreateFocusDistanceAttr(150.0)
        cam.CreateHorizontalApertureOffsetAttr(3.0)
        cam.CreateVerticalApertureOffsetAttr(-1.5)
        c = self.convert(st)["camera"]
        # 50 mm at f/2: a 12.5 mm lens radius, scaled by the camera's 2 → 0.025 m; focus 150 cm · 2
        self.assertAlmostEqual(c["lens_radius"], 0.025, places=6)
        self.assertAlmostEqual(c["focus_distance"], 3.0, places=5)
        self.assertEqual(c["aperture_offset"], [3.0, -1.5])  # the apertures' unit, as they are
        self.assertFalse(self.result_warnings())
        cam.GetFocusDistanceAttr().Set(4.0)  # a 2.5 cm lens for an 8 cm focus distance
        c = self.convert(st)["camera"]
        self.assertAlmostEqual(c["lens_radius"], 0.025, places=6)
        self.assertTrue(any("is large for its focus distance" in w for w in self.result_warnings()))
        cam.GetFocusDistanceAttr().Set(0.0)
        c = self.convert(st)["camera"]
        self.assertEqual(c["lens_radius"], 0.0)
        self.assertTrue(any("without a positive focusDistance" in w for w in self.result_warnings()))
        cam.GetFStopAttr().Set(0.0)
        c = self.convert(st)["camera"]
        self.assertEqual((c["lens_radius"], c["focus_distance"]), (0.0, 0.0))
        self.assertFalse(self.result_warnings())
        cam.GetFStopAttr().Set(4.0)
        cam.GetFocusDistanceAttr().Set(150.0)
        cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
        c = self.convert(st)["camera"]
        self.assertEqual(c["lens_radius"], 0.0)
        self.assertTrue(any("orthographic" in w for w in self.result_warnings()))
        self.assertVec(c["aperture_offset"], (3.0 * 0.1 * 0.01 * 2, -1.5 * 0.1 * 0.01 * 2), tol=1e-9)  # metres

    def test_camera_option_errors_name_the_prim_and_list_the_cameras(self):
        st = self.stage()
        quad(st, "/M")
        camera(st, "/Cams/A", z=1)
        camera(st, "/Cams/B", z=2)
        st.GetRootLayer().Save()
        for path, what in (("/Cams/C", "no such prim"), ("/M", "is a Mesh, not a Camera"),
                           ("Cams/A", "not an absolute prim path"), ("/Cams/A b", "not an absolute prim path")):
            r = self.convert(expect_ok=False, args=("--camera", path))
            self.assertEqual(r.rc, 2, r.stderr)
            errors = [l for l in r.stderr.splitlines() if l.startswith("error: ")]
            self.assertEqual(len(errors), 1, r.stderr)
            self.assertIn("%s: %s: %s" % (self.path, path, what), errors[0])
            self.assertIn("the stage's cameras: /Cams/A, /Cams/B", errors[0])
            self.assertNotIn("Traceback", r.stderr)
            self.assertFalse(r.out.exists())

    def test_frame_reads_animated_values_at_that_time_code(self):
        st = self.stage()
        st.SetStartTimeCode(1)
        st.SetEndTimeCode(10)
        m = quad(st, "/M")
        op = UsdGeom.Xformable(m.GetPrim()).AddTranslateOp()
        op.Set(Gf.Vec3d(0, 0, 0), 1.0)
        op.Set(Gf.Vec3d(9, 0, 0), 10.0)
        cam = camera(st, "/Cam")
        cam.CreateFocalLengthAttr().Set(20.0, 1.0)
        cam.GetFocalLengthAttr().Set(110.0, 10.0)
        rss = self.convert(st)  # the stage's start time
        self.assertVec(rss["instances"][0]["transform"][3], (0, 0, 0, 1))
        self.assertAlmostEqual(rss["camera"]["focal_length"], 20.0)
        self.assertEqual(rss["stage"]["time"], 1.0)
        self.assertEqual(rss["stage"]["time_range"], [1.0, 10.0])
        rss = self.convert(st, args=("--frame", "5.5"))
        self.assertVec(rss["instances"][0]["transform"][3], (4.5, 0, 0, 1))
        self.assertAlmostEqual(rss["camera"]["focal_length"], 65.0, places=4)
        self.assertEqual(rss["stage"]["time"], 5.5)
        self.assertEqual(self.result.summary["time"], 5.5)
        self.assertFalse(any("outside" in w["message"] for w in rss["warnings"]))
        rss = self.convert(st, args=("--frame", "20"))  # held at the last sample, with a warning
        self.assertVec(rss["instances"][0]["transform"][3], (9, 0, 0, 1))
        self.assertTrue(any("frame 20 is outside the stage's time range 1 to 10" in w["message"]
                            for w in rss["warnings"]), rss["warnings"])

    def test_bad_frame_values_are_rejected(self):
        st = self.stage()
        quad(st, "/M")
        st.GetRootLayer().Save()
        r = self.convert(expect_ok=False, args=("--frame", "nan"))
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("not a finite time code", r.stderr)
        self.assertFalse(r.out.exists())
        for args in (("--frame", "ten"), ("--frame",), ("--camera",)):
            r = self.convert(expect_ok=False, args=args)
            self.assertEqual(r.rc, 2, r.stderr)
            self.assertIn("usage", r.stderr)

    def test_missing_file_is_exit_2_naming_the_file(self):
        missing = self.dir / "nope" / "scene.usda"
        r = convert(missing, self.dir / "out.rss")
        self.assertEqual(r.rc, 2)
        lines = [l for l in r.stderr.splitlines() if l.strip()]
        self.assertEqual(len(lines), 1, r.stderr)
        self.assertTrue(lines[0].startswith("error: %s: " % missing), lines[0])
        self.assertNotIn("Traceback", r.stderr)
        self.assertFalse((self.dir / "out.rss").exists())

    def test_syntax_error_is_exit_2(self):
        self.path = self.dir / "syntax.usda"
        self.path.write_text('#usda 1.0\ndef Mesh "M" {\n  point3f[] points = [(0,0,0), (1,0\n}\n')
        r = self.convert(expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        errors = [l for l in r.stderr.splitlines() if l.startswith("error: ")]
        self.assertEqual(len(errors), 1, r.stderr)
        self.assertIn("syntax.usda", errors[0])
        self.assertIn("parse error", errors[0])
        self.assertNotIn("Traceback", r.stderr)
        self.assertFalse(r.out.exists())

    def test_no_geometry_is_exit_2(self):
        st = self.stage()
        UsdLux.DomeLight.Define(st, "/Dome")
        st.GetRootLayer().Save()
        r = self.convert(expect_ok=False)
        self.assertEqual(r.rc, 2)
        self.assertIn("no renderable geometry", r.stderr)

    def test_usage_error(self):
        r = convert(self.dir / "a.usda", self.dir / "b.rss", extra=("--bogus",))
        self.assertEqual(r.rc, 2)
        self.assertIn("usage", r.stderr)

    def test_dependencies_include_sublayers_with_hashes(self):
        sub = self.dir / "sub.usda"
        s = new_stage(sub)
        quad(s, "/M")
        s.GetRootLayer().Save()
        st = self.stage()
        st.GetRootLayer().subLayerPaths.append("sub.usda")
        rss = self.convert(st)
        deps = {d["path"]: d["sha256"] for d in rss["dependencies"]}
        for p in (sub, self.path):
            self.assertEqual(deps[str(p.resolve())], hashlib.sha256(p.read_bytes()).hexdigest())
        self.assertEqual(self.result.summary["dependencies"], 2)

    def test_output_is_replaced_atomically(self):
        st = self.stage()
        quad(st, "/M")
        out = self.dir / "out.rss"
        out.write_bytes(b"old")
        rss = self.convert(st)
        self.assertEqual(rss.version, 1)
        self.assertEqual([p.name for p in self.dir.iterdir() if p.name.startswith(".out.rss")], [])

    def test_json_summary_and_stderr_warnings(self):
        st = self.stage()
        quad(st, "/M", scheme="loop")
        UsdLux.SphereLight.Define(st, "/L")
        camera(st)
        rss = self.convert(st)
        s = self.result.summary
        for k in ("meshes", "instances", "triangles", "materials", "lights", "warnings", "dependencies"):
            self.assertIn(k, s)
        self.assertEqual((s["meshes"], s["instances"], s["triangles"], s["lights"]), (1, 1, 2, 1))
        self.assertEqual(s["warnings"], len(rss["warnings"]))
        self.assertTrue(any(l.startswith("warning: /M: ") for l in self.result.stderr_warnings))


# ----------------------------------------------------------------------------------------------------
# The repository's scenes (scripts/make_scenes.py)
# ----------------------------------------------------------------------------------------------------


class RunAsFilesTests(Case):
    def test_run_as_files_writes_the_same_scene(self):
        """`python3 raysplat_usd.py IN OUT` (the parts importing each other) writes the bytes the
        concatenated text the Rust binary pipes to Python writes: a textured subdivision surface, a
        sphere and a distant light, and the repository's glossy Cornell box."""
        st = self.stage()
        m = add_mesh(st, "/Cube", [(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)], [4] * 6,
                     [0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5], scheme="catmullClark")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(x, y) for _ in (0, 1) for y in (0, 1) for x in (0, 1)]))
        (self.dir / "t.png").write_bytes(png_bytes(rgb=(40, 200, 90)))
        mat, sh = preview(st, "/Looks/T", roughness=0.3)
        tex = UsdShade.Shader.Define(st, "/Looks/T/Tex")
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("t.png")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        UsdLux.SphereLight.Define(st, "/Lamp").CreateRadiusAttr(0.2)
        UsdLux.DistantLight.Define(st, "/Sun")
        camera(st)
        self.convert(st)
        piped = self.dir / "out.rss"
        for inp, ref in ((self.path, piped), (REPO / "scenes" / "cornell-glossy.usda", None)):
            if ref is None:
                ref = self.dir / "glossy-piped.rss"
                r = convert(inp, ref, extra=())
                self.assertEqual(r.rc, 0, r.stderr)
            files = self.dir / "files.rss"
            proc = subprocess.run([sys.executable, str(HERE.parent / "raysplat_usd.py"), str(inp), str(files)],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=str(self.dir), timeout=600)
            self.assertEqual(proc.returncode, 0, proc.stderr.decode("utf-8", "replace"))
            self.assertEqual(files.read_bytes(), ref.read_bytes(), inp)


class RepoSceneTests(unittest.TestCase):
    def test_scenes_are_reproducible_and_convert(self):
        with tempfile.TemporaryDirectory() as d:
            proc = subprocess.run([sys.executable, str(REPO / "scripts" / "make_scenes.py"), d],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            self.assertEqual(proc.returncode, 0, proc.stderr.decode())
            names = sorted(p.name for p in Path(d).glob("*.usda"))
            self.assertEqual(names, ["bumpy-box.usda", "concave-corners.usda", "cornell-box.usda",
                                     "cornell-glossy.usda", "furnace.usda", "plane-distant.usda", "plane-rect.usda",
                                     "secondary-light.usda"])
            for name in names:
                committed = REPO / "scenes" / name
                self.assertTrue(committed.exists(), "scenes/%s is missing: run make scenes" % name)
                self.assertEqual(committed.read_text(), (Path(d) / name).read_text(),
                                 "scenes/%s is stale: run scripts/make_scenes.py" % name)
                out = Path(d) / (name + ".rss")
                r = convert(committed, out)
                self.assertEqual(r.rc, 0, r.stderr)
                rss = Rss(out)
                self.assertEqual(rss["warnings"], [], name)
                self.assertIsNotNone(rss["camera"])
                self.assertIsNotNone(rss["resolution"])

    def test_cornell_box_contents(self):
        with tempfile.TemporaryDirectory() as d:
            out = Path(d) / "cb.rss"
            r = convert(REPO / "scenes" / "cornell-box.usda", out)
            self.assertEqual(r.rc, 0, r.stderr)
            rss = Rss(out)
            self.assertEqual(rss["resolution"], [256, 256])
            self.assertEqual(rss.triangles(), 30)
            light = rss["lights"][0]
            self.assertEqual(light["type"], "rect")
            down = [-x for x in light["transform"][2][:3]]
            for a, b in zip(down, (0, -1, 0)):
                self.assertAlmostEqual(a, b, places=6)
            for a, b in zip(light["radiance"], (17, 12, 4)):
                self.assertAlmostEqual(a, b, places=5)
            kinds = {m["name"]: m["diffuse_color"]["value"] for m in rss["materials"]}
            self.assertEqual(sorted(kinds), ["/World/Looks/Green", "/World/Looks/Red", "/World/Looks/White"])

    def test_analytic_expectations(self):
        stage = Usd.Stage.Open(str(REPO / "scenes" / "plane-rect.usda"))
        e = stage.GetRootLayer().customLayerData["raysplat:expected"]
        x = 0.5 * e["side"] / e["distance"]
        f = 2 * x / math.sqrt(1 + x * x) * math.atan(x / math.sqrt(1 + x * x)) / (2 * math.pi)
        self.assertAlmostEqual(e["irradiance"], math.pi * e["light_radiance"] * 4 * f, places=9)
        self.assertAlmostEqual(e["pixel_radiance"], e["albedo"] * e["irradiance"] / math.pi, places=9)
        stage = Usd.Stage.Open(str(REPO / "scenes" / "furnace.usda"))
        self.assertAlmostEqual(stage.GetRootLayer().customLayerData["raysplat:expected"]["pixel_radiance"], 2.0)
        stage = Usd.Stage.Open(str(REPO / "scenes" / "plane-distant.usda"))
        e = stage.GetRootLayer().customLayerData["raysplat:expected"]
        self.assertAlmostEqual(e["pixel_radiance"], 0.6 * 3 * math.cos(math.radians(30)) / math.pi, places=9)


# ----------------------------------------------------------------------------------------------------
# The shared real scenes
# ----------------------------------------------------------------------------------------------------


def shared_entries():
    """(entry file, documented triangle count) from ../shared/scenes/README.md."""
    readme = SHARED / "README.md"
    out = []
    for line in readme.read_text().splitlines():
        if not line.startswith("| `"):
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        files = re.findall(r"`([^`]+\.usd[acz]?)`", cells[0])
        counts = [int(x.replace(",", "")) for x in re.findall(r"[\d,]+", cells[3])]
        base = os.path.dirname(files[0])
        files = [f if "/" in f else os.path.join(base, f) for f in files]
        out.extend(zip(files, counts))
    return out


@unittest.skipUnless((SHARED / "README.md").exists(), "shared scenes not present (%s)" % SHARED)
class SharedSceneTests(unittest.TestCase):
    def test_every_entry_converts_with_the_documented_triangle_count(self):
        entries = shared_entries()
        self.assertGreaterEqual(len(entries), 7)
        with tempfile.TemporaryDirectory() as d:
            for entry, tris in entries:
                with self.subTest(entry=entry):
                    out = Path(d) / (Path(entry).stem + ".rss")
                    t0 = time.time()
                    # subdivision surfaces at their control cage (level 0), so the documented counts hold
                    r = convert(SHARED / entry, out, extra=("--subdivision-level", "0"))
                    dt = time.time() - t0
                    self.assertEqual(r.rc, 0, r.stderr)
                    self.assertNotIn("Traceback", r.stderr)
                    rss = Rss(out)
                    print("\n%s: %.2fs, %d triangles, %d meshes, %d instances, %d materials, %d lights, %d warnings"
                          % (entry, dt, rss.triangles(), len(rss["meshes"]), len(rss["instances"]),
                             len(rss["materials"]), len(rss["lights"]), len(rss["warnings"])), file=sys.stderr)
                    for w in rss["warnings"]:
                        print("    warning: %s: %s" % (w["prim"], w["message"][:200]), file=sys.stderr)
                    self.assertEqual(rss.triangles(), tris)
                    self.assertIsNotNone(rss["camera"])
                    self.assertTrue(rss["lights"])
                    if "sponza" in entry:
                        self.assertLess(dt, 60.0, "Sponza conversion took %.1fs" % dt)
                        self.assertEqual(len(rss["meshes"]), 381)


if __name__ == "__main__":
    unittest.main()
