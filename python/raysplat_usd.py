#!/usr/bin/env python3
"""raysplat_usd.py: convert a USD stage into the raysplat scene format (.rss).

    python3 raysplat_usd.py INPUT.usd[a|c|z] OUTPUT.rss [--json-summary]

The Rust binary embeds this file and runs it as `python3 - INPUT OUTPUT` with the source on stdin, so it
must not depend on its own location and imports nothing but the standard library and `pxr` (usd-core).

Output format: `docs/scene-format.md`; unit conventions: `docs/units.md`. Everything written is in
metres, Y up, linear Rec.709 radiance. Meshes are in object space and placed by instances.

Exit status: 0 converted; 2 bad input (missing file, parse error, no geometry, malformed arrays) with one
line `error: <file>: <prim path or ->: <message>` on stderr; 1 internal errors (with a traceback).
Whatever cannot be represented exactly is listed in the header's `warnings` and printed to stderr as
`warning: <prim>: <message>`; nothing is dropped silently.
"""

import array
import hashlib
import io
import json
import math
import os
import re
import sys
import tempfile
import time
import zipfile

if "Refinement" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_subdiv import Refinement, crease_edges, repeated_vertex_face
    from raysplat_curves import CurveError, combine, curve_samples, hermite_samples, icosphere, nurbs_curve_samples, nurbs_patch, tubes

CONVERTER_VERSION = "1"
FORMAT_VERSION = 1
MAGIC = b"RAYSPLAT"

# Tessellation of implicit gprims (segments around, rings from pole to pole).
SEGMENTS = 32
RINGS = 16
# Refinement levels of subdivision surfaces (`--subdivision-level`): the default, the most accepted,
# and the most faces one mesh may be refined to (its level is lowered to stay below, with a warning).
SUBDIVISION_LEVEL = 2
MAX_SUBDIVISION_LEVEL = 6
MAX_SUBDIVISION_FACES = 2000000
# Tessellation of curves (tube sides, samples per cubic segment) and points (icosphere levels), and
# the most triangles one curves or points prim may become (more: skipped, with a warning).
CURVE_SIDES = 6
CURVE_STEPS = 4
POINT_LEVELS = 1
MAX_TESSELLATED_TRIANGLES = 4000000
# Radius of a sphere light that stands for a point light (treatAsPoint or radius 0), metres.
POINT_LIGHT_RADIUS = 1e-3

# Before pxr loads: bindings on prims without MaterialBindingAPI applied still count (older assets).
os.environ.setdefault("USD_SHADE_MATERIAL_BINDING_API_CHECK", "allowMissingAPI")


class UserError(Exception):
    """Bad input: reported as `error: <file>: <prim>: <message>`, exit status 2."""

    def __init__(self, prim, message):
        super().__init__(message)
        self.prim = prim or "-"
        self.message = message


# --------------------------------------------------------------------------------------------------
# Small helpers
# --------------------------------------------------------------------------------------------------


def sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def f32_bytes(vt, width):
    """Raw little-endian f32 bytes of a Vt array of floats / float vectors (any float precision)."""
    if vt is None or len(vt) == 0:
        return b""
    mv = memoryview(vt)
    if mv.format == "f" and sys.byteorder == "little":
        return mv.tobytes()
    flat = mv.tolist()
    if flat and isinstance(flat[0], list):
        flat = [x for row in flat for x in row]
    a = array.array("f", flat)
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def int_list(vt):
    if vt is None:
        return []
    if isinstance(vt, list):
        return vt
    return memoryview(vt).tolist() if len(vt) else []


def chunks(data, width):
    return [data[i:i + width] for i in range(0, len(data), width)]


def gather(data, width, idx):
    """Elements `idx` of a packed array of `width`-byte elements."""
    if idx is None:
        return data
    c = chunks(data, width)
    return b"".join([c[i] for i in idx])


def u32_bytes(ints):
    a = array.array("I", ints)
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def finite(*xs):
    return all(isinstance(x, (int, float)) and math.isfinite(x) for x in xs)


IDENTITY_2D = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
# Shaders that read a colour primvar (a material's diffuse colour per vertex).
COLOR_READERS = ("UsdPrimvarReader_float3", "UsdPrimvarReader_vector", "UsdPrimvarReader_point", "UsdPrimvarReader_normal")


def compose_2d(outer, inner):
    """The 2D affine map `outer ∘ inner` (each `[[a, b, c], [d, e, f]]`)."""
    (a, b, c), (d, e, f) = outer
    (g, h, i), (j, k, l) = inner
    return [[a * g + b * j, a * h + b * k, a * i + b * l + c], [d * g + e * j, d * h + e * k, d * i + e * l + f]]


def zero_scale(m):
    """Whether a GfMatrix4d's linear part (upper-left 3 × 3) collapses space: a finite determinant
    of (almost) zero, USD's usual way to hide a prim. A non-finite matrix is not (it is an error)."""
    det = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
           - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
           + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    return finite(det) and abs(det) < 1e-30


