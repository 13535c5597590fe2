"""The harness of the USD -> .rss converter's tests (`test_convert_*.py`): running the converter the
way the Rust binary does (`python3 - INPUT OUTPUT` with its parts concatenated on stdin), reading the .rss
back with a small reader, checking the header against the serde shapes of `src/scene` (field names, types,
enum tags, so that a converter change the Rust loader would reject fails here first), building tiny stages
with usd-core, and the `Case` base class (a temporary directory per test).

Run the tests with `python3 -m unittest discover -s python/tests -v` (needs usd-core).
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
PARTS = [HERE.parent / n for n in ("raysplat_crate.py", "raysplat_curves.py", "raysplat_usd_common.py",
                                   "raysplat_usd_mtlx_nodes.py", "raysplat_usd_mtlx.py", "raysplat_usd_materials.py",
                                   "raysplat_usd_meshes.py", "raysplat_usd_lights.py", "raysplat_usd.py")]
REPO = HERE.parent.parent
# the .rss format version the converter writes (one constant, raysplat_usd_common.FORMAT_VERSION)
FORMAT_VERSION = int(re.search(r"^FORMAT_VERSION = (\d+)$", (HERE.parent / "raysplat_usd_common.py").read_text(), re.M).group(1))
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


ELEM = {"f32x3": ("f", 3), "u32x3": ("I", 3), "f32x2": ("f", 2), "u32x2": ("I", 2), "u32": ("I", 1), "f32": ("f", 1)}


class Rss:
    """A .rss file: the JSON header and typed access to the blob's arrays."""

    def __init__(self, path):
        data = Path(path).read_bytes()
        assert data[:8] == b"RAYSPLAT", "bad magic"
        self.version, crc = struct.unpack_from("<II", data, 8)
        assert self.version == FORMAT_VERSION, "version %d" % self.version
        assert crc == zlib.crc32(data[16:]), "the checksum does not match the content"
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
            if m.get("subdivision") is not None:
                self.subdivision(m["name"])

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

    def subdivision(self, name):
        """A subdivision mesh's cage: its points, material ids and the `subdivision` header with
        every array read (absent ones as [])."""
        m = next(m for m in self.header["meshes"] if m["name"] == name)
        sd = dict(m["subdivision"])
        for key in ("face_counts", "face_indices", "holes", "creases", "crease_sharpness", "corners", "corner_sharpness"):
            sd[key] = self.array(sd[key]) if sd.get(key) is not None else []
        for key in ("uvs", "colors"):
            if sd.get(key) is not None:
                pv = dict(sd[key])
                pv["values"] = self.array(pv["values"])
                pv["indices"] = self.array(pv["indices"]) if pv.get("indices") is not None else None
                sd[key] = pv
        sd["positions"] = self.array(m["positions"])
        sd["material_ids"] = self.array(m["material_ids"])
        return sd

    def instances_of(self, name_prefix):
        return [i for i in self.header["instances"] if i["name"].startswith(name_prefix)]

    def light(self, name):
        return next(l for l in self.header["lights"] if l["name"] == name)

    def material(self, name):
        return next(m for m in self.header["materials"] if m["name"] == name)

    def warnings_for(self, prim_substring=""):
        return [w for w in self.header["warnings"] if prim_substring in w["prim"]]

    def triangles(self):
        """Triangles of the placed meshes, a subdivision surface's cage counted as its polygons fan
        triangulated (holes left out)."""
        count = {}
        for k, m in enumerate(self.header["meshes"]):
            if m["indices"] is not None:
                count[k] = m["indices"]["count"]
            else:
                sd = self.subdivision(m["name"])
                holes = set(sd["holes"])
                count[k] = sum(max(c - 2, 0) for f, c in enumerate(sd["face_counts"]) if f not in holes)
        return sum(count[i["mesh"]] for i in self.header["instances"])


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
    assert h["format"] == "raysplat-scene" and h["version"] == FORMAT_VERSION
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
        if "exposure_scale" in cam:
            assert _is_num(cam["exposure_scale"]) and cam["exposure_scale"] > 0
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
            if "specular_tint" in m:
                assert _f32s(m["specular_tint"]["value"], 3) and _opt_u32(m["specular_tint"].get("texture"))
            if "transmission_color" in m:
                assert _f32s(m["transmission_color"], 3)
    for t in h["textures"]:
        assert isinstance(t["path"], str)
        assert t["wrap_s"] in ("repeat", "mirror", "clamp", "black") and t["wrap_t"] in ("repeat", "mirror", "clamp", "black")
        assert _f32s(t["scale"], 4) and _f32s(t["bias"], 4) and _f32s(t["fallback"], 4)
        assert t["color_space"] in ("sRGB", "raw", "auto", "ACEScg") and t["output"] in ("rgb", "r", "g", "b", "a")
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
    def array_ref(a, ty):
        return a["type"] == ty and a["offset"] >= 0 and a["count"] >= 0

    for m in h["meshes"]:
        assert isinstance(m["name"], str) and isinstance(m.get("double_sided", False), bool)
        for key, ty in (("positions", "f32x3"), ("material_ids", "u32")):
            assert array_ref(m[key], ty)
        sd = m.get("subdivision")
        # a subdivision surface has its faces and primvars in its cage, a triangle mesh triangles
        assert (m["indices"] is None) == (sd is not None), m["name"]
        assert m["indices"] is None or array_ref(m["indices"], "u32x3")
        for key, ty in (("normals", "f32x3"), ("uvs", "f32x2")):
            assert m[key] is None or (m[key]["type"] == ty and m[key]["count"] == m["positions"]["count"])
        if sd is not None:
            assert sd["scheme"] in ("catmullClark", "loop", "bilinear")
            assert sd["boundary"] in ("none", "edgeOnly", "edgeAndCorner")
            assert sd["face_varying"] in ("none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all")
            assert m["normals"] is None and m["uvs"] is None and m.get("colors") is None
            assert array_ref(sd["face_counts"], "u32") and array_ref(sd["face_indices"], "u32")
            for key, ty in (("holes", "u32"), ("creases", "u32x2"), ("crease_sharpness", "f32"), ("corners", "u32"),
                            ("corner_sharpness", "f32")):
                assert sd.get(key) is None or array_ref(sd[key], ty), key
            for key, ty in (("uvs", "f32x2"), ("colors", "f32x3")):
                pv = sd.get(key)
                if pv is not None:
                    assert pv["mode"] in ("vertex", "linear", "faceVarying") and array_ref(pv["values"], ty)
                    assert (pv["indices"] is None) == (pv["mode"] == "vertex")
                    assert pv["indices"] is None or (array_ref(pv["indices"], "u32")
                                                     and pv["indices"]["count"] == sd["face_indices"]["count"])
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


def uv_texture(stage, path, file=None):
    """A UsdUVTexture shader at `path`, reading `file` when given."""
    tex = UsdShade.Shader.Define(stage, path)
    tex.CreateIdAttr("UsdUVTexture")
    if file is not None:
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    return tex


def primvar_reader(stage, path, varname, varname_type=Sdf.ValueTypeNames.String):
    """A UsdPrimvarReader_float2 at `path` reading the primvar `varname` (output `result`)."""
    rd = UsdShade.Shader.Define(stage, path)
    rd.CreateIdAttr("UsdPrimvarReader_float2")
    rd.CreateInput("varname", varname_type).Set(varname)
    return rd

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
