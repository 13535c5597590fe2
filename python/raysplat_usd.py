#!/usr/bin/env python3
"""raysplat_usd.py: convert a USD stage into the raysplat scene format (.rss).

    python3 raysplat_usd.py INPUT.usd[a|c|z] OUTPUT.rss [--json-summary]

The converter is in parts, one per concept: `raysplat_usd_common.py` (imports, limits, errors, helpers),
`raysplat_usd_materials.py`, `raysplat_usd_mtlx.py` (with `raysplat_usd_mtlx_nodes.py`), `raysplat_usd_meshes.py` and `raysplat_usd_lights.py`
(the `Converter`'s mixins), and this file (the stage, traversal, cameras, instancing, output, command line). The Rust
binary embeds them with `raysplat_curves.py` and runs their concatenation as
`python3 - INPUT OUTPUT` with the source on stdin, so they must not depend on their location and import
nothing but the standard library, `pxr` (usd-core) and, for MaterialX looks only, `MaterialX` (without
it those fall back, with a warning); run as files, each imports the ones it needs.

Output format: `docs/scene-format.md`; unit conventions: `docs/units.md`. Everything written is in
metres, Y up, linear Rec.709 radiance. Meshes are in object space and placed by instances.

Exit status: 0 converted; 2 bad input (missing file, parse error, no geometry, malformed arrays, memory
running out) with one line `error: <file>: <prim path or ->: <message>` on stderr, the prim being the
one read when it failed; 1 when usd-core is missing. No traceback (set RAYSPLAT_CONVERTER_TRACEBACK=1
to see one). `--parent-pid PID` ends the converter with that parent (Linux), `--memory-limit BYTES`
caps its data segment, `--textures-dir DIR` is where textures packaged in a .usdz are extracted
(default OUTPUT.textures).
Whatever cannot be represented exactly is listed in the header's `warnings` and printed to stderr as
`warning: <prim>: <message>`; nothing is dropped silently.
"""

import json
import os
import sys

if "LightReader" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_usd_common import *  # noqa: F401,F403
    from raysplat_usd_materials import MaterialReader
    from raysplat_usd_mtlx import MtlxReader
    from raysplat_usd_meshes import MeshReader
    from raysplat_usd_lights import LightReader


# --------------------------------------------------------------------------------------------------
# The converter
# --------------------------------------------------------------------------------------------------