def luminance(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def fl(x):
    return float(x)


def vec(v, n):
    return [float(v[i]) for i in range(n)]


def clean_usd_message(text):
    text = re.sub(r"pxrInternal_v\d+_\d+(_\d+)?__pxrReserved__::", "", text)
    return " ".join(text.split())


def parse_tf_error(exc):
    """One readable line from a Tf.ErrorException (which lists every error in the chain)."""
    text = str(exc)
    msgs = re.findall(r":\s*'(.*?)'\s*(?=\n|$)", text, flags=re.S)
    msgs = [clean_usd_message(m) for m in msgs if m.strip()]
    if not msgs:
        return clean_usd_message(text) or "cannot open the stage"
    # The first error is the cause (e.g. the parse error); the last is "Failed to open layer".
    return msgs[0] if len(msgs) == 1 else "%s (%s)" % (msgs[0], msgs[-1])


class CaptureStderr:
    """Redirect fd 2 (where USD's C++ diagnostics go) into a temp file; `text` holds what was written."""

    def __init__(self):
        self.text = ""

    def __enter__(self):
        sys.stderr.flush()
        self._saved = os.dup(2)
        self._tmp = tempfile.TemporaryFile(mode="w+b")
        os.dup2(self._tmp.fileno(), 2)
        return self

    def __exit__(self, *exc):
        try:
            sys.stderr.flush()
        except Exception:
            pass
        os.dup2(self._saved, 2)
        os.close(self._saved)
        self._tmp.seek(0)
        self.text = self._tmp.read().decode("utf-8", "replace")
        self._tmp.close()
        return False


# --------------------------------------------------------------------------------------------------
# The converter
# --------------------------------------------------------------------------------------------------


class Converter:
    def __init__(self, input_path, output_path, camera=None, frame=None, subdivision_level=SUBDIVISION_LEVEL):
        """`camera`: the camera prim to render (default: the render settings' camera, else the first
        one); `frame`: the time code to read animated values at (default: the stage's start time)."""
        from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, UsdSkel, Vt  # noqa: F401

        self.Gf, self.Sdf, self.Tf, self.Usd = Gf, Sdf, Tf, Usd
        self.UsdGeom, self.UsdLux, self.UsdRender, self.UsdShade, self.Vt = UsdGeom, UsdLux, UsdRender, UsdShade, Vt
        self.UsdSkel = UsdSkel
        self._skinned = set()  # meshes whose points were skinned (their authored normals are not)
        self.input = input_path
        self.output = output_path
        self.warnings = []
        self._warned = set()
        self.materials = []  # JSON dicts
        self._material_index = {}  # key -> index
        self._material_uv = {}  # material index -> set of st primvar names its textures read
        self._material_color = {}  # material index -> the primvar its diffuse colour reads per vertex
        self.textures = []
        self._texture_index = {}
        self.lights = []
        self.meshes = []  # dicts: header data + geometry key
        self._mesh_index = {}  # (geometry key, material signature) -> mesh index or None
        self.geometries = {}  # geometry key -> Geometry or None
        self.instances = []
        # prim path -> instances of it left out for zero scale (one warning each, after traversal)
        self._zero_scale = {}
        self.texture_files = {}  # path -> True (dependencies)
        self.camera = None
        self.camera_path = camera
        self.subdivision_level = subdivision_level
        # render settings: width over height of a pixel, and how the apertures meet the image
        self.pixel_aspect, self.aspect_conform = 1.0, "expandAperture"
        self.frame = frame
        self.resolution = None
        self._extract_dir = None
        self._extracted = {}
        self._bindings = {}  # prim path -> bound materials (point-instancer leaves repeat)

    # ---- diagnostics --------------------------------------------------------------------------
    def warn(self, prim, message):
        prim = str(prim) if prim else "-"
        key = (prim, message)
        if key in self._warned:
            return
        self._warned.add(key)
        self.warnings.append({"prim": prim, "message": message})

    # ---- stage ----------------------------------------------------------------------------------
    def open_stage(self):
        Usd, Tf = self.Usd, self.Tf
        if not os.path.exists(self.input):
            raise UserError("-", "no such file")
        if os.path.isdir(self.input):
            raise UserError("-", "is a directory, not a USD file")
        try:
            with open(self.input, "rb"):
                pass
        except OSError as e:
            raise UserError("-", "cannot read: %s" % e.strerror)
        cap = CaptureStderr()
        stage = None
        try:
            with cap:
                stage = Usd.Stage.Open(self.input, Usd.Stage.LoadAll)
        except Tf.ErrorException as e:
            raise UserError("-", "cannot open the stage: %s" % parse_tf_error(e))
        self._usd_diagnostics(cap.text)
        if stage is None:
            raise UserError("-", "cannot open the stage")
        self.stage = stage
        if self.frame is not None:
            if not math.isfinite(self.frame):
                raise UserError("-", "frame %r is not a finite time code" % self.frame)
            self.time = Usd.TimeCode(self.frame)
            if stage.HasAuthoredTimeCodeRange():
                start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
                if not start <= self.frame <= end:
                    self.warn("/", "frame %g is outside the stage's time range %g to %g; animated values are "
                              "held at their nearest time sample" % (self.frame, start, end))
        elif stage.HasAuthoredTimeCodeRange():
            self.time = stage.GetStartTimeCode()
        else:
            self.time = Usd.TimeCode.EarliestTime()
        UsdGeom, Gf = self.UsdGeom, self.Gf
        self.mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
        if not UsdGeom.StageHasAuthoredMetersPerUnit(stage):
            self.warn("/", "metersPerUnit is not authored; using USD's fallback %g (centimetres)" % self.mpu)
        if not (self.mpu > 0 and math.isfinite(self.mpu)):
            raise UserError("/", "metersPerUnit must be positive, got %r" % self.mpu)
        self.up = str(UsdGeom.GetStageUpAxis(stage))
        scale = Gf.Matrix4d(1.0).SetScale(Gf.Vec3d(self.mpu))
        if self.up == "Z":
            # (x, y, z) -> (x, z, -y), as rows of a row-vector matrix.
            rot = Gf.Matrix4d(1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1)
        else:
            if self.up != "Y":
                self.warn("/", "unknown upAxis %r; treated as Y" % self.up)
            rot = Gf.Matrix4d(1.0)
        self.root = scale * rot  # row vectors: p_out = p_world * root
        self.xf = UsdGeom.XformCache(self.time)

    def _usd_diagnostics(self, text):
        """USD's own warnings/errors (printed by its C++ core) become converter warnings."""
        for line in text.splitlines():
            line = line.strip()
            if not line:
                continue
            m = re.match(r"^(?:Warning|Error|Coding Error|Runtime Error|Fatal Error|Status)?:?\s*in \S+ at line \d+ "
                         r"of \S+ -- (.*)$", line)
            msg = clean_usd_message(m.group(1) if m else line)
            msg = re.sub(r"\s*\(instantiating stage on stage @[^@]*@ <0x[0-9a-f]+>\)", "", msg)
            prim = "-"
            pm = re.match(r"^In <([^>]+)>:\s*(.*)$", msg)
            if pm:
                prim, msg = pm.group(1), pm.group(2)
            msg = re.sub(r" -- Cannot determine file format for @[^@]*@\.?", " (no file format plugin)", msg)
            self.warn(prim, "USD: " + msg)

    # ---- matrices ---------------------------------------------------------------------------------
    @staticmethod
    def cols(m):
        """Row-vector GfMatrix4d -> our column-major [[c0],[c1],[c2],[c3]] (rows written as columns)."""
        return [[float(m[i][0]), float(m[i][1]), float(m[i][2]), float(m[i][3])] for i in range(4)]

    def world(self, prim):
        return self.xf.GetLocalToWorldTransform(prim) * self.root

    def rigid(self, m, prim, what):
        """Split a row-vector matrix into an orthonormal frame (translation kept) and axis scales."""
        Gf = self.Gf
        x = Gf.Vec3d(m[0][0], m[0][1], m[0][2])
        y = Gf.Vec3d(m[1][0], m[1][1], m[1][2])
        z = Gf.Vec3d(m[2][0], m[2][1], m[2][2])
        sx, sy, sz = x.GetLength(), y.GetLength(), z.GetLength()
        if not (sx > 0 and sy > 0 and sz > 0) or not finite(sx, sy, sz):
            raise UserError(prim, "%s transform is singular or not finite" % what)
        det = Gf.Vec3d.GetDot(Gf.Cross(x, y), z)
        if det < 0:
            self.warn(prim, "%s transform is mirrored (negative determinant); the mirror is dropped" % what)
        zn = z / sz
        xo = x - zn * Gf.Vec3d.GetDot(x, zn)
        if xo.GetLength() < 1e-12:
            raise UserError(prim, "%s transform is degenerate" % what)
        xn = xo.GetNormalized()
        yn = Gf.Cross(zn, xn)
        if abs(Gf.Vec3d.GetDot(x / sx, zn)) > 1e-4 or abs(Gf.Vec3d.GetDot(y / sy, zn)) > 1e-4 or abs(Gf.Vec3d.GetDot(x / sx, y / sy)) > 1e-4:
            self.warn(prim, "%s transform has shear; it was orthonormalised" % what)
        t = m.ExtractTranslation()
        r = Gf.Matrix4d(xn[0], xn[1], xn[2], 0, yn[0], yn[1], yn[2], 0, zn[0], zn[1], zn[2], 0, t[0], t[1], t[2], 1)
        return r, (sx, sy, sz)

    # ---- traversal ------------------------------------------------------------------------------
    def run(self):
        t0 = time.time()
        self.open_stage()
        cap = CaptureStderr()
        try:
            with cap:
                self.apply_skinning()
                self.find_render_settings()
                self.traverse()
                for path, n in self._zero_scale.items():
                    # a point instancer hides instances by scaling them to zero: one line per prototype
                    self.warn(path, "transform has zero scale (no area): not rendered" if n == 1 else
                              "%d instances have zero scale (no area): not rendered" % n)
                if self.camera_path is not None:
                    self.use_camera(self.camera_path)
                elif self.camera is None:
                    self.find_camera()
        finally:
            self._usd_diagnostics(cap.text)
        if not self.instances:
            raise UserError("-", "the stage has no renderable geometry")
        if self.camera is None:
            self.warn("/", "the stage has no camera; the renderer frames the scene with a default camera")
        self.seconds = time.time() - t0

    def apply_skinning(self):
        """UsdSkel: every skinned prim posed at the conversion's time code by usd-core's skinning
        (linear or dual-quaternion blend, as the prim asks), authored into the stage's session
        layer, which is never saved. A rigidly bound prim gets a transform, a deformed mesh its
        skinned points (in the skeleton's space, placed by the skeleton's world transform)."""
        Usd, UsdGeom, UsdSkel = self.Usd, self.UsdGeom, self.UsdSkel
        roots = [p for p in self.stage.Traverse(self.predicate()) if p.IsA(UsdSkel.Root)]
        if not roots:
            return
        tc = self.time if isinstance(self.time, Usd.TimeCode) else Usd.TimeCode(self.time)
        # where the posed values are authored: at the time code they are read at (a numeric one),
        # else as the default (which, in the strongest layer, wins over weaker time samples)
        at = Usd.TimeCode.Default() if tc.IsDefault() or tc == Usd.TimeCode.EarliestTime() else tc
        self.stage.SetEditTarget(self.stage.GetSessionLayer())
        xfc = UsdGeom.XformCache(tc)
        cache = UsdSkel.Cache()
        for r in roots:
            root = UsdSkel.Root(r)
            cache.Populate(root, self.predicate())
            for binding in cache.ComputeSkelBindings(root, self.predicate()):
                skel = binding.GetSkeleton()
                query = cache.GetSkelQuery(skel)
                xforms = query.ComputeSkinningTransforms(tc) if query else None
                if xforms is None:
                    self.warn(skel.GetPath(), "the skeleton cannot be posed (invalid joints or animation); "
                              "its skinned prims are rendered in their rest shape")
                    continue
                skel_world = xfc.GetLocalToWorldTransform(skel.GetPrim())
                for target in binding.GetSkinningTargets():
                    prim = target.GetPrim()
                    shapes = target.HasBlendShapes()
                    if target.IsRigidlyDeformed() and not shapes:
                        m = target.ComputeSkinnedTransform(xforms, tc)
                        if m is None:
                            self.warn(prim.GetPath(), "rigid skinning failed; rendered unposed")
                            continue
                        world = m * skel_world
                    else:
                        attr = UsdGeom.PointBased(prim).GetPointsAttr()
                        points = attr.Get(tc)
                        if points is not None and shapes:
                            self.apply_blend_shapes(query, target, points, tc)
                        if points is None or not target.ComputeSkinnedPoints(xforms, points, tc):
                            self.warn(prim.GetPath(), "skinning failed (joint influences do not match the "
                                      "points?); rendered unposed")
                            continue
                        attr.Set(points, at)
                        world = skel_world
                        self._skinned.add(str(prim.GetPath()))
                    op = UsdGeom.Xformable(prim).MakeMatrixXform()
                    op.Set(world, at)
                    UsdGeom.Xformable(prim).SetResetXformStack(True)
        self.xf = UsdGeom.XformCache(self.time)

    def apply_blend_shapes(self, query, target, points, tc):
        """Deform `points` (in place) by the blend shapes of `target` at their animated weights."""
        UsdSkel = self.UsdSkel
        prim = target.GetPrim()
        anim = query.GetAnimQuery()
        if not anim:
            return  # no animation: every weight is 0
        weights = anim.ComputeBlendShapeWeights(tc)
        mapper = target.GetBlendShapeMapper()
        if mapper and not mapper.IsNull():
            weights = mapper.Remap(weights)
        shapes = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim))
        sub = shapes.ComputeSubShapeWeights(weights) if weights is not None else None
        if not sub or not shapes.ComputeDeformedPoints(sub[0], sub[1], sub[2], shapes.ComputeBlendShapePointIndices(),
                                                       shapes.ComputeSubShapePointOffsets(), points):
            self.warn(prim.GetPath(), "blend shapes could not be applied (weights or targets do not match); "
                      "the skinning is")

    def predicate(self):
        Usd = self.Usd
        return Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)

    def imageable_state(self, prim, inherited_purpose):
        """(skip, purpose) for a prim: invisible or proxy/guide purpose prunes the subtree."""
        UsdGeom = self.UsdGeom
        if not prim.IsA(UsdGeom.Imageable):
            return False, inherited_purpose
        img = UsdGeom.Imageable(prim)
        vis = img.GetVisibilityAttr().Get(self.time)
        if vis == UsdGeom.Tokens.invisible:
            return True, inherited_purpose
        pa = img.GetPurposeAttr()
        purpose = pa.Get(self.time) if pa.HasAuthoredValue() else inherited_purpose
        if purpose in (UsdGeom.Tokens.proxy, UsdGeom.Tokens.guide):
            return True, purpose
        return False, purpose

    def traverse(self):
        """Depth-first pre-order walk of the composed stage, instance proxies included."""
        UsdGeom, UsdShade, UsdLux = self.UsdGeom, self.UsdShade, self.UsdLux
        pred = self.predicate()
        stack = [(c, "default") for c in reversed(self.stage.GetPseudoRoot().GetFilteredChildren(pred))]
        while stack:
            prim, inherited = stack.pop()
            if prim.IsA(UsdShade.Material) or prim.IsA(UsdShade.NodeGraph) or prim.IsA(UsdShade.Shader):
                continue
            skip, purpose = self.imageable_state(prim, inherited)
            if skip:
                continue
            descend = self.visit(prim)
            if descend:
                children = prim.GetFilteredChildren(pred)
                stack.extend((c, purpose) for c in reversed(children))

    def visit(self, prim, proto=None):
        """Handle one prim. `proto` is None in world mode, else (proto_root, list) collecting leaves for a
        point instancer. Returns whether to descend into children."""
        UsdGeom, UsdLux = self.UsdGeom, self.UsdLux
        tname = prim.GetTypeName()
        if prim.IsA(UsdGeom.PointInstancer):
            if proto is None:
                self.point_instancer(prim)
            else:
                proto[1].append(("instancer", prim))
            return False
        if prim.IsA(UsdGeom.Mesh) or tname in GPRIM_TYPES or tname in TESSELLATED_TYPES:
            if prim.HasAPI(UsdLux.MeshLightAPI) or prim.HasAPI(UsdLux.LightAPI):
                self.warn(prim.GetPath(), "MeshLightAPI/LightAPI on geometry is not supported; the geometry is "
                          "rendered with its material only (use an emissiveColor to make it emit)")
            if proto is None:
                self.place_geometry(prim, self.world(prim), str(prim.GetPath()))
            else:
                proto[1].append(("geom", prim))
            return True
        if prim.IsA(UsdLux.BoundableLightBase) or prim.IsA(UsdLux.NonboundableLightBase) or prim.HasAPI(UsdLux.LightAPI):
            if proto is None:
                self.light(prim)
            else:
                self.warn(prim.GetPath(), "lights inside PointInstancer prototypes are not supported; skipped")
            return True
        if prim.IsA(UsdLux.LightFilter):
            self.warn(prim.GetPath(), "light filters are not supported; ignored")
            return False
        if prim.IsA(UsdGeom.Camera):
            return False
        if prim.IsA(UsdGeom.Gprim):
            self.warn(prim.GetPath(), "%s is not supported; skipped" % (tname or "this gprim type"))
            return True
        if tname in ("Volume", "OpenVDBAsset", "Field3DAsset"):
            self.warn(prim.GetPath(), "volumes are not supported; skipped")
            return False
        return True

    # ---- render settings and camera -------------------------------------------------------------
    def find_render_settings(self):
        UsdRender = self.UsdRender
        settings = UsdRender.Settings.GetStageRenderSettings(self.stage)
        if not settings:
            for p in self.stage.Traverse():
                if p.IsA(UsdRender.Settings):
                    settings = UsdRender.Settings(p)
                    break
        if not settings:
            return
        sp = settings.GetPrim().GetPath()
        res = settings.GetResolutionAttr().Get(self.time)
        par = settings.GetPixelAspectRatioAttr().Get(self.time)
        conform = settings.GetAspectRatioConformPolicyAttr().Get(self.time)
        cam_targets = settings.GetCameraRel().GetForwardedTargets()
        for pp in settings.GetProductsRel().GetForwardedTargets():
            prod = UsdRender.Product(self.stage.GetPrimAtPath(pp))
            if not prod:
                continue
            if prod.GetResolutionAttr().HasAuthoredValue():
                res = prod.GetResolutionAttr().Get(self.time)
            if prod.GetPixelAspectRatioAttr().HasAuthoredValue():
                par = prod.GetPixelAspectRatioAttr().Get(self.time)
            if prod.GetAspectRatioConformPolicyAttr().HasAuthoredValue():
                conform = prod.GetAspectRatioConformPolicyAttr().Get(self.time)
            if not cam_targets and prod.GetCameraRel().GetForwardedTargets():
                cam_targets = prod.GetCameraRel().GetForwardedTargets()
            break
        if res is not None:
            w, h = int(res[0]), int(res[1])
            if w > 0 and h > 0:
                self.resolution = [w, h]
            else:
                self.warn(sp, "resolution %dx%d is not positive; ignored" % (w, h))
        if par is not None:
            if not (finite(float(par)) and 1e-3 < par < 1e3):
                raise UserError(str(sp), "pixelAspectRatio %g must be between 0.001 and 1000" % par)
            self.pixel_aspect = float(par)
        if conform is not None:
            if str(conform) not in ASPECT_CONFORM:
                self.warn(sp, "unknown aspectRatioConformPolicy %r; expandAperture is used" % str(conform))
            else:
                self.aspect_conform = str(conform)
        if cam_targets and self.camera_path is None:
            cp = self.stage.GetPrimAtPath(cam_targets[0])
            if cp and cp.IsA(self.UsdGeom.Camera):
                self.convert_camera(cp)
            else:
                self.warn(sp, "camera relationship target %s is not a Camera; using the first camera" % cam_targets[0])

    def find_camera(self):
        for p in self.stage.Traverse():
            if p.IsA(self.UsdGeom.Camera):
                self.convert_camera(p)
                return

    def cameras(self):
        """Paths of the stage's cameras, in traversal order (instance proxies included)."""
        return [str(p.GetPath()) for p in self.stage.Traverse(self.predicate()) if p.IsA(self.UsdGeom.Camera)]

    def use_camera(self, path):
        """The camera the user asked for by prim path (an error naming the stage's cameras otherwise)."""
        def listing():
            cams = self.cameras()
            if not cams:
                return "the stage has no camera"
            more = " and %d more" % (len(cams) - 20) if len(cams) > 20 else ""
            return "the stage's cameras: %s%s" % (", ".join(cams[:20]), more)
        if not path.startswith("/") or not self.Sdf.Path.IsValidPathString(path):
            raise UserError(path, "not an absolute prim path (e.g. /World/Camera); %s" % listing())
        prim = self.stage.GetPrimAtPath(path)
        if not prim:
            raise UserError(path, "no such prim; %s" % listing())
        if not prim.IsA(self.UsdGeom.Camera):
            raise UserError(path, "is a %s, not a Camera; %s" % (prim.GetTypeName() or "typeless prim", listing()))
        self.convert_camera(prim)

    def convert_camera(self, prim):
        UsdGeom, Gf = self.UsdGeom, self.Gf
        path = str(prim.GetPath())
        cam = UsdGeom.Camera(prim)
        t = self.time
        m = self.world(prim)
        frame, (sx, sy, sz) = self.rigid(m, path, "camera")
        proj = cam.GetProjectionAttr().Get(t) or "perspective"
        fl_ = float(cam.GetFocalLengthAttr().Get(t))
        ha = float(cam.GetHorizontalApertureAttr().Get(t))
        va = float(cam.GetVerticalApertureAttr().Get(t))
        clip = cam.GetClippingRangeAttr().Get(t)
        near, far = float(clip[0]) * sz, float(clip[1]) * sz  # sz already includes metersPerUnit
        if proj == "orthographic":
            # USD: orthographic apertures are in tenths of a scene unit.
            ha, va = ha * 0.1 * sx, va * 0.1 * sy
        elif proj != "perspective":
            self.warn(path, "unknown projection %r; rendered as perspective" % proj)
            proj = "perspective"
        # the film's offset, in the apertures' unit (metres for orthographic, as the apertures)
        hoff = float(cam.GetHorizontalApertureOffsetAttr().Get(t) or 0.0)
        voff = float(cam.GetVerticalApertureOffsetAttr().Get(t) or 0.0)
        if proj == "orthographic":
            hoff, voff = hoff * 0.1 * sx, voff * 0.1 * sy
        if not (fl_ > 0 and ha > 0 and va > 0):
            raise UserError(path, "focalLength and apertures must be positive (got %g, %g, %g)" % (fl_, ha, va))
        # depth of field: a thin lens of radius focalLength / (2 fStop), focalLength in tenths of a
        # scene unit, focusDistance in scene units (both scaled like the clipping range)
        fstop = float(cam.GetFStopAttr().Get(t) or 0.0)
        focus = float(cam.GetFocusDistanceAttr().Get(t) or 0.0)
        lens_radius, focus_m = 0.0, 0.0
        if fstop < 0 or not math.isfinite(fstop):
            self.warn(path, "fStop %g is not a positive f-number; rendered without depth of field" % fstop)
        elif fstop > 0:
            if proj == "orthographic":
                self.warn(path, "depth of field (fStop %g) with an orthographic projection is not supported; "
                          "rendered without it" % fstop)
            elif not (focus > 0 and math.isfinite(focus)):
                self.warn(path, "fStop %g without a positive focusDistance (got %g): rendered without depth of field"
                          % (fstop, focus))
            else:
                lens_radius = fl_ * 0.1 * sz / (2.0 * fstop)
                focus_m = focus * sz
                if lens_radius > 0.25 * focus_m:
                    # e.g. focalLength 35 authored as millimetres on a stage in metres
                    self.warn(path, "the lens (radius %.3g m = focalLength %g / (2 fStop %g), focalLength in tenths "
                              "of a scene unit of %g m) is large for its focus distance %.3g m: everything not "
                              "in focus is very blurred; is focalLength in the stage's units?"
                              % (lens_radius, fl_, fstop, self.mpu, focus_m))
        self.camera = {
            "name": path,
            "transform": self.cols(frame),
            "projection": proj,
            "focal_length": fl_,
            "horizontal_aperture": ha,
            "vertical_aperture": va,
            "clipping": [near, far],
            "aperture_offset": [hoff, voff],
            "lens_radius": lens_radius,
            "focus_distance": focus_m,
        }

    # ---- point instancers -----------------------------------------------------------------------
    def collect_proto(self, root):
        """Renderable leaves of a prototype subtree: list of (prim, row-vector matrix relative to root,
        including the root's own transform only through the instance transform)."""
        UsdShade = self.UsdShade
        found = []
        pred = self.predicate()
        stack = [(root, "default")]
        while stack:
            prim, inherited = stack.pop()
            if prim.IsA(UsdShade.Material) or prim.IsA(UsdShade.Shader) or prim.IsA(UsdShade.NodeGraph):
                continue
            skip, purpose = self.imageable_state(prim, inherited)
            if skip:
                continue
            holder = (root, [])
            descend = self.visit(prim, holder)
            for kind, leaf in holder[1]:
                rel, _ = self.xf.ComputeRelativeTransform(leaf, root)
                if kind == "geom":
                    found.append((leaf, rel, ""))
                else:  # a nested instancer: expand its instances relative to our root
                    for lf, lrel, suffix in self.expand_instancer(leaf):
                        found.append((lf, lrel * rel, suffix))
            if descend:
                stack.extend((c, purpose) for c in reversed(prim.GetFilteredChildren(pred)))
        return found

    def expand_instancer(self, prim):
        """(leaf prim, matrix relative to the instancer's own space, name suffix) for every instance."""
        UsdGeom = self.UsdGeom
        path = prim.GetPath()
        pi = UsdGeom.PointInstancer(prim)
        t = self.time
        if t == self.Usd.TimeCode.EarliestTime():
            samples = pi.GetPositionsAttr().GetTimeSamples()
            t = self.Usd.TimeCode(samples[0]) if samples else self.Usd.TimeCode.Default()
        protos = pi.GetPrototypesRel().GetForwardedTargets()
        proto_indices = int_list(pi.GetProtoIndicesAttr().Get(t))
        if not protos:
            self.warn(path, "PointInstancer has no prototypes; nothing instanced")
            return []
        if not proto_indices:
            self.warn(path, "PointInstancer has no protoIndices; nothing instanced")
            return []
        xforms = pi.ComputeInstanceTransformsAtTime(t, t, UsdGeom.PointInstancer.IncludeProtoXform,
                                                    UsdGeom.PointInstancer.IgnoreMask)
        if xforms is None or len(xforms) != len(proto_indices):
            self.warn(path, "PointInstancer positions/orientations/scales do not match protoIndices; skipped")
            return []
        mask = list(pi.ComputeMaskAtTime(t) or [])
        leaves = []
        for pp in protos:
            proot = self.stage.GetPrimAtPath(pp)
            if not proot:
                self.warn(path, "prototype %s does not exist" % pp)
                leaves.append([])
            else:
                leaves.append(self.collect_proto(proot))
        out = []
        bad = 0
        for i, j in enumerate(proto_indices):
            if mask and not mask[i]:
                continue
            if j < 0 or j >= len(leaves):
                bad += 1
                continue
            for leaf, rel, suffix in leaves[j]:
                out.append((leaf, rel * xforms[i], "[%d]%s" % (i, suffix)))
        if bad:
            self.warn(path, "%d protoIndices out of range (%d prototypes); those instances skipped" % (bad, len(protos)))
        return out

    def point_instancer(self, prim):
        base = self.world(prim)
        for leaf, rel, suffix in self.expand_instancer(prim):
            self.place_geometry(leaf, rel * base, "%s%s" % (leaf.GetPath(), suffix))

    # ---- geometry placement -----------------------------------------------------------------------
    def place_geometry(self, prim, matrix, name):
        """Add an instance of `prim`'s mesh (built once per prototype and material assignment)."""
        # A zero scale leaves no area to render: skipped, and counted for one warning per prim
        # after the traversal (not an error).
        if zero_scale(matrix):
            key = str(prim.GetPath())
            self._zero_scale[key] = self._zero_scale.get(key, 0) + 1
            return
        src = prim.GetPrimInPrototype() if prim.IsInstanceProxy() else prim
        src_path = str(src.GetPath())
        ppath = str(prim.GetPath())
        mats = self._bindings.get(ppath)
        if mats is None:
            mats = self._bindings[ppath] = self.bound_materials(prim)
        sig = (src_path, mats["signature"])
        if sig in self._mesh_index:
            idx = self._mesh_index[sig]
        else:
            idx = self.build_mesh_entry(prim, src_path, mats)
            self._mesh_index[sig] = idx
        if idx is None:
            return
        self.instances.append({"mesh": idx, "name": name, "transform": self.cols(matrix)})

    def build_mesh_entry(self, prim, src_path, mats):
        # Texture coordinates: the primvar the bound materials read.
        wanted = []
        for mi in mats["all"]:
            for n in sorted(self._material_uv.get(mi, ())):
                if n not in wanted:
                    wanted.append(n)
        # Vertex colours: the primvar the bound materials' diffuse colour reads (one per mesh).
        colors = []
        for mi in mats["all"]:
            c = self._material_color.get(mi)
            if c and c not in colors:
                colors.append(c)
        if len(colors) > 1:
            self.warn(prim.GetPath(), "its materials read the vertex colours of several primvars (%s); all use %s"
                      % (", ".join(colors), colors[0]))
        color = colors[0] if colors else None
        gkey = (src_path, tuple(wanted), color)
        if gkey not in self.geometries:
            self.geometries[gkey] = self.build_geometry(prim, wanted, color)
        geo = self.geometries[gkey]
        if geo is None:
            return None
        # Material id per triangle.
        face_mat = mats["faces"]
        if face_mat is None:
            ids = [mats["mesh"]]
        else:
            tf = geo.tri_face
            ids = face_mat if tf is None else [face_mat[f] for f in tf]
            if len(set(ids)) <= 1:
                ids = [ids[0] if ids else mats["mesh"]]
        self.meshes.append({"name": str(prim.GetPath()), "geometry": geo, "material_ids": ids})
        return len(self.meshes) - 1

    # ---- materials ------------------------------------------------------------------------------
    def compute_binding(self, prim):
        UsdShade = self.UsdShade
        api = UsdShade.MaterialBindingAPI(prim)
        mat, _ = api.ComputeBoundMaterial(UsdShade.Tokens.full)
        if not mat:
            mat, _ = api.ComputeBoundMaterial(UsdShade.Tokens.preview)
        return mat if mat else None

    def bound_materials(self, prim):
        """Material indices for a geometry prim: mesh-level, and per face from materialBind subsets."""
        UsdShade, UsdGeom = self.UsdShade, self.UsdGeom
        mat = self.compute_binding(prim)
        subsets = UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets() if prim.IsA(UsdGeom.Mesh) else []
        assigned = []
        nfaces = 0
        if subsets:
            nfaces = len(UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get(self.time) or [])
            for sub in subsets:
                sp = sub.GetPrim()
                smat = self.compute_binding(sp)
                if smat is None:
                    continue  # an unbound subset keeps the mesh's material
                faces = int_list(sub.GetIndicesAttr().Get(self.time))
                bad = sum(1 for f in faces if not 0 <= f < nfaces)
                if bad:
                    self.warn(sp.GetPath(), "%d face indices out of range (%d faces); ignored" % (bad, nfaces))
                assigned.append((str(sp.GetName()), self.material_for(smat), faces))
        covered = set()
        for _, _, faces in assigned:
            covered.update(f for f in faces if 0 <= f < nfaces)
        if assigned and len(covered) == nfaces and mat is None:
            mesh_mi = assigned[0][1]  # every face has a subset material: no default needed
        else:
            mesh_mi = self.material_for(mat) if mat else self.default_material(prim)
        result = {"mesh": mesh_mi, "faces": None, "all": [mesh_mi], "signature": (mesh_mi,)}
        if not assigned:
            return result
        face_mat = [mesh_mi] * nfaces
        sig = [mesh_mi]
        for name, mi, faces in assigned:
            for f in faces:
                if 0 <= f < nfaces:
                    face_mat[f] = mi
            sig.append((name, mi))
            if mi not in result["all"]:
                result["all"].append(mi)
        result["faces"] = face_mat
        result["signature"] = tuple(sig)
        return result

    def add_material(self, key, mdict, uvnames=(), color=None):
        self.materials.append(mdict)
        idx = len(self.materials) - 1
        self._material_index[key] = idx
        self._material_uv[idx] = set(uvnames)
        if color:
            self._material_color[idx] = color
        return idx

    def default_material(self, prim):
        """Unbound geometry: displayColor as a diffuse colour (a varying one on a mesh: its vertex colours),
        else the spec's grey."""
        UsdGeom = self.UsdGeom
        color, opacity, vertex = None, None, False
        if prim.IsA(UsdGeom.Gprim):
            g = UsdGeom.Gprim(prim)
            for pv, what in ((g.GetDisplayColorPrimvar(), "color"), (g.GetDisplayOpacityPrimvar(), "opacity")):
                if not pv or not pv.HasAuthoredValue():
                    continue
                vals = pv.ComputeFlattened(self.time)
                if vals is None or len(vals) == 0:
                    continue
                if len(vals) > 1:
                    same = all(v == vals[0] for v in vals)
                    if not same and what == "color" and any(prim.IsA(k) for k in (
                            UsdGeom.Mesh, UsdGeom.Curves, UsdGeom.Points)):
                        vertex = True  # the mesh's colours, per vertex (the average where it has none)
                    elif not same:
                        self.warn(prim.GetPath(), "per-%s display%s is not supported; using its average"
                                  % (pv.GetInterpolation(), what.capitalize()))
                if what == "color":
                    n = len(vals)
                    color = tuple(round(sum(float(v[c]) for v in vals) / n, 6) for c in range(3))
                else:
                    opacity = round(sum(float(v) for v in vals) / len(vals), 6)
        key = ("default", color, opacity, vertex)
        if key in self._material_index:
            return self._material_index[key]
        m = {"kind": "preview_surface", "name": "%s.displayColor" % prim.GetPath() if color else "<default grey>"}
        if color is not None:
            m["diffuse_color"] = {"value": list(color), "texture": None}
            if vertex:
                m["diffuse_color"]["vertex"] = True
        if opacity is not None and opacity != 1.0:
            m["opacity"] = {"value": opacity, "texture": None}
        return self.add_material(key, m, (), "displayColor" if vertex else None)

    def shader_desc(self, shader):
        sid = shader.GetShaderId()
        if sid:
            return str(sid)
        src = shader.GetImplementationSource()
        if src == "sourceAsset":
            for ctx in ("mdl", "osl", "glslfx", ""):
                a = shader.GetSourceAsset(ctx)
                if a:
                    return "%s (%s)" % (a.path, ctx or "sourceAsset")
        return "an unidentified shader"

    def material_for(self, mat):
        UsdShade = self.UsdShade
        mpath = str(mat.GetPath())
        key = ("usd", mpath)
        if key in self._material_index:
            return self._material_index[key]
        shader = None
        src = mat.ComputeSurfaceSource("")
        other = []
        if src and src[0] and src[0].GetShaderId() == "UsdPreviewSurface":
            shader = src[0]
        else:
            if src and src[0]:
                other.append(self.shader_desc(src[0]))
            for out in mat.GetSurfaceOutputs():
                ctx = UsdShade.Utils.GetBaseNameAndType(out.GetFullName())[0]
                ctx = ctx.split(":")[0] if ":" in ctx else ""
                s = mat.ComputeSurfaceSource(ctx)
                if s and s[0]:
                    if s[0].GetShaderId() == "UsdPreviewSurface":
                        shader = s[0]
                        break
                    d = self.shader_desc(s[0])
                    if d not in other:
                        other.append(d)
            if shader is not None:
                self.warn(mpath, "surface shader %s is not supported; using the material's UsdPreviewSurface"
                          % ", ".join(other))
        if shader is None:
            if other:
                self.warn(mpath, "surface shader %s is not UsdPreviewSurface; rendered as an error material"
                          % ", ".join(other))
            else:
                self.warn(mpath, "material has no surface shader; rendered as an error material")
            return self.add_material(key, {"kind": "error", "name": mpath})
        m, uvnames, color = self.preview_surface(mpath, shader)
        return self.add_material(key, m, uvnames, color)

    PREVIEW_INPUTS = {
        # usd name: (field, kind, default)
        "diffuseColor": ("diffuse_color", "color", (0.18, 0.18, 0.18)),
        "emissiveColor": ("emissive_color", "color", (0.0, 0.0, 0.0)),
        "specularColor": ("specular_color", "color", (0.0, 0.0, 0.0)),
        "metallic": ("metallic", "float", 0.0),
        "roughness": ("roughness", "float", 0.5),
        "clearcoat": ("clearcoat", "float", 0.0),
        "clearcoatRoughness": ("clearcoat_roughness", "float", 0.01),
        "opacity": ("opacity", "float", 1.0),
    }
    KNOWN_INPUTS = set(PREVIEW_INPUTS) | {"useSpecularWorkflow", "opacityThreshold", "ior", "normal",
                                          "displacement", "occlusion", "opacityMode"}

    def resolve(self, inp):
        """What drives a shader input: ('value', v) | ('output', shader, output name) | ('none', None)."""
        UsdShade = self.UsdShade
        attrs = inp.GetValueProducingAttributes(False)
        if not attrs:
            if inp.HasConnectedSource():
                return ("dangling", None)
            return ("none", None)
        a = attrs[0]
        base, kind = UsdShade.Utils.GetBaseNameAndType(a.GetName())
        if kind == UsdShade.AttributeType.Output:
            return ("output", UsdShade.Shader(a.GetPrim()), str(base))
        v = a.Get(self.time)
        if v is None:
            return ("none", None)
        return ("value", v)

    def input_value(self, shader, name, default):
        inp = shader.GetInput(name)
        if not inp:
            return default
        r = self.resolve(inp)
        if r[0] == "value":
            return r[1]
        return default

    def preview_surface(self, mpath, shader):
        sp = shader.GetPath()
        m = {"kind": "preview_surface", "name": mpath}
        uvnames = set()
        color = None  # the primvar a UsdPrimvarReader gives the diffuse colour from
        for inp in shader.GetInputs():
            base = inp.GetBaseName()
            if base not in self.KNOWN_INPUTS:
                if inp.GetAttr().HasAuthoredValue() or inp.HasConnectedSource():
                    self.warn(sp, "input %r is not part of UsdPreviewSurface; ignored" % str(base))
        for uname, (field, kind, default) in self.PREVIEW_INPUTS.items():
            inp = shader.GetInput(uname)
            value, tex = default, None
            if inp:
                r = self.resolve(inp)
                if r[0] == "value":
                    value = r[1]
                elif r[0] == "output" and uname == "diffuseColor" and str(r[1].GetShaderId()) in COLOR_READERS:
                    # per-vertex colour: the mesh's primvar, or the reader's fallback without one
                    color = str(self.input_value(r[1], "varname", "") or "")
                    value = self.input_value(r[1], "fallback", (0.0, 0.0, 0.0))
                    if not color:
                        self.warn(r[1].GetPath(), "primvar reader without a varname; its fallback is used")
                elif r[0] == "output":
                    tex, uv = self.texture_from(r[1], r[2], "%s.inputs:%s" % (sp, uname), kind)
                    if uv:
                        uvnames.add(uv)
                    vv = inp.GetAttr().Get(self.time)
                    if isinstance(tex, tuple):  # no file: the texture's constant fallback
                        vv, tex = tex[1], None
                    if vv is not None:
                        value = vv
                elif r[0] == "dangling":
                    self.warn(sp, "inputs:%s is connected to nothing; using its default" % uname)
            if kind == "color":
                try:
                    value = vec(value, 3)
                except Exception:
                    self.warn(sp, "inputs:%s has an unexpected type; using the default" % uname)
                    value = list(default)
            else:
                try:
                    value = float(value)
                except Exception:
                    self.warn(sp, "inputs:%s has an unexpected type; using the default" % uname)
                    value = float(default)
            m[field] = {"value": value, "texture": tex}
            if uname == "diffuseColor" and color:
                m[field]["vertex"] = True
        # Inputs that cannot come from textures in our format.
        for uname, field, default, conv in (("useSpecularWorkflow", "use_specular_workflow", 0, lambda v: bool(int(v))),
                                             ("opacityThreshold", "opacity_threshold", 0.0, float),
                                             ("ior", "ior", 1.5, float)):
            inp = shader.GetInput(uname)
            v = default
            if inp:
                r = self.resolve(inp)
                if r[0] == "value":
                    v = r[1]
                elif r[0] in ("output", "dangling"):
                    self.warn(sp, "inputs:%s cannot be textured; using its default %s" % (uname, default))
            try:
                m[field] = conv(v)
            except Exception:
                self.warn(sp, "inputs:%s has an unexpected type; using the default" % uname)
                m[field] = conv(default)
        # Normal map.
        m["normal_map"] = None
        inp = shader.GetInput("normal")
        if inp:
            r = self.resolve(inp)
            if r[0] == "output":
                tex, uv = self.texture_from(r[1], r[2], "%s.inputs:normal" % sp, "normal")
                if uv:
                    uvnames.add(uv)
                m["normal_map"] = None if isinstance(tex, tuple) else tex
            elif r[0] == "value":
                n = vec(r[1], 3)
                if any(abs(a - b) > 1e-6 for a, b in zip(n, (0.0, 0.0, 1.0))):
                    self.warn(sp, "a constant inputs:normal %s is not supported; ignored" % n)
        mode = self.input_value(shader, "opacityMode", "transparent")
        if mode not in ("transparent", None):
            self.warn(sp, "opacityMode %r is not supported; opacity is treated as transparency" % str(mode))
        inp = shader.GetInput("displacement")
        if inp and (inp.HasConnectedSource() or (inp.GetAttr().HasAuthoredValue() and self.input_value(shader, "displacement", 0.0))):
            self.warn(sp, "displacement is not supported; ignored")
        return m, uvnames, color

    def texture_from(self, node, output, where, kind):
        """Texture index for a UsdUVTexture output driving an input (and the st primvar name it reads)."""
        sid = node.GetShaderId()
        npath = node.GetPath()
        if sid != "UsdUVTexture":
            self.warn(npath, "%s drives %s; only UsdUVTexture is supported, so the input's value is used"
                      % (self.shader_desc(node), where))
            return None, None
        if output not in ("rgb", "r", "g", "b", "a"):
            self.warn(npath, "output %r is not supported; using rgb" % output)
            output = "rgb"
        t = self.time
        Sdf = self.Sdf
        # file
        finp = node.GetInput("file")
        asset, asset_attr = None, None
        if finp:
            r = self.resolve(finp)
            if r[0] == "value":
                asset = r[1]
                asset_attr = finp.GetValueProducingAttributes(False)[0]
        if not isinstance(asset, Sdf.AssetPath) or not asset.path:
            fb = vec(self.input_value(node, "fallback", (0.0, 0.0, 0.0, 1.0)), 4)
            value = fb[:3] if kind == "color" else fb["rgba".index(output[0])]
            self.warn(npath, "UsdUVTexture has no file; its fallback %s is used as a constant" % (value,))
            return ("constant", value), None
        path = self.resolve_texture(asset, asset_attr, npath)

        def tok(name, default):
            v = self.input_value(node, name, default)
            return str(v) if v is not None else default

        wraps = []
        for name in ("wrapS", "wrapT"):
            w = tok(name, "useMetadata")
            if w == "useMetadata":
                w = "black"  # no image format we read carries wrap metadata: the spec's fallback is black
            if w not in ("repeat", "mirror", "clamp", "black"):
                self.warn(npath, "unknown %s %r; using black" % (name, w))
                w = "black"
            wraps.append(w)

        def f4(name, default):
            v = self.input_value(node, name, default)
            try:
                return vec(v, 4)
            except Exception:
                self.warn(npath, "inputs:%s has an unexpected type; using the default" % name)
                return list(default)

        scale = f4("scale", (1.0, 1.0, 1.0, 1.0))
        bias = f4("bias", (0.0, 0.0, 0.0, 0.0))
        fallback = f4("fallback", (0.0, 0.0, 0.0, 1.0))
        cs = tok("sourceColorSpace", "auto")
        if cs not in ("sRGB", "raw", "auto"):
            self.warn(npath, "sourceColorSpace %r is not supported; using auto" % cs)
            cs = "auto"
        if asset_attr is not None:
            acs = asset_attr.GetColorSpace() if asset_attr.HasColorSpace() else ""
            if acs:
                low = acs.lower()
                if low in ("srgb", "srgb_texture", "srgb_rec709_scene"):
                    cs = "sRGB"
                elif low in ("raw", "lin_rec709", "lin_rec709_scene", "linear", "lin_srgb"):
                    cs = "raw"
                else:
                    self.warn(npath, "file colorSpace %r is not converted; read as %s" % (acs, cs))
        # st
        uvname, st_transform = self.texture_st(node)
        desc = {"path": path, "wrap_s": wraps[0], "wrap_t": wraps[1], "scale": scale, "bias": bias,
                "color_space": cs, "output": output, "fallback": fallback}
        if st_transform != IDENTITY_2D:
            desc["st_transform"] = st_transform
        key = json.dumps(desc, sort_keys=True)
        if key not in self._texture_index:
            # the first prim that reads it, for the renderer's warnings (not part of the key)
            desc["prim"] = str(npath)
            self.textures.append(desc)
            self._texture_index[key] = len(self.textures) - 1
        return self._texture_index[key], uvname

    def texture_st(self, node):
        """The primvar name a texture's st reads (or None) and the affine map of the UsdTransform2d
        nodes between them (`[[a, b, c], [d, e, f]]`: st' = (a s + b t + c, d s + e t + f))."""
        npath = node.GetPath()
        sinp = node.GetInput("st")
        m = IDENTITY_2D
        if not sinp:
            self.warn(npath, "st is not connected (the spec samples st = (0, 0)); the mesh's texture "
                      "coordinates are used")
            return None, m
        r = self.resolve(sinp)
        depth = 0
        while r[0] == "output" and depth < 8:
            depth += 1
            src = r[1]
            sid = src.GetShaderId()
            if sid == "UsdTransform2d":
                # the spec: scale, then rotate counter-clockwise by `rotation` degrees, then translate
                rot = float(self.input_value(src, "rotation", 0.0) or 0.0)
                sc = vec(self.input_value(src, "scale", (1.0, 1.0)), 2)
                tr = vec(self.input_value(src, "translation", (0.0, 0.0)), 2)
                if not finite(rot, *sc, *tr):
                    raise UserError(src.GetPath(), "UsdTransform2d has a non-finite value (rotation %r, scale %r, "
                                    "translation %r)" % (rot, sc, tr))
                c, s = math.cos(math.radians(rot)), math.sin(math.radians(rot))
                node_m = [[c * sc[0], -s * sc[1], tr[0]], [s * sc[0], c * sc[1], tr[1]]]
                m = compose_2d(m, node_m)  # the nodes nearer the texture apply last
                ii = src.GetInput("in")
                if not ii:
                    self.warn(src.GetPath(), "UsdTransform2d has no input; the mesh's texture coordinates are "
                              "transformed")
                    return None, m
                r = self.resolve(ii)
                continue
            if sid and str(sid).startswith("UsdPrimvarReader"):
                v = self.input_value(src, "varname", "st")
                return (str(v) if v else "st"), m
            self.warn(src.GetPath(), "%s drives a texture's st; not supported, the mesh's texture coordinates "
                      "are used" % self.shader_desc(src))
            return None, m
        if r[0] == "value":
            self.warn(npath, "st is a constant; the mesh's texture coordinates are used instead")
        elif r[0] != "output":
            self.warn(npath, "st is not connected (the spec samples st = (0, 0)); the mesh's texture "
                      "coordinates are used")
        return None, m

    def resolve_texture(self, asset, attr, where):
        """Absolute path of a texture asset; package members are extracted next to the output."""
        authored = asset.path
        if "<UDIM>" in authored:
            self.warn(where, "UDIM textures are not supported (%s); the fallback is used" % authored)
            return self.anchor(authored, attr)
        resolved = asset.resolvedPath
        if not resolved:
            guess = self.anchor(authored, attr)
            self.warn(where, "texture file %s not found; its fallback is used" % guess)
            if os.path.isabs(guess):
                self.texture_files[os.path.abspath(guess)] = True  # recorded as absent
            return guess
        if resolved.endswith("]") and "[" in resolved:
            return self.extract_packaged(resolved, where)
        if not os.path.isfile(resolved):
            self.warn(where, "texture file %s not found; its fallback is used" % resolved)
            self.texture_files[os.path.abspath(resolved)] = True  # recorded as absent
            return resolved
        real = os.path.abspath(resolved)
        self.texture_files[real] = True
        return real

    def anchor(self, authored, attr):
        """Best guess of where a missing asset was expected: relative to the layer that authored it."""
        if os.path.isabs(authored) or attr is None:
            return authored
        try:
            stack = attr.GetPropertyStack(self.time)
            real = stack[0].layer.realPath if stack else ""
        except Exception:
            real = ""
        if not real:
            return authored
        if "[" in real and real.endswith("]"):
            real = real[:real.index("[")]
        return os.path.normpath(os.path.join(os.path.dirname(real), authored))

    def extract_packaged(self, resolved, where):
        """'/a/b.usdz[tex/c.png]' (possibly nested) -> a real file under OUTPUT.textures/."""
        if resolved in self._extracted:
            return self._extracted[resolved]
        outer = resolved[:resolved.index("[")]
        inner = resolved[len(outer) + 1:-1]
        try:
            data = None
            with zipfile.ZipFile(outer) as z:
                name = inner
                rest = None
                if "[" in inner:
                    name = inner[:inner.index("[")]
                    rest = inner[len(name) + 1:-1]
                data = z.read(name)
                while rest is not None:
                    with zipfile.ZipFile(io.BytesIO(data)) as z2:
                        name = rest
                        rest = None
                        if "[" in name:
                            n2 = name[:name.index("[")]
                            rest = name[len(n2) + 1:-1]
                            name = n2
                        data = z2.read(name)
        except (OSError, KeyError, zipfile.BadZipFile) as e:
            self.warn(where, "cannot extract %s: %s; its fallback is used" % (resolved, e))
            return resolved
        if self._extract_dir is None:
            self._extract_dir = os.path.abspath(self.output) + ".textures"
            os.makedirs(self._extract_dir, exist_ok=True)
        digest = hashlib.sha256(resolved.encode("utf-8")).hexdigest()[:12]
        target = os.path.join(self._extract_dir, "%s_%s" % (digest, os.path.basename(name)))
        with open(target + ".tmp", "wb") as f:
            f.write(data)
        os.replace(target + ".tmp", target)
        self.texture_files[os.path.abspath(outer)] = True
        self._extracted[resolved] = target
        return target

    # ---- meshes ---------------------------------------------------------------------------------
    def build_geometry(self, prim, uv_wanted, color=None):
        UsdGeom = self.UsdGeom
        if prim.IsA(UsdGeom.Mesh):
            return self.mesh_geometry(prim, uv_wanted, color)
        if prim.IsA(UsdGeom.Curves) or prim.IsA(UsdGeom.Points):
            return self.tessellated_geometry(prim, color)
        if prim.IsA(UsdGeom.NurbsPatch):
            return self.patch_geometry(prim)
        if prim.IsA(UsdGeom.TetMesh):
            return self.tet_geometry(prim)
        if color:
            self.warn(prim.GetPath(), "vertex colours (%s) of a %s are not read; its material's fallback colour is "
                      "used" % (color, prim.GetTypeName()))
        return self.gprim_geometry(prim)

    def pick_uv(self, prim, wanted):
        """The texture-coordinate primvar of a mesh: one the materials read, else `st`, else the first
        texCoord2f primvar."""
        UsdGeom, Sdf = self.UsdGeom, self.Sdf
        api = UsdGeom.PrimvarsAPI(prim)
        path = prim.GetPath()
        two = {str(Sdf.ValueTypeNames.TexCoord2fArray), str(Sdf.ValueTypeNames.Float2Array),
               str(Sdf.ValueTypeNames.TexCoord2dArray), str(Sdf.ValueTypeNames.Double2Array),
               str(Sdf.ValueTypeNames.TexCoord2hArray), str(Sdf.ValueTypeNames.Half2Array)}
        found = None
        for n in wanted:
            pv = api.GetPrimvar(n)
            if pv and pv.HasAuthoredValue() and str(pv.GetTypeName()) in two:
                if found is None:
                    found = pv
                elif n != found.GetPrimvarName():
                    self.warn(path, "materials read texture coordinates %r and %r; only %r is used"
                              % (str(found.GetPrimvarName()), n, str(found.GetPrimvarName())))
            elif n:
                self.warn(path, "a bound material reads texture coordinates %r, which the mesh does not have" % n)
        if found is not None:
            return found
        pv = api.GetPrimvar("st")
        if pv and pv.HasAuthoredValue() and str(pv.GetTypeName()) in two:
            return pv
        for pv in api.GetPrimvarsWithAuthoredValues():
            if str(pv.GetTypeName()) in (str(Sdf.ValueTypeNames.TexCoord2fArray), str(Sdf.ValueTypeNames.TexCoord2dArray),
                                         str(Sdf.ValueTypeNames.TexCoord2hArray)):
                return pv
        return None

    def plan(self, prim, what, values, width, interp, indices, npts, nf, nfv, corner_face):
        """How an attribute maps onto the mesh: ('vertex', per-point index list or None) or
        ('corner', per-corner index list or None = identity); None when unusable (warned)."""
        path = prim.GetPath()
        n = len(values) // width
        idx = int_list(indices) if indices is not None and len(indices) else None
        if idx is not None and (min(idx) < 0 or max(idx) >= n):
            self.warn(path, "%s indices are out of range (%d values); %s ignored" % (what, n, what))
            return None
        count = len(idx) if idx is not None else n
        if interp == "constant":
            if count < 1:
                return None
            return ("vertex", [idx[0] if idx else 0] * npts)
        if interp in ("vertex", "varying"):
            if count != npts:
                self.warn(path, "%s has %d %s values for %d points; ignored" % (what, count, interp, npts))
                return None
            return ("vertex", idx)
        if interp == "uniform":
            if count != nf:
                self.warn(path, "%s has %d uniform values for %d faces; ignored" % (what, count, nf))
                return None
            cf = corner_face()
            return ("corner", [idx[f] for f in cf] if idx else cf)
        if interp == "faceVarying":
            if count != nfv:
                self.warn(path, "%s has %d faceVarying values for %d face-vertices; ignored" % (what, count, nfv))
                return None
            return ("corner", idx)
        self.warn(path, "%s has unknown interpolation %r; ignored" % (what, interp))
        return None

    def mesh_geometry(self, prim, uv_wanted, color=None):
        UsdGeom = self.UsdGeom
        t = self.time
        path = str(prim.GetPath())
        mesh = UsdGeom.Mesh(prim)
        pts_vt = mesh.GetPointsAttr().Get(t)
        fvc_vt = mesh.GetFaceVertexCountsAttr().Get(t)
        fvi_vt = mesh.GetFaceVertexIndicesAttr().Get(t)
        if pts_vt is None or len(pts_vt) == 0 or fvc_vt is None or len(fvc_vt) == 0:
            self.warn(path, "mesh has no points or faces; skipped")
            return None
        P = f32_bytes(pts_vt, 3)
        npts = len(pts_vt)
        fvc = int_list(fvc_vt)
        fvi = int_list(fvi_vt)
        nf, nfv = len(fvc), len(fvi)
        if min(fvc) < 0:
            raise UserError(path, "faceVertexCounts contains negative counts")
        if sum(fvc) != nfv:
            raise UserError(path, "faceVertexCounts sum to %d but faceVertexIndices has %d entries" % (sum(fvc), nfv))
        if nfv and (min(fvi) < 0 or max(fvi) >= npts):
            bad = next(i for i in fvi if i < 0 or i >= npts)
            raise UserError(path, "faceVertexIndices: vertex index %d out of range (mesh has %d points)" % (bad, npts))
        scheme = mesh.GetSubdivisionSchemeAttr().Get(t)
        subdiv = scheme not in ("none", None)
        left = mesh.GetOrientationAttr().Get(t) == UsdGeom.Tokens.leftHanded
        holes = set(int_list(mesh.GetHoleIndicesAttr().Get(t)))
        ref = self.refinement(prim, mesh, scheme, npts, fvc, fvi) if subdiv else None
        cage = (npts, nf, nfv, fvc)
        if ref is not None:
            p = array.array("f")
            p.frombytes(P)
            raw = ref.points(p.tolist(), 3)
            P = array.array("f", ref.project(raw, 3)).tobytes()
            # the limit surface's own normals where its tangent masks hold (smooth points)
            limit_normals = ref.limit_normals(raw)
            del raw
            npts, fvc, fvi = ref.npts, ref.fvc, ref.fvi
            nf, nfv = len(fvc), len(fvi)
            holes = {f for f, q in enumerate(ref.parent_face) if q in holes}
        # Triangulation (fan) into corner indices.
        if not holes and fvc.count(3) == nf and not left and ref is None:
            tri_corners, tri_face = None, None
            ntri = nf
        else:
            tri_corners, tri_face = [], []
            off = 0
            degenerate = 0
            for f, c in enumerate(fvc):
                if c >= 3 and f not in holes:
                    if c == 3:
                        tri_corners.extend((off, off + 2, off + 1) if left else (off, off + 1, off + 2))
                        tri_face.append(f)
                    else:
                        for k in range(1, c - 1):
                            tri_corners.extend((off, off + k + 1, off + k) if left else (off, off + k, off + k + 1))
                            tri_face.append(f)
                elif c < 3:
                    degenerate += 1
                off += c
            if degenerate:
                self.warn(path, "%d faces with fewer than 3 vertices skipped" % degenerate)
            ntri = len(tri_face)
            if ntri == 0:
                self.warn(path, "mesh has no triangles after removing holes and degenerate faces; skipped")
                return None
            if ref is not None:
                tri_face = [ref.parent_face[f] for f in tri_face]  # subsets name faces of the cage
        _cf = []

        def corner_face():
            if not _cf:
                _cf.extend(f for f, c in enumerate(fvc) for _ in range(c))
            return _cf

        attrs = []  # (name, values bytes, width, plan)
        # Normals: primvars:normals wins over the normals attribute.
        api = UsdGeom.PrimvarsAPI(prim)
        npv = api.GetPrimvar("normals")
        nvals, ninterp, nidx = None, None, None
        if npv and npv.HasAuthoredValue():
            nvals, ninterp, nidx = npv.Get(t), npv.GetInterpolation(), npv.GetIndices(t)
        elif mesh.GetNormalsAttr().HasAuthoredValue():
            nvals, ninterp = mesh.GetNormalsAttr().Get(t), mesh.GetNormalsInterpolation()
        nb = f32_bytes(nvals, 3) if nvals is not None else b""
        if nvals is not None and path in self._skinned:
            self.warn(path, "authored normals are not skinned; smooth normals are computed from the skinned points")
            nvals, nb = None, b""
        if nvals is not None and ref is not None:
            self.warn(path, "authored normals are ignored on a subdivision surface (as USD specifies); smooth "
                      "normals are computed from the refined points")
            nvals, nb = None, b""
        if nvals is None and ref is not None and ref.hard_edges:
            # sharp creases stay hard edges in the shading: normals per smooth fan of each point
            p = array.array("f")
            p.frombytes(P)
            cn, cidx = ref.corner_normals(p.tolist(), holes, limit_normals)
            attrs.append(("normals", array_f32(cn), 12, ("corner", cidx)))
        elif nvals is None and (path in self._skinned or ref is not None):
            nb = self.smooth_normals(P, npts, fvi, tri_corners, nfv)
            if ref is not None:
                nb = with_exact_normals(nb, limit_normals)
            attrs.append(("normals", nb, 12, ("vertex", None)))
        elif nvals is not None and len(nvals) and len(nb) != 12 * len(nvals):
            self.warn(path, "normals are not 3-vectors; ignored")
        elif nvals is not None and len(nvals):
            p = self.plan(prim, "normals", nb, 12, ninterp, nidx, npts, nf, nfv, corner_face)
            if p is not None:
                attrs.append(("normals", nb, 12, p))
        elif subdiv:
            attrs.append(("normals", self.smooth_normals(P, npts, fvi, tri_corners, nfv), 12, ("vertex", None)))
        uvpv = self.pick_uv(prim, uv_wanted)
        if uvpv is not None:
            vals = uvpv.Get(t)
            ub = f32_bytes(vals, 2) if vals is not None else b""
            if vals is not None and len(vals) and len(ub) != 8 * len(vals):
                self.warn(path, "primvars:%s is not 2-vectors; ignored" % uvpv.GetPrimvarName())
            elif vals is not None and len(vals):
                p = self.plan_refined(prim, "primvars:%s" % uvpv.GetPrimvarName(), ub, 2, uvpv.GetInterpolation(),
                                      uvpv.GetIndices(t), ref, cage, corner_face)
                if p is not None:
                    ub, p = p
                if p is not None:
                    attrs.append(("uvs", ub, 8, p))
        if color:
            cpv = api.GetPrimvar(color)
            vals = cpv.Get(t) if cpv and cpv.HasAuthoredValue() else None
            cb = f32_bytes(vals, 3) if vals is not None else b""
            if vals is None or not len(vals):
                self.warn(path, "has no primvars:%s for its material's vertex colours; the material's fallback "
                          "colour is used" % color)
            elif len(cb) != 12 * len(vals):
                self.warn(path, "primvars:%s is not 3-vectors; the material's fallback colour is used" % color)
            elif not finite(*array.array("f", cb)):
                raise UserError(path, "primvars:%s has non-finite values" % color)
            else:
                p = self.plan_refined(prim, "primvars:%s" % color, cb, 3, cpv.GetInterpolation(), cpv.GetIndices(t),
                                      ref, cage, corner_face)
                if p is not None:
                    cb, p = p
                if p is not None:
                    attrs.append(("colors", cb, 12, p))
        out = {"positions": None, "normals": None, "uvs": None, "colors": None}
        if all(a[3][0] == "vertex" for a in attrs):
            out["positions"] = P
            nverts = npts
            for name, data, w, (_, idx) in attrs:
                out[name] = gather(data, w, idx)
            if tri_corners is None:
                indices = fvi
            else:
                indices = [fvi[c] for c in tri_corners]
        else:
            corner_attrs = [a for a in attrs if a[3][0] == "corner"]
            if any(a[3][1] is None for a in corner_attrs):
                # Un-indexed face-varying data: every face-vertex is its own vertex.
                keys = None
                remap = None
                nverts = nfv
            else:
                uniq = {}
                lists = [fvi] + [a[3][1] for a in corner_attrs]
                remap = [uniq.setdefault(k, len(uniq)) for k in zip(*lists)]
                keys = list(uniq)
                nverts = len(keys)
            pidx = fvi if keys is None else [k[0] for k in keys]
            out["positions"] = gather(P, 12, pidx)
            ci = 0
            for name, data, w, (mode, idx) in attrs:
                if mode == "vertex":
                    sel = pidx if idx is None else [idx[p] for p in pidx]
                else:
                    ci += 1
                    sel = idx if keys is None else [k[ci] for k in keys]
                out[name] = gather(data, w, sel)
            if tri_corners is None:
                indices = list(range(nfv)) if remap is None else remap
            else:
                indices = tri_corners if remap is None else [remap[c] for c in tri_corners]
        geo = Geometry()
        geo.positions, geo.npos = out["positions"], nverts
        geo.indices, geo.ntri = u32_bytes(indices), ntri
        geo.normals, geo.uvs, geo.colors = out["normals"], out["uvs"], out["colors"]
        geo.tri_face = tri_face
        geo.double_sided = bool(mesh.GetDoubleSidedAttr().Get(t))
        return geo

    def refinement(self, prim, mesh, scheme, npts, fvc, fvi):
        """The mesh's cage refined `subdivision_level` times by its scheme and subdivision tags, or
        None (the cage is rendered; warned)."""
        t = self.time
        path = str(prim.GetPath())
        level = self.subdivision_level
        if level == 0:
            self.warn(path, "subdivision surface (%s) rendered as its control cage (--subdivision-level 0)" % scheme)
            return None
        if scheme not in ("catmullClark", "loop", "bilinear"):
            self.warn(path, "unknown subdivision scheme %r; rendered as its control cage" % scheme)
            return None
        if scheme == "loop" and any(c != 3 for c in fvc):
            self.warn(path, "the loop scheme needs triangles and this mesh has other faces; rendered as its control cage")
            return None
        small = next((f for f, c in enumerate(fvc) if c < 3), None)
        if small is not None:
            self.warn(path, "face %d has %d vertices, which no subdivision rule covers; rendered as its control cage"
                      % (small, fvc[small]))
            return None
        bad = repeated_vertex_face(fvc, fvi)
        if bad is not None:
            self.warn(path, "face %d names a vertex twice (%s), which no subdivision rule covers; rendered as its "
                      "control cage" % bad)
            return None
        # faces after the first level (Catmull-Clark and bilinear: a quad per face-vertex)
        faces = 4 * len(fvc) if scheme == "loop" else sum(fvc)
        fits = 0
        while fits < level and faces * (4 ** fits) <= MAX_SUBDIVISION_FACES:
            fits += 1
        if fits < level:
            self.warn(path, "subdivision level %d would give more than %d faces; refined %d times" % (level, MAX_SUBDIVISION_FACES, fits))
            if fits == 0:
                return None
        boundary = mesh.GetInterpolateBoundaryAttr().Get(t) or "edgeAndCorner"
        if boundary == "none":
            self.warn(path, "interpolateBoundary none is refined as edgeOnly (its boundary faces are kept)")
            boundary = "edgeOnly"
        crease_s = [float(x) for x in mesh.GetCreaseSharpnessesAttr().Get(t) or []]
        try:
            creases = crease_edges(int_list(mesh.GetCreaseIndicesAttr().Get(t)), int_list(mesh.GetCreaseLengthsAttr().Get(t)), crease_s)
        except ValueError as e:
            raise UserError(path, "subdivision creases: %s" % e)
        ci, cs = int_list(mesh.GetCornerIndicesAttr().Get(t)), list(mesh.GetCornerSharpnessesAttr().Get(t) or [])
        if len(ci) != len(cs) or any(not (0 <= v < npts) for v in ci) or any(not (0 <= v < npts) for e in creases for v in e):
            raise UserError(path, "subdivision tags (creases or corners) name vertices out of range or lack sharpnesses")
        if not finite(*cs, *crease_s):
            raise UserError(path, "subdivision tags have non-finite sharpnesses")
        negative = [x for x in (*cs, *crease_s) if x < 0]
        if negative:
            self.warn(path, "%d crease or corner sharpnesses are negative (the least %g); they are read as 0 "
                      "(smooth)" % (len(negative), min(negative)))
        ref = Refinement(npts, fvc, fvi, fits, scheme, boundary, creases, dict(zip(ci, map(float, cs))))
        # how its face-varying primvars are refined (`plan_refined`)
        ref.fvar_rule = str(mesh.GetFaceVaryingLinearInterpolationAttr().Get(t) or "cornersPlus1")
        if ref.fvar_rule not in FVAR_RULES:
            self.warn(path, "unknown faceVaryingLinearInterpolation %r; face-varying primvars are refined as "
                      "cornersPlus1" % ref.fvar_rule)
            ref.fvar_rule = "cornersPlus1"
        return ref

    def plan_refined(self, prim, what, data, width, interp, indices, ref, cage, corner_face):
        """`plan` of a primvar (packed f32 `data`, `width` floats per value), refined with `ref`
        first: (data, plan) or None."""
        npts, nf, nfv, fvc = cage
        if ref is None:
            p = self.plan(prim, what, data, 4 * width, interp, indices, npts, nf, nfv, corner_face)
            return None if p is None else (data, p)
        cage_faces = lambda: [f for f, c in enumerate(fvc) for _ in range(c)]  # noqa: E731
        if self.plan(prim, what, data, 4 * width, interp, indices, npts, nf, nfv, cage_faces) is None:
            return None  # warned, with the cage's counts
        v = array.array("f")
        v.frombytes(data)
        v = v.tolist()
        idx = int_list(indices) if indices is not None and len(indices) else None
        if idx is not None:
            v = [v[i * width + c] for i in idx for c in range(width)]
        fidx = None
        if interp == "constant":
            out = v[:width]
        elif interp == "vertex":
            out = ref.points(v, width, limit=True)
        elif interp == "varying":
            out = ref.varying(v, width)
        elif interp == "uniform":
            out = [v[q * width + c] for q in ref.parent_face for c in range(width)]
        else:
            out, fidx = ref.face_varying(v, width, ref.fvar_rule, limit=True)
        out = array.array("f", out).tobytes()
        p = self.plan(prim, what, out, 4 * width, interp, fidx, ref.npts, len(ref.fvc), len(ref.fvi), corner_face)
        return None if p is None else (out, p)

    def smooth_normals(self, P, npts, fvi, tri_corners, nfv):
        """Area-weighted vertex normals (for subdivision cages, whose authored normals USD ignores)."""
        p = array.array("f")
        p.frombytes(P)
        acc = [0.0] * (3 * npts)
        corners = tri_corners if tri_corners is not None else range(nfv)
        it = iter(corners)
        for c0 in it:
            c1, c2 = next(it), next(it)
            a, b, c = fvi[c0], fvi[c1], fvi[c2]
            ax, ay, az = p[3 * a], p[3 * a + 1], p[3 * a + 2]
            ux, uy, uz = p[3 * b] - ax, p[3 * b + 1] - ay, p[3 * b + 2] - az
            vx, vy, vz = p[3 * c] - ax, p[3 * c + 1] - ay, p[3 * c + 2] - az
            nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            for v in (a, b, c):
                acc[3 * v] += nx
                acc[3 * v + 1] += ny
                acc[3 * v + 2] += nz
        out = array.array("f", [0.0] * (3 * npts))
        for i in range(npts):
            x, y, z = acc[3 * i], acc[3 * i + 1], acc[3 * i + 2]
            ln = math.sqrt(x * x + y * y + z * z)
            if ln > 0 and math.isfinite(ln):
                out[3 * i], out[3 * i + 1], out[3 * i + 2] = x / ln, y / ln, z / ln
        if sys.byteorder != "little":
            out.byteswap()
        return out.tobytes()

    def gprim_geometry(self, prim):
        UsdGeom = self.UsdGeom
        t = self.time
        tname = prim.GetTypeName()

        def get(name, default):
            a = prim.GetAttribute(name)
            if a and a.HasValue():
                v = a.Get(t)
                if v is not None:
                    return v
            return default

        axis = str(get("axis", "Z"))
        if tname == "Cube":
            pos, nrm, uv, tris = tess_cube(float(get("size", 2.0)))
            axis = "Z"
        elif tname == "Sphere":
            pos, nrm, uv, tris = tess_revolve(sphere_profile(float(get("radius", 1.0))))
            axis = "Z"
        elif tname in ("Cylinder", "Cylinder_1"):
            r = float(get("radius", 1.0))
            rt, rb = float(get("radiusTop", r)), float(get("radiusBottom", r))
            h = float(get("height", 2.0))
            pos, nrm, uv, tris = tess_revolve(cylinder_profile(rb, rt, h))
        elif tname == "Cone":
            pos, nrm, uv, tris = tess_revolve(cylinder_profile(float(get("radius", 1.0)), 0.0, float(get("height", 2.0))))
        elif tname in ("Capsule", "Capsule_1"):
            r = float(get("radius", 0.5))
            rt, rb = float(get("radiusTop", r)), float(get("radiusBottom", r))
            if abs(rt - rb) > 1e-9:
                self.warn(prim.GetPath(), "capsule with different top and bottom radii tessellated with their mean")
            pos, nrm, uv, tris = tess_revolve(capsule_profile(0.5 * (rt + rb), float(get("height", 1.0))))
        elif tname == "Plane":
            pos, nrm, uv, tris = tess_plane(float(get("width", 2.0)), float(get("length", 2.0)))
        else:
            self.warn(prim.GetPath(), "%s is not supported; skipped" % tname)
            return None
        if axis != "Z":
            pos, nrm = permute_axis(pos, axis), permute_axis(nrm, axis)
        g = UsdGeom.Gprim(prim)
        if g.GetOrientationAttr().Get(t) == UsdGeom.Tokens.leftHanded:
            tris = [(a, c, b) for a, b, c in tris]
        geo = Geometry()
        geo.positions = array_f32([x for p in pos for x in p])
        geo.npos = len(pos)
        geo.normals = array_f32([x for n in nrm for x in n])
        geo.uvs = array_f32([x for u in uv for x in u])
        geo.colors = None
        geo.indices = u32_bytes([i for tri in tris for i in tri])
        geo.ntri = len(tris)
        geo.tri_face = None
        geo.double_sided = bool(g.GetDoubleSidedAttr().Get(t))
        return geo

    def point_floats(self, prim):
        """(path, points) of a point-based prim: its points at the conversion's time as a flat
        list of floats, or None (it has none: warned); non-finite coordinates are an error."""
        path = str(prim.GetPath())
        pts_vt = self.UsdGeom.PointBased(prim).GetPointsAttr().Get(self.time)
        if pts_vt is None or len(pts_vt) == 0:
            self.warn(path, "has no points; skipped")
            return path, None
        P = array.array("f")
        P.frombytes(f32_bytes(pts_vt, 3))
        P = P.tolist()
        if not finite(*P):
            raise UserError(path, "points have non-finite coordinates")
        return path, P

    def tessellated_geometry(self, prim, color=None):
        """A BasisCurves, NurbsCurves or HermiteCurves prim as round tubes, a Points prim as spheres
        (`raysplat_curves.py`), their widths and vertex colours (`color`, a primvar) of any
        interpolation interpolated. Both face outward whatever the prim's orientation."""
        UsdGeom = self.UsdGeom
        t = self.time
        is_curves = prim.IsA(UsdGeom.Curves)
        is_nurbs = prim.IsA(UsdGeom.NurbsCurves)
        is_hermite = prim.IsA(UsdGeom.HermiteCurves)
        path, P = self.point_floats(prim)
        if P is None:
            return None
        npts = len(P) // 3
        if is_curves:
            curves = (UsdGeom.NurbsCurves if is_nurbs else UsdGeom.HermiteCurves if is_hermite else UsdGeom.BasisCurves)(prim)
            counts = int_list(curves.GetCurveVertexCountsAttr().Get(t))
            if not counts or min(counts) < 0 or sum(counts) != npts:
                raise UserError(path, "curveVertexCounts sum to %d for %d points" % (sum(counts), npts))
            try:
                if is_nurbs:
                    wrap = "nonperiodic"
                    orders = int_list(curves.GetOrderAttr().Get(t))
                    knots = [float(k) for k in (curves.GetKnotsAttr().Get(t) or [])]
                    ranges = [tuple(map(float, r)) for r in (curves.GetRangesAttr().Get(t) or [])]
                    weights = [float(w) for w in (curves.GetPointWeightsAttr().Get(t) or [])]
                    if len(orders) != len(counts) or (ranges and len(ranges) != len(counts)) or \
                            (weights and len(weights) != npts) or not finite(*knots, *weights, *sum(ranges, ())):
                        raise UserError(path, "NURBS curves need an order per curve, a range per curve (or none), a "
                                        "weight per point (or none), all finite")
                    if weights and min(weights) <= 0:
                        raise UserError(path, "pointWeights must be positive")
                    samples, nvar = nurbs_curve_samples(counts, orders, knots, ranges, weights, CURVE_STEPS)
                elif is_hermite:
                    wrap, nvar = "nonperiodic", npts
                    tv = curves.GetTangentsAttr().Get(t)
                    tangents = array.array("f")
                    tangents.frombytes(f32_bytes(tv, 3) if tv is not None else b"")
                    tangents = tangents.tolist()
                    if len(tangents) != len(P) or not finite(*tangents):
                        raise UserError(path, "a Hermite curve needs a finite tangent per point (%d tangents for %d "
                                        "points)" % (len(tangents) // 3, npts))
                    samples, hermite_pos = hermite_samples(counts, npts, CURVE_STEPS)
                else:
                    kind = str(curves.GetTypeAttr().Get(t) or "cubic")
                    basis = str(curves.GetBasisAttr().Get(t) or "bezier")
                    wrap = str(curves.GetWrapAttr().Get(t) or "nonperiodic")
                    samples, nvar = curve_samples(counts, kind, basis, wrap, CURVE_STEPS)
            except CurveError as e:
                raise UserError(path, str(e))
            if not is_nurbs and not is_hermite and curves.GetNormalsAttr().HasAuthoredValue():
                self.warn(path, "curve normals (oriented ribbons) are not read; the curves are rendered as round tubes")
            ntri = sum((len(c) if wrap == "periodic" else len(c) - 1) for c in samples) * CURVE_SIDES * 2
            counts_by = {"vertex": npts, "varying": nvar, "faceVarying": nvar, "uniform": len(counts), "constant": 1}
        else:
            samples, nvar = None, npts
            levels = POINT_LEVELS
            while levels > 0 and npts * 20 * 4 ** levels > MAX_TESSELLATED_TRIANGLES:
                levels -= 1
            ntri = npts * 20 * 4 ** levels
            counts_by = {"vertex": npts, "varying": npts, "faceVarying": npts, "uniform": 1, "constant": 1}
        if ntri > MAX_TESSELLATED_TRIANGLES:
            self.warn(path, "would be tessellated into %d triangles (more than %d); skipped" % (ntri, MAX_TESSELLATED_TRIANGLES))
            return None

        def values(what, vt, interp, width):
            """Per-element values of a primvar and its interpolation, or None (warned)."""
            if vt is None or len(vt) == 0:
                return None
            v = array.array("f")
            v.frombytes(f32_bytes(vt, width))
            v = v.tolist()
            if not finite(*v):
                raise UserError(path, "%s has non-finite values" % what)
            want = counts_by.get(interp)
            if want is None or len(v) != want * width:
                self.warn(path, "%s has %d %s values where %s are needed; ignored"
                          % (what, len(v) // width, interp, want if want is not None else "known interpolations"))
                return None
            return v, interp

        typed = UsdGeom.Curves(prim) if is_curves else UsdGeom.Points(prim)
        widths = values("widths", typed.GetWidthsAttr().Get(t), typed.GetWidthsInterpolation(), 1)
        if widths is None:
            self.warn(path, "no usable widths; a width of 1 (scene unit) is used")
            widths = ([1.0], "constant")
        if min(widths[0]) < 0:
            raise UserError(path, "widths has negative values")
        cols = None
        if color:
            pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar(color)
            if pv and pv.HasAuthoredValue():
                cols = values("primvars:%s" % color, pv.ComputeFlattened(t), pv.GetInterpolation(), 3)
            if cols is None:
                self.warn(path, "has no usable primvars:%s for its material's vertex colours; grey is used" % color)

        def at(data, curve, sample, width):
            """`data` (values, interpolation) at a curve's sample (points: at point `curve`)."""
            v, interp = data
            if interp == "constant":
                return v[:width]
            if interp == "uniform" or not is_curves:
                # a curve's value, a points prim's one (uniform) or a point's own
                k = 0 if interp == "uniform" and not is_curves else curve
                return v[k * width:(k + 1) * width]
            vert, var = samples[curve][sample]
            return combine(vert if interp == "vertex" else var, v, width)

        if is_curves:
            if is_hermite:
                PT = P + tangents
                centres = [[tuple(combine(st, PT, 3)) for st in c] for c in hermite_pos]
            else:
                centres = [[tuple(combine(vert, P, 3)) for vert, _ in c] for c in samples]
            radii = [[max(0.0, 0.5 * at(widths, ci, si, 1)[0]) for si in range(len(c))] for ci, c in enumerate(samples)]
            pos, nrm, tris, origin = tubes(centres, radii, [wrap == "periodic"] * len(samples), CURVE_SIDES)
            ccache = {}
            vcols = [ccache.setdefault(o, at(cols, o[0], o[1], 3)) for o in origin] if cols else None
        else:
            sv, sf = icosphere(levels)
            pos, nrm, tris, vcols = [], [], [], [] if cols else None
            for k in range(npts):
                r = 0.5 * at(widths, k, 0, 1)[0]
                base = len(pos)
                c = P[3 * k:3 * k + 3]
                pos.extend((c[0] + r * x, c[1] + r * y, c[2] + r * z) for x, y, z in sv)
                nrm.extend(sv)
                tris.extend((base + a, base + b, base + d) for a, b, d in sf)
                if cols:
                    vcols.extend([at(cols, k, 0, 3)] * len(sv))
        if not tris:
            self.warn(path, "has no curves to tessellate; skipped")
            return None
        return Geometry(array_f32([x for p in pos for x in p]), len(pos), u32_bytes([i for tri in tris for i in tri]),
                        len(tris), normals=array_f32([x for n in nrm for x in n]),
                        colors=array_f32([x for c in vcols for x in c]) if vcols else None,
                        double_sided=bool(UsdGeom.Gprim(prim).GetDoubleSidedAttr().Get(t)))

    def patch_geometry(self, prim):
        """A NurbsPatch tessellated into a grid of quads (`raysplat_curves.nurbs_patch`: 8 samples per
        knot span in each direction), its normalised parameters as texture coordinates, smooth
        normals; trim curves are not applied (warned)."""
        UsdGeom = self.UsdGeom
        t = self.time
        path, P = self.point_floats(prim)
        if P is None:
            return None
        patch = UsdGeom.NurbsPatch(prim)
        nu, nv = patch.GetUVertexCountAttr().Get(t) or 0, patch.GetVVertexCountAttr().Get(t) or 0
        if nu * nv * 3 != len(P):
            raise UserError(path, "uVertexCount x vVertexCount = %d x %d for %d points" % (nu, nv, len(P) // 3))
        weights = [float(w) for w in (patch.GetPointWeightsAttr().Get(t) or [])]
        uk = [float(k) for k in (patch.GetUKnotsAttr().Get(t) or [])]
        vk = [float(k) for k in (patch.GetVKnotsAttr().Get(t) or [])]
        ur, vr = patch.GetURangeAttr().Get(t), patch.GetVRangeAttr().Get(t)
        ur = tuple(map(float, ur)) if ur is not None else None
        vr = tuple(map(float, vr)) if vr is not None else None
        if not finite(*weights, *uk, *vk, *(ur or ()), *(vr or ())) or (weights and len(weights) != nu * nv):
            raise UserError(path, "NURBS patch values must be finite, with a weight per point (or none)")
        if weights and min(weights) <= 0:
            raise UserError(path, "pointWeights must be positive")
        if patch.GetTrimCurveCountsAttr().HasAuthoredValue():
            self.warn(path, "trim curves are not applied; the whole patch is rendered")
        try:
            pos, uvs, quads = nurbs_patch(P, weights, nu, nv, patch.GetUOrderAttr().Get(t) or 0,
                                          patch.GetVOrderAttr().Get(t) or 0, uk, vk, ur, vr, 8)
        except CurveError as e:
            raise UserError(path, "NURBS patch: %s" % e)
        if UsdGeom.Gprim(prim).GetOrientationAttr().Get(t) == UsdGeom.Tokens.leftHanded:
            quads = [(a, d, c, b) for a, b, c, d in quads]
        tris = [i for a, b, c, d in quads for i in (a, b, c, a, c, d)]
        flat = array_f32([x for p in pos for x in p])
        return Geometry(flat, len(pos), u32_bytes(tris), len(tris) // 3,
                        normals=self.smooth_normals(flat, len(pos), tris, None, len(tris)),
                        uvs=array_f32([x for u in uvs for x in u]),
                        double_sided=bool(UsdGeom.Gprim(prim).GetDoubleSidedAttr().Get(t)))

    def tet_geometry(self, prim):
        """A TetMesh rendered by its surface: `surfaceFaceVertexIndices`, else the faces usd-core
        finds on no two tetrahedra (`TetMesh.ComputeSurfaceFaces`), facing as the spec orients them."""
        UsdGeom = self.UsdGeom
        t = self.time
        path, P = self.point_floats(prim)
        if P is None:
            return None
        tet = UsdGeom.TetMesh(prim)
        npts = len(P) // 3
        tets = [int(i) for v in (tet.GetTetVertexIndicesAttr().Get(t) or []) for i in v]
        if tets and (min(tets) < 0 or max(tets) >= npts):
            raise UserError(path, "tetVertexIndices: index out of range (mesh has %d points)" % npts)
        faces = tet.GetSurfaceFaceVertexIndicesAttr().Get(t)
        if faces is None or len(faces) == 0:
            faces = UsdGeom.TetMesh.ComputeSurfaceFaces(tet, t) if tets else None
        idx = [int(i) for f in (faces or []) for i in f]
        if not idx:
            self.warn(path, "has no surface faces; skipped")
            return None
        if min(idx) < 0 or max(idx) >= npts:
            raise UserError(path, "surfaceFaceVertexIndices: index out of range (mesh has %d points)" % npts)
        if tet.GetOrientationAttr().Get(t) == UsdGeom.Tokens.leftHanded:
            idx = [i for k in range(0, len(idx), 3) for i in (idx[k], idx[k + 2], idx[k + 1])]
        return Geometry(array_f32(P), npts, u32_bytes(idx), len(idx) // 3, double_sided=bool(tet.GetDoubleSidedAttr().Get(t)))

    # ---- lights ---------------------------------------------------------------------------------
    def lattr(self, prim, name, default):
        """A UsdLux input, read with the `inputs:` prefix (USD >= 21.05) or without (older files)."""
        a = prim.GetAttribute("inputs:" + name)
        b = prim.GetAttribute(name)
        if a and a.HasAuthoredValue():
            return a.Get(self.time)
        if b and b.HasAuthoredValue():
            return b.Get(self.time)
        if a and a.HasValue():
            v = a.Get(self.time)
            if v is not None:
                return v
        return default

    def lnum(self, prim, name, default):
        v = self.lattr(prim, name, default)
        try:
            x = float(v)
        except (TypeError, ValueError):
            self.warn(prim.GetPath(), "inputs:%s has an unexpected value %r; using %g" % (name, v, default))
            return float(default)
        return x

    def lvec3(self, prim, name, default):
        v = self.lattr(prim, name, default)
        try:
            return vec(v, 3)
        except (TypeError, ValueError, IndexError):
            self.warn(prim.GetPath(), "inputs:%s has an unexpected value %r; using %s" % (name, v, default))
            return list(default)

    def emission(self, prim):
        """color * intensity * 2^exposure * blackbody(colorTemperature)."""
        path = prim.GetPath()
        color = self.lvec3(prim, "color", (1.0, 1.0, 1.0))
        intensity = self.lnum(prim, "intensity", 1.0)
        exposure = self.lnum(prim, "exposure", 0.0)
        try:
            k = intensity * math.pow(2.0, exposure)
        except OverflowError:  # an exposure beyond ~1024 stops: infinite (refused below)
            k = intensity * math.inf
        rgb = [c * k for c in color]
        if self.lattr(prim, "enableColorTemperature", False):
            temp = self.lnum(prim, "colorTemperature", 6500.0)
            if not math.isfinite(temp):
                # (usd-core's blackbody table crashes the process on NaN)
                raise UserError(str(path), "colorTemperature %r is not a finite temperature" % temp)
            bb = blackbody_rgb(self.UsdLux, temp)
            rgb = [rgb[i] * bb[i] for i in range(3)]
        for name in ("diffuse", "specular"):
            v = self.lnum(prim, name, 1.0)
            if abs(v - 1.0) > 1e-6:
                self.warn(path, "inputs:%s %g (a non-physical multiplier) is not supported; ignored" % (name, v))
        if not finite(*rgb):
            raise UserError(str(path), "light emission is NaN or infinite (color %s, intensity %r, exposure %r)"
                            % (color, intensity, exposure))
        if any(c < 0 for c in rgb):
            raise UserError(str(path), "light emission is negative (color %s, intensity %r)" % (color, intensity))
        return rgb

    def light(self, prim):
        UsdLux, Gf = self.UsdLux, self.Gf
        path = str(prim.GetPath())
        tname = prim.GetTypeName()
        if prim.GetRelationship("light:filters") and prim.GetRelationship("light:filters").GetTargets():
            self.warn(path, "light filters are not supported; ignored")
        if prim.HasAPI(UsdLux.ShadowAPI):
            se = self.lattr(prim, "shadow:enable", True)
            if not se:
                self.warn(path, "shadow:enable = false is not supported; the light casts shadows")
        for coll in ("lightLink", "shadowLink"):
            inc = prim.GetAttribute("collection:%s:includeRoot" % coll)
            exc = prim.GetRelationship("collection:%s:excludes" % coll)
            if (inc and inc.HasAuthoredValue() and not inc.Get()) or (exc and exc.GetTargets()):
                self.warn(path, "light linking (%s) is not supported; the light affects everything" % coll)
        if zero_scale(self.world(prim)):
            # zero scale, USD's usual way to hide a prim: no emitter left (as for meshes)
            self.warn(path, "transform has zero scale: the light is left out")
            return
        if prim.IsA(UsdLux.RectLight):
            self.rect_light(prim, path)
        elif prim.IsA(UsdLux.DiskLight):
            self.disk_light(prim, path)
        elif prim.IsA(UsdLux.SphereLight):
            self.sphere_light(prim, path)
        elif prim.IsA(UsdLux.DistantLight):
            self.distant_light(prim, path)
        elif prim.IsA(UsdLux.DomeLight) or tname == "DomeLight_1":
            self.dome_light(prim, path, tname)
        elif prim.IsA(UsdLux.CylinderLight):
            self.warn(path, "CylinderLight is not supported; skipped")
        elif prim.IsA(UsdLux.PortalLight):
            self.warn(path, "PortalLight is not supported; ignored")
        elif prim.IsA(UsdLux.GeometryLight):
            self.warn(path, "GeometryLight is not supported; skipped")
        else:
            self.warn(path, "light type %s is not supported; skipped" % (tname or "(LightAPI on %s)" % prim.GetTypeName()))

    def shaping_ignored(self, prim, path):
        if prim.HasAPI(self.UsdLux.ShapingAPI):
            ang = self.lnum(prim, "shaping:cone:angle", 90.0)
            foc = self.lnum(prim, "shaping:focus", 0.0)
            if ang < 90.0 or foc > 0:
                self.warn(path, "ShapingAPI (cone/focus) is only supported on SphereLight; ignored")
        self.ies_ignored(prim, path)

    def ies_ignored(self, prim, path):
        ies = self.lattr(prim, "shaping:ies:file", None)
        if ies is not None and getattr(ies, "path", ""):
            self.warn(path, "IES profiles are not supported; ignored")

    def light_texture(self, prim, path, wrap_s, wrap_t):
        asset = self.lattr(prim, "texture:file", None)
        if asset is None or not getattr(asset, "path", ""):
            return None
        attr = prim.GetAttribute("inputs:texture:file")
        if not (attr and attr.HasAuthoredValue()):
            attr = prim.GetAttribute("texture:file")
        p = self.resolve_texture(asset, attr, path)
        if not os.path.isfile(p):
            return None  # warned: rendered untextured
        desc = {"path": p, "wrap_s": wrap_s, "wrap_t": wrap_t, "scale": [1.0, 1.0, 1.0, 1.0],
                "bias": [0.0, 0.0, 0.0, 0.0], "color_space": "auto", "output": "rgb", "fallback": [1.0, 1.0, 1.0, 1.0]}
        key = json.dumps(desc, sort_keys=True)
        if key not in self._texture_index:
            desc["prim"] = str(path)
            self.textures.append(desc)
            self._texture_index[key] = len(self.textures) - 1
        return self._texture_index[key]

    def rect_light(self, prim, path):
        m = self.world(prim)
        frame, (sx, sy, sz) = self.rigid(m, path, "light")
        w = self.lnum(prim, "width", 1.0) * sx
        h = self.lnum(prim, "height", 1.0) * sy
        rgb = self.emission(prim)
        if not (w > 0 and h > 0):
            raise UserError(path, "RectLight size %g x %g m is not positive" % (w, h))
        if self.lattr(prim, "normalize", False):
            rgb = [c / (w * h) for c in rgb]
        self.shaping_ignored(prim, path)
        tex = self.light_texture(prim, path, "clamp", "clamp")
        self.lights.append({"type": "rect", "name": path, "transform": self.cols(frame), "width": w, "height": h,
                            "radiance": rgb, "texture": tex})

    def disk_light(self, prim, path):
        m = self.world(prim)
        frame, (sx, sy, sz) = self.rigid(m, path, "light")
        if abs(sx - sy) > 1e-3 * max(sx, sy):
            self.warn(path, "non-uniform scale makes an elliptic disk; rendered as a disk of equal area")
        r = self.lnum(prim, "radius", 0.5) * math.sqrt(sx * sy)
        rgb = self.emission(prim)
        if not r > 0:
            raise UserError(path, "DiskLight radius %g m is not positive" % r)
        if self.lattr(prim, "normalize", False):
            rgb = [c / (math.pi * r * r) for c in rgb]
        self.shaping_ignored(prim, path)
        self.lights.append({"type": "disk", "name": path, "transform": self.cols(frame), "radius": r, "radiance": rgb})

    def sphere_light(self, prim, path):
        m = self.world(prim)
        frame, (sx, sy, sz) = self.rigid(m, path, "light")
        if max(sx, sy, sz) - min(sx, sy, sz) > 1e-3 * max(sx, sy, sz):
            self.warn(path, "non-uniform scale makes an ellipsoid; rendered as a sphere of equal volume")
        r = self.lnum(prim, "radius", 0.5) * (sx * sy * sz) ** (1.0 / 3.0)
        if r < 0 or not math.isfinite(r):
            raise UserError(path, "SphereLight radius %g m is negative or not finite" % r)
        rgb = self.emission(prim)
        normalize = bool(self.lattr(prim, "normalize", False))
        point = bool(self.lattr(prim, "treatAsPoint", False)) or r == 0.0
        if point:
            # A point light keeps the radiant intensity (W/sr) of the authored sphere:
            #   J = L * pi r^2 (unnormalised; for r = 0, J = color*intensity*2^exposure),
            #   J = color*intensity*2^exposure / 4 (normalised: L = I / (4 pi r^2)).
            if normalize:
                j = [c / 4.0 for c in rgb]
            elif r > 0:
                j = [c * math.pi * r * r for c in rgb]
            else:
                j = rgb
            rp = min(r, POINT_LIGHT_RADIUS) if r > 0 else POINT_LIGHT_RADIUS
            rgb = [c / (math.pi * rp * rp) for c in j]
            r = rp
        elif normalize:
            rgb = [c / (4.0 * math.pi * r * r) for c in rgb]
        cone = None
        if prim.HasAPI(self.UsdLux.ShapingAPI) or prim.GetAttribute("inputs:shaping:cone:angle").HasAuthoredValue() \
                or prim.GetAttribute("shaping:cone:angle").HasAuthoredValue():
            ang = self.lnum(prim, "shaping:cone:angle", 90.0)
            soft = self.lnum(prim, "shaping:cone:softness", 0.0)
            foc = self.lnum(prim, "shaping:focus", 0.0)
            tint = self.lattr(prim, "shaping:focusTint", None)
            if foc > 0 and tint is not None and any(abs(float(x)) > 1e-6 for x in vec(tint, 3)):
                self.warn(path, "shaping:focusTint is not supported; treated as black")
            if not finite(ang, soft, foc):
                raise UserError(path, "shaping parameters are NaN or infinite")
            if ang < 180.0 or foc > 0:
                cone = {"angle_deg": min(max(ang, 0.0), 180.0), "softness": min(max(soft, 0.0), 1.0),
                        "focus": max(foc, 0.0)}
        self.ies_ignored(prim, path)
        self.lights.append({"type": "sphere", "name": path, "transform": self.cols(frame), "radius": r,
                            "radiance": rgb, "cone": cone})

    def distant_light(self, prim, path):
        Gf = self.Gf
        m = self.world(prim)
        d = Gf.Vec3d(-m[2][0], -m[2][1], -m[2][2])
        if not d.GetLength() > 0:
            raise UserError(path, "DistantLight transform is singular")
        d = d.GetNormalized()
        angle = self.lnum(prim, "angle", 0.53)
        if not (0.0 <= angle < 360.0):
            self.warn(path, "angle %g clamped to [0, 180]" % angle)
        angle = min(max(angle, 0.0), 180.0)
        # Irradiance on a surface facing the light = color * intensity * 2^exposure (docs/units.md).
        e = self.emission(prim)
        self.shaping_ignored(prim, path)
        self.lights.append({"type": "distant", "name": path, "direction": [d[0], d[1], d[2]], "angle_deg": angle,
                            "irradiance": e})

    def dome_light(self, prim, path, tname):
        Gf = self.Gf
        m = self.xf.GetLocalToWorldTransform(prim)
        pre = Gf.Matrix4d(1.0)
        if tname == "DomeLight_1":
            pole = str(prim.GetAttribute("poleAxis").Get() or "scene")
            if pole == "Z" or (pole == "scene" and self.up == "Z"):
                pre = Gf.Matrix4d(1.0).SetRotate(Gf.Rotation(Gf.Vec3d(1, 0, 0), 90.0))  # +Y pole -> +Z
        # The renderer's lat-long map follows OpenEXR/USD: local +Z at the image centre, +Y up.
        full = pre * m * self.root
        frame, _ = self.rigid(full, path, "light")
        fmt = str(self.lattr(prim, "texture:format", "automatic"))
        tex = None
        if fmt not in ("automatic", "latlong"):
            self.warn(path, "dome texture format %r is not supported (lat-long only); texture ignored" % fmt)
        else:
            tex = self.light_texture(prim, path, "repeat", "clamp")
        rgb = self.emission(prim)
        if prim.GetRelationship("portals") and prim.GetRelationship("portals").GetTargets():
            self.warn(path, "dome light portals are ignored")
        self.lights.append({"type": "dome", "name": path, "transform": self.cols(frame), "radiance": rgb,
                            "texture": tex})

    # ---- output ---------------------------------------------------------------------------------
    def dependencies(self):
        deps = {}
        for layer in self.stage.GetUsedLayers():
            rp = layer.realPath
            if not rp:
                continue
            if "[" in rp and rp.endswith("]"):
                rp = rp[:rp.index("[")]
            if os.path.isfile(rp):
                deps[os.path.abspath(rp)] = True
        for p in self.texture_files:
            deps[p] = True
        # A texture that does not exist is recorded with a null hash: the cached conversion stays
        # valid only while it is still absent.
        return [{"path": p, "sha256": sha256_file(p) if os.path.isfile(p) else None} for p in sorted(deps)]

    def write(self):
        blob = bytearray()

        def push(data, ty, count):
            pad = (-len(blob)) % 16
            blob.extend(b"\0" * pad)
            off = len(blob)
            blob.extend(data)
            return {"type": ty, "offset": off, "count": count}

        geo_refs = {}
        meshes = []
        for m in self.meshes:
            g = m["geometry"]
            if id(g) not in geo_refs:
                geo_refs[id(g)] = {
                    "positions": push(g.positions, "f32x3", g.npos),
                    "indices": push(g.indices, "u32x3", g.ntri),
                    "normals": push(g.normals, "f32x3", g.npos) if g.normals is not None else None,
                    "uvs": push(g.uvs, "f32x2", g.npos) if g.uvs is not None else None,
                    "colors": push(g.colors, "f32x3", g.npos) if g.colors is not None else None,
                }
            r = geo_refs[id(g)]
            meshes.append({"name": m["name"], "double_sided": g.double_sided, "positions": r["positions"],
                           "indices": r["indices"], "normals": r["normals"], "uvs": r["uvs"], "colors": r["colors"],
                           "material_ids": push(u32_bytes(m["material_ids"]), "u32", len(m["material_ids"]))})
        for i in self.instances:
            check_finite(i["transform"], i["name"], "transform")
        for light in self.lights:
            check_finite(light, light["name"], "light")
        for mat in self.materials:
            check_finite(mat, mat["name"], "material")
        for tex in self.textures:
            check_finite(tex, tex["path"], "texture")
        if self.camera:
            # the render settings' pixels and conform policy (they may be read after the camera)
            self.camera["pixel_aspect"], self.camera["aspect_conform"] = self.pixel_aspect, self.aspect_conform
            check_finite(self.camera, self.camera["name"], "camera")
        self.deps = self.dependencies()
        header = {
            "format": "raysplat-scene",
            "version": FORMAT_VERSION,
            "source": os.path.abspath(self.input),
            "converter_version": CONVERTER_VERSION,
            "dependencies": self.deps,
            "stage": {"meters_per_unit": self.mpu, "up_axis": self.up, "time": self.time_code(),
                      "time_range": self.time_range(), "cameras": self.cameras()},
            "resolution": self.resolution,
            "camera": self.camera,
            "materials": self.materials,
            "textures": self.textures,
            "lights": self.lights,
            "meshes": meshes,
            "instances": self.instances,
            "warnings": self.warnings,
        }
        js = json.dumps(header, separators=(",", ":"), allow_nan=False).encode("utf-8")
        out = bytearray()
        out += MAGIC
        out += FORMAT_VERSION.to_bytes(4, "little")
        out += (0).to_bytes(4, "little")
        out += len(js).to_bytes(8, "little")
        out += js
        out += b"\0" * ((-len(out)) % 16)
        out += blob
        write_atomic(self.output, bytes(out))

    def time_range(self):
        """The stage's authored [startTimeCode, endTimeCode], or None."""
        st = self.stage
        return [float(st.GetStartTimeCode()), float(st.GetEndTimeCode())] if st.HasAuthoredTimeCodeRange() else None

    def time_code(self):
        """The time code values were read at, or None for each attribute's earliest sample."""
        t = self.time if isinstance(self.time, self.Usd.TimeCode) else self.Usd.TimeCode(self.time)
        return None if t.IsDefault() or t == self.Usd.TimeCode.EarliestTime() else float(t.GetValue())

    def summary(self):
        tris = sum(self.meshes[i["mesh"]]["geometry"].ntri for i in self.instances)
        return {
            "meshes": len(self.meshes),
            "instances": len(self.instances),
            "triangles": tris,
            "unique_triangles": sum(m["geometry"].ntri for m in self.meshes),
            "materials": len(self.materials),
            "textures": len(self.textures),
            "lights": len(self.lights),
            "warnings": len(self.warnings),
            "dependencies": len(self.deps),
            "camera": self.camera["name"] if self.camera else None,
            "time": self.time_code(),
            "seconds": round(self.seconds, 3),
        }


class Geometry:
    __slots__ = ("positions", "npos", "indices", "ntri", "normals", "uvs", "colors", "tri_face", "double_sided")

    def __init__(self, positions=None, npos=0, indices=None, ntri=0, normals=None, uvs=None, colors=None,
                 tri_face=None, double_sided=False):
        self.positions, self.npos, self.indices, self.ntri = positions, npos, indices, ntri
        self.normals, self.uvs, self.colors = normals, uvs, colors
        self.tri_face, self.double_sided = tri_face, double_sided


GPRIM_TYPES = {"Cube", "Sphere", "Cylinder", "Cylinder_1", "Cone", "Capsule", "Capsule_1", "Plane"}
# UsdRender aspectRatioConformPolicy values (the renderer applies them: src/prepare/camera.rs).
ASPECT_CONFORM = {"expandAperture", "cropAperture", "adjustApertureWidth", "adjustApertureHeight",
                  "adjustPixelAspectRatio"}
# faceVaryingLinearInterpolation rules of subdivision surfaces (raysplat_subdiv.Refinement.face_varying).
FVAR_RULES = {"none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all"}
# Tessellated into triangles by raysplat_curves.py.
TESSELLATED_TYPES = {"BasisCurves", "NurbsCurves", "HermiteCurves", "Points", "NurbsPatch", "TetMesh"}


def check_finite(obj, prim, what):
    def walk(o, key):
        if isinstance(o, float):
            if not math.isfinite(o):
                raise UserError(prim, "%s parameter %s is NaN or infinite" % (what, key))
        elif isinstance(o, dict):
            for k, v in o.items():
                walk(v, k)
        elif isinstance(o, (list, tuple)):
            for v in o:
                walk(v, key)

    walk(obj, what)


def blackbody_rgb(UsdLux, kelvin):
    """Linear Rec.709 colour of a blackbody, normalised to luminance 1 (6500 K is close to white)."""
    kelvin = min(max(kelvin, 1000.0), 10000.0)
    c = UsdLux.BlackbodyTemperatureAsRgb(kelvin)
    rgb = [float(c[0]), float(c[1]), float(c[2])]
    y = luminance(rgb)
    return [x / y for x in rgb] if y > 0 else [1.0, 1.0, 1.0]


def with_exact_normals(normals, exact):
    """Packed f32 vertex `normals` with each point's `exact` normal where it has one (None:
    kept), turned to the side of the one it replaces (the triangles' winding, flipped for
    leftHanded meshes)."""
    a = array.array("f")
    a.frombytes(normals)
    if sys.byteorder != "little":
        a.byteswap()
    for v, n in enumerate(exact):
        if n is not None:
            s = -1.0 if n[0] * a[3 * v] + n[1] * a[3 * v + 1] + n[2] * a[3 * v + 2] < 0.0 else 1.0
            a[3 * v], a[3 * v + 1], a[3 * v + 2] = s * n[0], s * n[1], s * n[2]
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def array_f32(values):
    a = array.array("f", values)
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def permute_axis(vs, axis):
    """Geometry built around +Z turned to the gprim's axis by a cyclic permutation (a rotation)."""
    if axis == "X":
        return [(z, x, y) for x, y, z in vs]
    if axis == "Y":
        return [(y, z, x) for x, y, z in vs]
    return vs


def tess_cube(size):
    h = 0.5 * size
    faces = [  # normal, u axis, v axis
        ((1, 0, 0), (0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
        ((0, 1, 0), (0, 0, 1), (1, 0, 0)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
        ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
    ]
    pos, nrm, uv, tris = [], [], [], []
    for n, u, v in faces:
        base = len(pos)
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            pos.append(tuple(h * (n[i] + a * u[i] + b * v[i]) for i in range(3)))
            nrm.append(n)
            uv.append((0.5 * (a + 1), 0.5 * (b + 1)))
        tris += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return pos, nrm, uv, tris


def sphere_profile(r):
    """(radius, z, normal_r, normal_z, v) from the south to the north pole."""
    out = []
    for i in range(RINGS + 1):
        th = math.pi * i / RINGS  # 0 at the south pole
        s, c = math.sin(th), -math.cos(th)
        out.append((r * s, r * c, s, c, i / RINGS))
    return [out]


def cylinder_profile(rb, rt, h):
    """Side, bottom cap and top cap of a (possibly conical) cylinder along Z, as separate strips."""
    hz = 0.5 * h
    slope = math.atan2(rb - rt, h)  # normal tilt of the side
    ns, nz = math.cos(slope), math.sin(slope)
    strips = [[(rb, -hz, ns, nz, 0.0), (rt, hz, ns, nz, 1.0)]]
    if rb > 0:
        strips.append([(0.0, -hz, 0.0, -1.0, 0.0), (rb, -hz, 0.0, -1.0, 1.0)])
    if rt > 0:
        strips.append([(rt, hz, 0.0, 1.0, 0.0), (0.0, hz, 0.0, 1.0, 1.0)])
    return strips


def capsule_profile(r, h):
    out = []
    half = RINGS // 2
    for i in range(half + 1):  # bottom hemisphere
        th = 0.5 * math.pi * i / half
        s, c = math.sin(th), -math.cos(th)
        out.append((r * s, -0.5 * h + r * c, s, c, 0.5 * i / half))
    for i in range(half + 1):  # top hemisphere
        th = 0.5 * math.pi + 0.5 * math.pi * i / half
        s, c = math.sin(th), -math.cos(th)
        out.append((r * s, 0.5 * h + r * c, s, c, 0.5 + 0.5 * i / half))
    return [out]


def tess_revolve(strips):
    """Surfaces of revolution about +Z from profile strips; counter-clockwise seen from outside."""
    pos, nrm, uv, tris = [], [], [], []
    for strip in strips:
        base = len(pos)
        for j in range(SEGMENTS + 1):
            ph = 2.0 * math.pi * j / SEGMENTS
            cp, sp = math.cos(ph), math.sin(ph)
            for (rr, z, nr, nz, v) in strip:
                pos.append((rr * cp, rr * sp, z))
                nrm.append((nr * cp, nr * sp, nz))
                uv.append((j / SEGMENTS, v))
        n = len(strip)
        for j in range(SEGMENTS):
            for i in range(n - 1):
                a = base + j * n + i
                b = base + (j + 1) * n + i
                # quad a (j,i), b (j+1,i), b+1, a+1; skip triangles collapsed at the axis
                if strip[i][0] > 0:
                    tris.append((a, b, b + 1))
                if strip[i + 1][0] > 0:
                    tris.append((a, b + 1, a + 1))
    return pos, nrm, uv, tris


def tess_plane(w, l):
    hw, hl = 0.5 * w, 0.5 * l
    pos = [(-hw, -hl, 0.0), (hw, -hl, 0.0), (hw, hl, 0.0), (-hw, hl, 0.0)]
    nrm = [(0.0, 0.0, 1.0)] * 4
    uv = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    return pos, nrm, uv, [(0, 1, 2), (0, 2, 3)]


def write_atomic(path, data):
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        raise UserError("-", "cannot write %s: directory %s does not exist" % (path, d))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=d)
    try:
        # the usual 0666 & ~umask, not mkstemp's 0600: other users and processes read scene files
        mask = os.umask(0)
        os.umask(mask)
        os.fchmod(fd, 0o666 & ~mask)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


USAGE = ("usage: raysplat_usd.py INPUT.usd[a|c|z] OUTPUT.rss [--camera PRIM] [--frame TIMECODE] "
         "[--subdivision-level N] [--json-summary]")


def parse_args(argv):
    """(input, output, camera, frame, subdivision level, summary), or None for a usage error."""
    args, camera, frame, level, summary = [], None, None, SUBDIVISION_LEVEL, False
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--json-summary":
            summary = True
        elif a in ("--camera", "--frame", "--subdivision-level"):
            if i + 1 == len(argv):
                return None
            i += 1
            if a == "--camera":
                camera = argv[i]
            elif a == "--subdivision-level":
                if not argv[i].isdigit() or int(argv[i]) > MAX_SUBDIVISION_LEVEL:
                    return None
                level = int(argv[i])
            else:
                try:
                    frame = float(argv[i])
                except ValueError:
                    return None
        elif a.startswith("--"):
            return None
        else:
            args.append(a)
        i += 1
    if len(args) != 2:
        return None
    return args[0], args[1], camera, frame, level, summary


def main(argv):
    if any(a in ("-h", "--help") for a in argv):
        print(USAGE)
        return 0
    parsed = parse_args(argv)
    if parsed is None:
        sys.stderr.write("error: -: -: %s\n" % USAGE)
        return 2
    inp, outp, camera, frame, level, summary = parsed
    try:
        import pxr.Usd  # noqa: F401
    except ImportError as e:
        sys.stderr.write("error: %s: -: cannot import pxr (usd-core): %s\n" % (inp, e))
        return 1
    conv = Converter(inp, outp, camera=camera, frame=frame, subdivision_level=level)
    try:
        conv.run()
        conv.write()
    except UserError as e:
        for w in conv.warnings:
            sys.stderr.write("warning: %s: %s\n" % (w["prim"], w["message"]))
        sys.stderr.write("error: %s: %s: %s\n" % (inp, e.prim, e.message))
        return 2
    for w in conv.warnings:
        sys.stderr.write("warning: %s: %s\n" % (w["prim"], w["message"]))
    if summary:
        sys.stdout.write(json.dumps(conv.summary()) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
