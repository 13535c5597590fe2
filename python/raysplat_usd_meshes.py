"""raysplat_usd_meshes.py: the converter's geometry: meshes (primvars, subsets; subdivision surfaces as
their control cages and tags, which the renderer tessellates), implicit gprims, curves, points, NURBS
patches and tet meshes (through `raysplat_curves.py`). A part of the converter (`raysplat_usd.py`), which the Rust binary runs as
one text after `raysplat_usd_common.py`."""

import os
import sys

if "UserError" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_usd_common import *  # noqa: F401,F403


class MeshReader:
    """Geometry of `Converter` (a mixin: the state lives in `Converter.__init__`)."""

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
        if subdiv and scheme in SUBDIVISION_SCHEMES:
            return self.subdivision_geometry(prim, mesh, P, npts, fvc, fvi, uv_wanted, color)
        if subdiv:
            self.warn(path, "unknown subdivision scheme %r; rendered as its control cage" % scheme)
        left = mesh.GetOrientationAttr().Get(t) == UsdGeom.Tokens.leftHanded
        holes = set(int_list(mesh.GetHoleIndicesAttr().Get(t)))
        # Triangulation (fan) into corner indices.
        if not holes and fvc.count(3) == nf and not left:
            tri_corners, tri_face = None, None
            ntri = nf
        else:
            tri_corners, tri_face, degenerate = fan_triangles(fvc, holes, left)
            if degenerate:
                self.warn(path, "%d faces with fewer than 3 vertices skipped" % degenerate)
            ntri = len(tri_face)
            if ntri == 0:
                self.warn(path, "mesh has no triangles after removing holes and degenerate faces; skipped")
                return None
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
        if nvals is None and path in self._skinned:
            nb = self.smooth_normals(P, npts, fvi, tri_corners, nfv)
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
                p = self.plan(prim, "primvars:%s" % uvpv.GetPrimvarName(), ub, 8, uvpv.GetInterpolation(),
                              uvpv.GetIndices(t), npts, nf, nfv, corner_face)
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
                p = self.plan(prim, "primvars:%s" % color, cb, 12, cpv.GetInterpolation(), cpv.GetIndices(t),
                              npts, nf, nfv, corner_face)
                if p is not None:
                    attrs.append(("colors", cb, 12, p))
        out = {"positions": None, "normals": None, "uvs": None, "colors": None}
        if all(a[3][0] == "vertex" for a in attrs):
            out["positions"] = P
            nverts = npts
            for name, data, w, (_, idx) in attrs:
                out[name] = gather(data, w, idx)
            indices = fvi if tri_corners is None else take(fvi, tri_corners)
        else:
            corner_attrs = [a for a in attrs if a[3][0] == "corner"]
            if any(a[3][1] is None for a in corner_attrs):
                # Un-indexed face-varying data: every face-vertex is its own vertex.
                keys = None
                remap = None
                nverts = nfv
            else:
                remap, keys = unique_rows([fvi] + [a[3][1] for a in corner_attrs])
                nverts = len(keys)
            pidx = fvi if keys is None else [k[0] for k in keys] if np is None else keys[:, 0]
            out["positions"] = gather(P, 12, pidx)
            ci = 0
            for name, data, w, (mode, idx) in attrs:
                if mode == "vertex":
                    sel = pidx if idx is None else take(idx, pidx)
                else:
                    ci += 1
                    sel = idx if keys is None else [k[ci] for k in keys] if np is None else keys[:, ci]
                out[name] = gather(data, w, sel)
            if tri_corners is None:
                indices = list(range(nfv)) if remap is None else remap
            else:
                indices = tri_corners if remap is None else take(remap, tri_corners)
        geo = Geometry()
        geo.positions, geo.npos = out["positions"], nverts
        geo.indices, geo.ntri = u32_bytes(indices), ntri
        geo.normals, geo.uvs, geo.colors = out["normals"], out["uvs"], out["colors"]
        geo.tri_face = tri_face.tolist() if np is not None and isinstance(tri_face, np.ndarray) else tri_face
        geo.double_sided = bool(mesh.GetDoubleSidedAttr().Get(t))
        return geo

    def subdivision_geometry(self, prim, mesh, P, npts, fvc, fvi, uv_wanted, color):
        """A subdivision surface as its control cage and tags (`docs/scene-format.md`, "Subdivision
        surfaces"), which the renderer tessellates (Catmull-Clark, through Embree) or refines:
        leftHanded faces reversed, holes, creases (one sharpness per edge, negative read as 0 with a
        warning), corners, the boundary and face-varying rules, and the texture coordinates and
        vertex colours as values with an index per face-vertex."""
        UsdGeom = self.UsdGeom
        t = self.time
        path = str(prim.GetPath())
        nf, nfv = len(fvc), len(fvi)
        perm = None
        if mesh.GetOrientationAttr().Get(t) == UsdGeom.Tokens.leftHanded:
            # each face reversed, its first corner kept: the front is then the counter-clockwise side
            perm, off = [], 0
            for c in fvc:
                if c:
                    perm.append(off)
                    perm.extend(range(off + c - 1, off, -1))
                off += c
            fvi = [fvi[k] for k in perm]
        holes = int_list(mesh.GetHoleIndicesAttr().Get(t))
        bad = [h for h in holes if not 0 <= h < nf]
        if bad:
            self.warn(path, "%d holeIndices out of range (%d faces) ignored" % (len(bad), nf))
        holes = sorted({h for h in holes if 0 <= h < nf})
        boundary = str(mesh.GetInterpolateBoundaryAttr().Get(t) or "edgeAndCorner")
        if boundary not in BOUNDARY_RULES:
            self.warn(path, "unknown interpolateBoundary %r; edgeAndCorner is used" % boundary)
            boundary = "edgeAndCorner"
        fvar = str(mesh.GetFaceVaryingLinearInterpolationAttr().Get(t) or "cornersPlus1")
        if fvar not in FVAR_RULES:
            self.warn(path, "unknown faceVaryingLinearInterpolation %r; face-varying primvars are refined as "
                      "cornersPlus1" % fvar)
            fvar = "cornersPlus1"
        crease_s = [float(x) for x in mesh.GetCreaseSharpnessesAttr().Get(t) or []]
        try:
            creases = crease_edges(int_list(mesh.GetCreaseIndicesAttr().Get(t)), int_list(mesh.GetCreaseLengthsAttr().Get(t)),
                                   crease_s)
        except ValueError as e:
            raise UserError(path, "subdivision creases: %s" % e)
        ci, cs = int_list(mesh.GetCornerIndicesAttr().Get(t)), [float(x) for x in mesh.GetCornerSharpnessesAttr().Get(t) or []]
        if len(ci) != len(cs) or any(not (0 <= v < npts) for v in ci) or any(not (0 <= v < npts) for e in creases for v in e):
            raise UserError(path, "subdivision tags (creases or corners) name vertices out of range or lack sharpnesses")
        if not finite(*cs, *crease_s):
            raise UserError(path, "subdivision tags have non-finite sharpnesses")
        negative = [x for x in (*cs, *crease_s) if x < 0]
        if negative:
            self.warn(path, "%d crease or corner sharpnesses are negative (the least %g); they are read as 0 "
                      "(smooth)" % (len(negative), min(negative)))
        api = UsdGeom.PrimvarsAPI(prim)
        npv = api.GetPrimvar("normals")
        if (npv and npv.HasAuthoredValue()) or mesh.GetNormalsAttr().HasAuthoredValue():
            self.warn(path, "authored normals are ignored on a subdivision surface (as USD specifies); the "
                      "surface's own normals are used")
        cf = []

        def corner_face():
            if not cf:
                cf.extend(f for f, c in enumerate(fvc) for _ in range(c))
            return cf

        def primvar(what, pv, width):
            vals = pv.Get(t)
            data = f32_bytes(vals, width) if vals is not None else b""
            if vals is None or not len(vals):
                return None
            if len(data) != 4 * width * len(vals):
                self.warn(path, "%s is not %d-vectors; ignored" % (what, width))
                return None
            plan = self.plan(prim, what, data, 4 * width, pv.GetInterpolation(), pv.GetIndices(t), npts, nf, nfv, corner_face)
            if plan is None:
                return None
            kind, idx = plan
            if kind == "vertex":
                values = gather(data, 4 * width, idx)
                if pv.GetInterpolation() == UsdGeom.Tokens.varying:
                    return {"mode": "linear", "values": (values, npts), "indices": (u32_bytes(fvi), nfv)}
                return {"mode": "vertex", "values": (values, npts), "indices": None}
            idx = list(range(nfv)) if idx is None else idx
            if perm is not None:
                idx = [idx[k] for k in perm]
            mode = "faceVarying" if pv.GetInterpolation() == UsdGeom.Tokens.faceVarying else "linear"
            return {"mode": mode, "values": (data, len(data) // (4 * width)), "indices": (u32_bytes(idx), nfv)}

        uvs = cols = None
        uvpv = self.pick_uv(prim, uv_wanted)
        if uvpv is not None:
            uvs = primvar("primvars:%s" % uvpv.GetPrimvarName(), uvpv, 2)
        if color:
            cpv = api.GetPrimvar(color)
            if cpv and cpv.HasAuthoredValue():
                cols = primvar("primvars:%s" % color, cpv, 3)
                if cols is not None and not finite(*array.array("f", cols["values"][0])):
                    raise UserError(path, "primvars:%s has non-finite values" % color)
            if cols is None:
                self.warn(path, "has no usable primvars:%s for its material's vertex colours; the material's "
                          "fallback colour is used" % color)
        edges = sorted(creases)
        sd = {
            "scheme": str(mesh.GetSubdivisionSchemeAttr().Get(t)),
            "face_counts": (u32_bytes(fvc), nf),
            "face_indices": (u32_bytes(fvi), nfv),
            "holes": (u32_bytes(holes), len(holes)),
            "creases": (u32_bytes([v for e in edges for v in e]), len(edges)),
            "crease_sharpness": (array_f32([max(0.0, creases[e]) for e in edges]), len(edges)),
            "corners": (u32_bytes(ci), len(ci)),
            "corner_sharpness": (array_f32([max(0.0, x) for x in cs]), len(cs)),
            "boundary": boundary,
            "face_varying": fvar,
            "uvs": uvs,
            "colors": cols,
        }
        return Geometry(P, npts, None, 0, double_sided=bool(mesh.GetDoubleSidedAttr().Get(t)), subdivision=sd)

    def smooth_normals(self, P, npts, fvi, tri_corners, nfv):
        """Area-weighted vertex normals (for cages of unknown subdivision schemes, whose authored
        normals USD ignores, and skinned meshes)."""
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
        elif np is not None:
            sv, sf = icosphere(levels)
            pos, npos, idx, ntris, nrm, vcols = point_spheres(P, widths, cols, sv, sf)
            return Geometry(pos, npos, idx, ntris, normals=nrm, colors=vcols,
                            double_sided=bool(UsdGeom.Gprim(prim).GetDoubleSidedAttr().Get(t)))
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


def crease_edges(indices, lengths, sharpnesses):
    """UsdGeomMesh creases as {(a, b) with a < b: sharpness}: `creaseLengths` chains of
    `creaseIndices`, one sharpness per chain or one per edge of the chains (an edge named twice
    keeps the larger)."""
    if any(n < 0 for n in lengths) or sum(lengths) != len(indices):
        raise ValueError("creaseLengths add up to %d where creaseIndices has %d" % (sum(lengths), len(indices)))
    edges = sum(max(n - 1, 0) for n in lengths)
    if len(sharpnesses) not in (len(lengths), edges):
        raise ValueError("%d creaseSharpnesses for %d creases of %d edges (one per crease or one per edge)"
                         % (len(sharpnesses), len(lengths), edges))
    per_edge = len(sharpnesses) != len(lengths)
    out, off, k = {}, 0, 0
    for c, n in enumerate(lengths):
        for j in range(n - 1):
            a, b = indices[off + j], indices[off + j + 1]
            s = sharpnesses[k] if per_edge else sharpnesses[c]
            k += 1
            key = (a, b) if a < b else (b, a)
            out[key] = max(out.get(key, 0.0), float(s))
        off += n
    return out