class Converter(MaterialReader, MtlxReader, MeshReader, LightReader):
    """A stage read into scene data: the stage, its traversal, cameras, instancing and the output;
    materials, geometry and lights come from the mixins (`raysplat_usd_materials.py`,
    `raysplat_usd_meshes.py`, `raysplat_usd_lights.py`)."""

    def __init__(self, input_path, output_path, camera=None, frame=None):
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
        self.progress = Progress()
        # render settings: width over height of a pixel, and how the apertures meet the image
        self.pixel_aspect, self.aspect_conform = 1.0, "expandAperture"
        self.frame = frame
        self.resolution = None
        self._extract_dir = None
        self.textures_dir = None  # where packaged textures are extracted (default: OUTPUT.textures)
        self.current_prim = None  # the prim being read (an unexpected failure names it)
        self._extracted = {}
        self._bindings = {}  # prim path -> bound materials (point-instancer leaves repeat)
        self._mtlx = None  # (MaterialX module, standard library) once loaded; False without the package
        self._mtlx_docs = {}  # .mtlx path -> its document (None: unreadable)

    # ---- diagnostics --------------------------------------------------------------------------
    def warn(self, prim, message):
        prim = str(prim) if prim else "-"
        key = (prim, message)
        if key in self._warned:
            return
        self._warned.add(key)
        self.warnings.append({"prim": prim, "message": message})

    # ---- stage ----------------------------------------------------------------------------------
    def check_declared_sizes(self):
        """A crate file (the input, or the layers packaged in a .usdz) must not declare more than it
        holds: usd-core would allocate it first (raysplat_crate.py)."""
        import mmap
        try:
            with open(self.input, "rb") as f:
                if f.read(8) == b"PXR-USDC":
                    with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
                        check_crate(data)
                    return
            if not zipfile.is_zipfile(self.input):
                return
            with zipfile.ZipFile(self.input) as z:
                for info in z.infolist():
                    if info.filename.lower().endswith((".usdc", ".usd")):
                        try:
                            data = read_member(z, info.filename)
                        except ValueError as e:
                            raise UserError("-", "the package's layer %s: %s" % (info.filename, e))
                        if data[:8] == b"PXR-USDC":
                            check_crate(data)
        except CrateError as e:
            raise UserError(e.prim, e.message)
        except (OSError, ValueError, zipfile.BadZipFile):
            return  # usd-core reports what it cannot read

    def check_layer_files(self):
        """Every layer the stage opens (sublayers, references, payloads, found from the root layer
        by Sdf, before any composition) must be a regular file: usd-core would wait for ever on a
        FIFO. Crate files among them are checked for their declared sizes (raysplat_crate.py)."""
        import mmap
        Sdf = self.Sdf
        self._checked_layers = []  # kept open: the stage reuses them
        todo, seen = [os.path.abspath(self.input)], set()
        while todo:
            path = todo.pop()
            if path in seen:
                continue
            seen.add(path)
            cap = CaptureStderr()
            try:
                with cap:
                    layer = Sdf.Layer.FindOrOpen(path)
            except self.Tf.ErrorException:
                layer = None  # usd-core reports it when it composes the stage
            if layer is None:
                continue
            self._checked_layers.append(layer)
            for dep in layer.GetCompositionAssetDependencies():
                if not dep:
                    continue  # an empty asset path (an internal reference, `references = </A>`): nothing to open
                try:
                    resolved = Sdf.ComputeAssetPathRelativeToLayer(layer, dep)
                except self.Tf.ErrorException:
                    continue  # usd-core reports it when it composes the stage
                if not resolved or "[" in resolved or not os.path.exists(resolved):
                    continue
                if not os.path.isfile(resolved):
                    kind = "a directory" if os.path.isdir(resolved) else "not a regular file (a FIFO, device or socket)"
                    raise UserError("-", "the layer %s refers to %s, which is %s" % (path, dep, kind))
                try:
                    with open(resolved, "rb") as f:
                        if f.read(8) == b"PXR-USDC":
                            with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
                                check_crate(data)
                except CrateError as e:
                    raise UserError(e.prim, "%s (in %s)" % (e.message, resolved))
                except (OSError, ValueError):
                    continue
                # only USD layers are opened here: a MaterialX document is read by its own file
                # format (with arguments this plain open would not give), when the stage composes
                if os.path.splitext(resolved)[1].lower() in (".usd", ".usda", ".usdc", ".usdz"):
                    todo.append(resolved)

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
        self.check_declared_sizes()
        self.check_layer_files()
        cap = CaptureStderr()
        stage = None
        try:
            with cap:
                stage = Usd.Stage.Open(self.input, Usd.Stage.LoadAll)
        except Tf.ErrorException as e:
            why = parse_tf_error(e)
            if "bad_alloc" in why:
                raise UserError("-", "out of memory opening the stage (its layers need more than the memory left)")
            raise UserError("-", "cannot open the stage: %s" % why)
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
            if re.search(r"Could not open asset @[^@]*\.mtlx@", msg):
                # usd-core has no usdMtlx plugin; bindings to such looks are read with MaterialX
                msg = re.sub(r" for reference introduced by .*", "", msg)
                msg += (": USD cannot compose MaterialX documents (no usdMtlx plugin); the converter reads the "
                        "materials bound from it with the MaterialX package")
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
        visited = 0
        while stack:
            prim, inherited = stack.pop()
            visited += 1
            self.progress("read %d prims, %d meshes, %d instances" % (visited, len(self.meshes), len(self.instances)))
            if prim.IsA(UsdShade.Material) or prim.IsA(UsdShade.NodeGraph) or prim.IsA(UsdShade.Shader):
                continue
            skip, purpose = self.imageable_state(prim, inherited)
            if skip:
                continue
            self.current_prim = str(prim.GetPath())
            try:
                descend = self.visit(prim)
            except self.Tf.ErrorException as e:
                # a value usd-core cannot read (a crate file whose arrays claim more than it holds)
                raise UserError(self.current_prim, "cannot read the prim: %s" % parse_tf_error(e))
            except MemoryError:
                raise UserError(self.current_prim, "out of memory reading the prim (its arrays claim more "
                                "than the memory left)")
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
        self.current_prim = str(sp)
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
            if 0 < w <= MAX_RESOLUTION and 0 < h <= MAX_RESOLUTION:
                self.resolution = [w, h]
            else:
                self.warn(sp, "resolution %dx%d is out of range (1 to %d per side); ignored (--resolution, else "
                          "512x512, is used)" % (w, h, MAX_RESOLUTION))
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
        # exposure: the linear scale a renderer applies to the image (USD 24.11+:
        # 2^exposure · (exposure:time · exposure:iso / 100) / exposure:fStop² · exposure:responsivity)
        exposure = float(cam.ComputeLinearExposureScale(t)) if hasattr(cam, "ComputeLinearExposureScale") else 1.0
        if not (exposure > 0.0 and math.isfinite(exposure)):
            raise UserError(path, "the camera's exposure scale is %r (exposure %r, exposure:iso %r, exposure:time %r, "
                            "exposure:fStop %r, exposure:responsivity %r): it must be positive and finite"
                            % (exposure, cam.GetExposureAttr().Get(t), cam.GetExposureIsoAttr().Get(t),
                               cam.GetExposureTimeAttr().Get(t), cam.GetExposureFStopAttr().Get(t),
                               cam.GetExposureResponsivityAttr().Get(t)))
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
            "exposure_scale": exposure,
        }

    # ---- point instancers -----------------------------------------------------------------------
    def collect_proto(self, root):
        """Renderable leaves of a prototype subtree: list of (prim, row-vector matrix relative to root,
        including the root's own transform only through the instance transform)."""
        UsdShade = self.UsdShade
        found = []
        pred = self.predicate()
        stack = [(root, "default")]
        visited = 0
        while stack:
            prim, inherited = stack.pop()
            visited += 1
            self.progress("read %d prims, %d meshes, %d instances" % (visited, len(self.meshes), len(self.instances)))
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
        self.progress("writing %d meshes" % len(self.meshes), force=True)
        for m in self.meshes:
            g = m["geometry"]
            if id(g) not in geo_refs:
                sd = g.subdivision
                geo_refs[id(g)] = {
                    "positions": push(g.positions, "f32x3", g.npos),
                    "indices": push(g.indices, "u32x3", g.ntri) if sd is None else None,
                    "normals": push(g.normals, "f32x3", g.npos) if g.normals is not None else None,
                    "uvs": push(g.uvs, "f32x2", g.npos) if g.uvs is not None else None,
                    "colors": push(g.colors, "f32x3", g.npos) if g.colors is not None else None,
                }
                if sd is not None:
                    geo_refs[id(g)]["subdivision"] = self.subdivision_header(sd, push)
            r = geo_refs[id(g)]
            entry = {"name": m["name"], "double_sided": g.double_sided, "positions": r["positions"],
                     "indices": r["indices"], "normals": r["normals"], "uvs": r["uvs"], "colors": r["colors"],
                     "material_ids": push(u32_bytes(m["material_ids"]), "u32", len(m["material_ids"]))}
            if "subdivision" in r:
                entry["subdivision"] = r["subdivision"]
            meshes.append(entry)
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
        out += (0).to_bytes(4, "little")  # the checksum, below
        out += len(js).to_bytes(8, "little")
        out += js
        out += b"\0" * ((-len(out)) % 16)
        out += blob
        out[12:16] = (zlib.crc32(memoryview(out)[16:]) & 0xFFFFFFFF).to_bytes(4, "little")
        write_atomic(self.output, bytes(out))

    @staticmethod
    def subdivision_header(sd, push):
        """A subdivision surface's header (`docs/scene-format.md`), its arrays pushed into the blob."""
        def arr(pair, ty, optional=False):
            data, count = pair
            return None if optional and count == 0 else push(data, ty, count)

        def primvar(pv, ty):
            if pv is None:
                return None
            return {"mode": pv["mode"], "values": arr(pv["values"], ty),
                    "indices": arr(pv["indices"], "u32") if pv["indices"] is not None else None}
        return {
            "scheme": sd["scheme"],
            "face_counts": arr(sd["face_counts"], "u32"),
            "face_indices": arr(sd["face_indices"], "u32"),
            "holes": arr(sd["holes"], "u32", True),
            "creases": arr(sd["creases"], "u32x2", True),
            "crease_sharpness": arr(sd["crease_sharpness"], "f32", True),
            "corners": arr(sd["corners"], "u32", True),
            "corner_sharpness": arr(sd["corner_sharpness"], "f32", True),
            "boundary": sd["boundary"],
            "face_varying": sd["face_varying"],
            "uvs": primvar(sd["uvs"], "f32x2"),
            "colors": primvar(sd["colors"], "f32x3"),
        }

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
        faces = sum(len(self.meshes[i["mesh"]]["geometry"].subdivision["face_counts"][0]) // 4
                    for i in self.instances if self.meshes[i["mesh"]]["geometry"].subdivision is not None)
        return {
            "meshes": len(self.meshes),
            "instances": len(self.instances),
            "triangles": tris,
            "unique_triangles": sum(m["geometry"].ntri for m in self.meshes),
            "subdivision_faces": faces,
            "materials": len(self.materials),
            "textures": len(self.textures),
            "lights": len(self.lights),
            "warnings": len(self.warnings),
            "dependencies": len(self.deps),
            "camera": self.camera["name"] if self.camera else None,
            "time": self.time_code(),
            "seconds": round(self.seconds, 3),
        }


