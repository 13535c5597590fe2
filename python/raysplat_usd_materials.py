"""raysplat_usd_materials.py: the converter's materials and textures: material bindings (per prim and
per geometry subset), UsdPreviewSurface networks and their UsdUVTexture / UsdTransform2d /
primvar-reader inputs, texture assets (packaged ones extracted from .usdz). A part of the converter
(`raysplat_usd.py`), which the Rust binary runs as one text after `raysplat_usd_common.py`."""

import os
import sys

if "UserError" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_usd_common import *  # noqa: F401,F403
    from raysplat_usd_mtlx import MtlxRef
    from raysplat_usd_mtlx_nodes import UsdGraph


class MaterialReader:
    """Materials of `Converter` (a mixin: the state lives in `Converter.__init__`)."""

    # ---- materials ------------------------------------------------------------------------------
    def compute_binding(self, prim):
        """The bound UsdShade.Material, a `MtlxRef` (a binding to a material of a `.mtlx` document
        that USD could not compose), or None."""
        UsdShade = self.UsdShade
        api = UsdShade.MaterialBindingAPI(prim)
        rels = []
        for purpose in (UsdShade.Tokens.full, UsdShade.Tokens.preview):
            mat, rel = api.ComputeBoundMaterial(purpose)
            if mat:
                return mat
            rels.append(rel)
        for rel in rels:
            targets = rel.GetTargets() if rel else []
            if targets and self.mtlx() is not None:
                ref = self.mtlx_reference(targets[0])
                if ref is not None:
                    return ref
        return None

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
        if isinstance(mat, MtlxRef):
            return self.mtlx_document_material(mat)
        mpath = str(mat.GetPath())
        key = ("usd", mpath)
        if key in self._material_index:
            return self._material_index[key]
        # MaterialX first, as Hydra renderers that read it do: a network on outputs:mtlx:surface,
        # else a .mtlx document referenced onto the material
        mx_shader = self.mtlx_usd_shader(mat)
        if mx_shader is not None:
            m, uvnames, color = self.mx_surface(UsdGraph(self, self._mtlx[1]), mx_shader, mpath)
            if m["kind"] != "error":
                return self.add_material(key, m, uvnames, color)
        if not mat.GetSurfaceOutputs() and self.mtlx() is not None:
            ref = self.mtlx_reference(mat.GetPath())
            if ref is not None:
                idx = self.mtlx_document_material(ref)
                self._material_index[key] = idx
                return idx
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
                elif low in ("acescg", "lin_ap1", "lin_ap1_scene"):
                    cs = "ACEScg"
                else:
                    self.warn(npath, "file colorSpace %r is not converted; read as %s" % (acs, cs))
        # st
        uvname, st_transform = self.texture_st(node)
        desc = {"path": path, "wrap_s": wraps[0], "wrap_t": wraps[1], "scale": scale, "bias": bias,
                "color_space": cs, "output": output, "fallback": fallback}
        if st_transform != IDENTITY_2D:
            desc["st_transform"] = st_transform
        return self.register_texture(desc, npath), uvname

    def register_texture(self, desc, prim):
        """Index of the texture `desc` (shared by every reader of the same file and settings)."""
        key = json.dumps(desc, sort_keys=True)
        if key not in self._texture_index:
            # the first prim that reads it, for the renderer's warnings (not part of the key)
            desc = dict(desc, prim=str(prim))
            self.textures.append(desc)
            self._texture_index[key] = len(self.textures) - 1
        return self._texture_index[key]

    def texture_st(self, node):
        """The primvar name a texture's st reads (or None) and the affine map of the UsdTransform2d
        nodes between them (`[[a, b, c], [d, e, f]]`: st' = (a s + b t + c, d s + e t + f)). An st
        that reads no primvar (unconnected, a constant, a UsdTransform2d without input) is the
        constant it has, (0, 0) unless authored, as Hydra Storm samples it: a map whose linear part
        is zero."""
        npath = node.GetPath()
        sinp = node.GetInput("st")
        m = IDENTITY_2D
        if not sinp:
            self.warn(npath, "st is not connected; the texture is sampled at st = (0, 0), as the spec and "
                      "Hydra Storm do")
            return None, constant_2d((0.0, 0.0))
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
                    self.warn(src.GetPath(), "UsdTransform2d has no input; its fallback st = (0, 0) is transformed")
                    return None, compose_2d(m, constant_2d((0.0, 0.0)))
                r = self.resolve(ii)
                continue
            if sid and str(sid).startswith("UsdPrimvarReader"):
                v = self.input_value(src, "varname", "st")
                return (str(v) if v else "st"), m
            self.warn(src.GetPath(), "%s drives a texture's st; not supported, the mesh's texture coordinates "
                      "are used" % self.shader_desc(src))
            return None, m
        if r[0] == "value":
            try:
                st = vec(r[1], 2)
            except Exception:
                st = None
            if st is None or not finite(*st):
                self.warn(npath, "st has an unexpected value %r; the texture is sampled at st = (0, 0)" % (r[1],))
                st = [0.0, 0.0]
            return None, compose_2d(m, constant_2d(st))
        if r[0] != "output":
            self.warn(npath, "st is not connected; the texture is sampled at st = (0, 0), as the spec and "
                      "Hydra Storm do")
        return None, compose_2d(m, constant_2d((0.0, 0.0)))

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
                data = read_member(z, name)
                while rest is not None:
                    with zipfile.ZipFile(io.BytesIO(data)) as z2:
                        name = rest
                        rest = None
                        if "[" in name:
                            n2 = name[:name.index("[")]
                            rest = name[len(n2) + 1:-1]
                            name = n2
                        data = read_member(z2, name)
        except (OSError, KeyError, ValueError, zipfile.BadZipFile) as e:
            self.warn(where, "cannot extract %s: %s; its fallback is used" % (resolved, e))
            return resolved
        if self._extract_dir is None:
            self._extract_dir = os.path.abspath(self.textures_dir or (self.output + ".textures"))
            os.makedirs(self._extract_dir, exist_ok=True)
        digest = hashlib.sha256(resolved.encode("utf-8")).hexdigest()[:12]
        target = os.path.join(self._extract_dir, "%s_%s" % (digest, os.path.basename(name)))
        with open(target + ".tmp", "wb") as f:
            f.write(data)
        os.replace(target + ".tmp", target)
        self.texture_files[os.path.abspath(outer)] = True
        self._extracted[resolved] = target
        return target