# Bytes held back under --memory-limit and freed to report an error (a line and its formatting).
SPARE_BYTES = 8 << 20

USAGE = ("usage: raysplat_usd.py INPUT.usd[a|c|z] OUTPUT.rss [--camera PRIM] [--frame TIMECODE] "
         "[--textures-dir DIR] [--parent-pid PID] [--memory-limit BYTES] [--json-summary]")


class Args:
    """The command line: input, output and options."""

    def __init__(self):
        self.input = self.output = self.camera = self.frame = self.textures_dir = None
        self.parent_pid = self.memory_limit = None
        self.summary = False


def parse_args(argv):
    """The command line as `Args`, or None for a usage error."""
    a, files = Args(), []
    i = 0
    while i < len(argv):
        arg = argv[i]
        if arg == "--json-summary":
            a.summary = True
        elif arg in ("--camera", "--frame", "--textures-dir", "--parent-pid", "--memory-limit"):
            if i + 1 == len(argv):
                return None
            i += 1
            v = argv[i]
            if arg == "--camera":
                a.camera = v
            elif arg == "--textures-dir":
                a.textures_dir = v
            elif arg in ("--parent-pid", "--memory-limit"):
                if not v.isdigit():
                    return None
                if arg == "--parent-pid":
                    a.parent_pid = int(v)
                else:
                    a.memory_limit = int(v)
            else:
                try:
                    a.frame = float(v)
                except ValueError:
                    return None
        elif arg.startswith("--"):
            return None
        else:
            files.append(arg)
        i += 1
    if len(files) != 2:
        return None
    a.input, a.output = files
    return a


def end_with_parent(parent_pid):
    """Ask the kernel to kill this process when its parent (`raysplat`) ends (Linux
    `PR_SET_PDEATHSIG`); if the parent has already ended, end now. Elsewhere: nothing."""
    try:
        import ctypes
        import signal
        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError, ImportError):
        return
    if os.getppid() != parent_pid:
        os._exit(1)


def limit_memory(limit):
    """Keep the data segment (the heap, anonymous mappings) under `limit` bytes, so that a stage
    whose arrays claim absurd sizes fails with MemoryError instead of exhausting the machine."""
    try:
        import resource
        soft, hard = resource.getrlimit(resource.RLIMIT_DATA)
        if hard != resource.RLIM_INFINITY:
            limit = min(limit, hard)
        if soft == resource.RLIM_INFINITY or limit < soft:
            resource.setrlimit(resource.RLIMIT_DATA, (limit, hard))
    except (ImportError, ValueError, OSError):
        pass


def failure_message(conv, e):
    """(prim, message) of an exception that is not a UserError: a malformed file usd-core could not
    read, memory running out, or a bug of the converter (one line, no traceback)."""
    prim = (conv.current_prim if conv is not None else None) or "-"
    if isinstance(e, MemoryError):
        return prim, "out of memory while converting (the stage's arrays are larger than the memory left)"
    tf = sys.modules.get("pxr.Tf")
    if tf is not None and isinstance(e, tf.ErrorException):
        return prim, "cannot read the stage: %s" % parse_tf_error(e)
    if isinstance(e, (OverflowError, ValueError, IndexError, KeyError, TypeError, ZeroDivisionError)):
        return prim, "malformed data (%s: %s)" % (type(e).__name__, clean_usd_message(str(e)) or "-")
    return prim, "internal error of the converter (%s: %s); please report it" % (type(e).__name__, clean_usd_message(str(e)) or "-")


def main(argv):
    if any(a in ("-h", "--help") for a in argv):
        print(USAGE)
        return 0
    a = parse_args(argv)
    if a is None:
        sys.stderr.write("error: -: -: %s\n" % USAGE)
        return 2
    if a.parent_pid is not None:
        end_with_parent(a.parent_pid)
    # memory set aside while converting and given back before an error is reported, so that the
    # report of memory running out has memory to be written with
    spare = []
    if a.memory_limit is not None:
        limit_memory(a.memory_limit)
        spare.append(bytearray(SPARE_BYTES))
    inp = a.input
    try:
        import pxr.Usd  # noqa: F401
    except ImportError as e:
        sys.stderr.write("error: %s: -: cannot import pxr (usd-core): %s\n" % (inp, e))
        return 1
    except MemoryError:
        sys.stderr.write("error: %s: -: out of memory loading usd-core (limit %s bytes)\n" % (inp, a.memory_limit))
        return 2
    conv = None
    try:
        conv = Converter(inp, a.output, camera=a.camera, frame=a.frame)
        conv.textures_dir = a.textures_dir
        conv.run()
        conv.write()
    except UserError as e:
        spare.clear()
        for w in conv.warnings:
            sys.stderr.write("warning: %s: %s\n" % (w["prim"], w["message"]))
        sys.stderr.write("error: %s: %s: %s\n" % (inp, e.prim, e.message))
        return 2
    except Exception as e:  # noqa: BLE001 (every failure becomes one line naming the file and prim)
        spare.clear()
        if os.environ.get("RAYSPLAT_CONVERTER_TRACEBACK"):
            raise
        # the failed step's frames (and the arrays they hold) go before the message is made
        e.__traceback__ = None
        prim, message = failure_message(conv, e)
        sys.stderr.write("error: %s: %s: %s\n" % (inp, prim, message))
        return 2
    for w in conv.warnings:
        sys.stderr.write("warning: %s: %s\n" % (w["prim"], w["message"]))
    if a.summary:
        sys.stdout.write(json.dumps(conv.summary()) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
