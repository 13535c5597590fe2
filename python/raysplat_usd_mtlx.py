"""raysplat_usd_mtlx.py: MaterialX looks, read with the `MaterialX` package (PyPI, installed by
`make setup`): `.mtlx` documents that USD references (`@X.mtlx@</MaterialX/Materials>`, which the
PyPI usd-core cannot compose: it has no usdMtlx plugin) and `outputs:mtlx:surface` networks of
UsdShade shaders whose `info:id` names a MaterialX node definition. `standard_surface`,
`open_pbr_surface` and `UsdPreviewSurface` shaders map onto the renderer's UsdPreviewSurface
material; their inputs are values, or image lookups through the nodes the mapping can carry
(`docs/units.md`, "Materials (MaterialX)"). A part of the converter (`raysplat_usd.py`)."""

import os
import sys

if "UserError" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_usd_common import *  # noqa: F401,F403

# MaterialX value types: number of components (scalars 1).
MX_SIZES = {"float": 1, "integer": 1, "boolean": 1, "vector2": 2, "color3": 3, "vector3": 3, "color4": 4, "vector4": 4}
# MaterialX colour spaces -> the texture's `color_space`.
MX_COLOR_SPACES = {"srgb_texture": "sRGB", "lin_rec709": "raw", "lin_srgb": "raw", "raw": "raw", "none": "raw",
                   "acescg": "ACEScg", "lin_ap1": "ACEScg", "lin_ap1_scene": "ACEScg"}
# MaterialX address modes -> wrap modes (`constant` returns the image's `default`: black when it is 0).
MX_ADDRESS = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "constant": "black"}


class MxConst:
    """A constant: a list of floats (one for scalars)."""

    def __init__(self, v):
        self.v = [float(x) for x in v]


class MxTex:
    """`(texel · scale + bias)[channels]` of one image: `desc` is its texture description without
    scale, bias and output; `uv` the primvar its coordinates read (None: the mesh's own)."""

    def __init__(self, desc, scale, bias, channels, uv):
        self.desc, self.scale, self.bias, self.channels, self.uv = desc, list(scale), list(bias), list(channels), uv

    def copy(self):
        return MxTex(dict(self.desc), self.scale, self.bias, self.channels, self.uv)


class MxUV:
    """Texture coordinates: the primvar `name` (None: the mesh's own), mapped by the 2D affine `m`."""

    def __init__(self, name, m):
        self.name, self.m = name, m


class MxVertex:
    """A colour primvar read per vertex."""

    def __init__(self, name):
        self.name = name


class MxNormal:
    """A tangent-space normal map (`normalmap` node): its texture gives the normal in [-1, 1]."""

    def __init__(self, tex):
        self.tex = tex


class MtlxRef:
    """A material in a MaterialX document: `path` is the bound USD path it stands for."""

    def __init__(self, file, name, path):
        self.file, self.name, self.path = file, name, path


def mx_list(v):
    """A MaterialX or USD value as a list of floats, or a string / number as is."""
    if isinstance(v, (str, bool)):
        return v
    if isinstance(v, (int, float)):
        return [float(v)]
    try:
        return [float(x) for x in v]
    except TypeError:
        return v


def broadcast(v, n):
    return v * n if len(v) == 1 else v[:n]


class DocGraph:
    """A node network inside a MaterialX document (`mx.Node` elements)."""

    def __init__(self, conv, doc, path):
        self.conv, self.doc, self.path = conv, doc, path

    def nodedef(self, node):
        return node.getNodeDef()

    def where(self, node):
        return "%s:%s" % (self.path, node.getNamePath())

    def input(self, node, name):
        """('value', v) | ('node', upstream node, output name) | ('default', v) | ('none',)."""
        inp = node.getInput(name)
        depth = 0
        while inp is not None and depth < 16:
            depth += 1
            iface = inp.getInterfaceInput() if inp.hasInterfaceName() else None
            if iface is not None:
                inp = iface
                continue
            up = inp.getConnectedNode()
            if up is not None:
                out = inp.getConnectedOutput()
                return ("node", up, out.getName() if out is not None and out.getParent() == up else "out")
            if inp.hasValueString():
                return ("value", inp.getValue())
            break
        nd = self.nodedef(node)
        d = nd.getActiveInput(name) if nd is not None else None
        if d is not None and d.hasValueString():
            return ("default", d.getValue())
        return ("none",)

    def file(self, node):
        """(absolute path or None, colour space, the authored path) of an image node's `file`."""
        inp = node.getInput("file")
        if inp is None or not inp.getValueString():
            return None, "", ""
        authored = inp.getResolvedValueString()
        path = authored if os.path.isabs(authored) else os.path.normpath(
            os.path.join(os.path.dirname(self.path), authored))
        # a dependency of the conversion (recorded absent when missing: adding it re-converts)
        self.conv.texture_files[os.path.abspath(path)] = True
        if not os.path.isfile(path):
            self.conv.warn(self.where(node), "texture file %s not found; its fallback is used" % path)
        return path, inp.getActiveColorSpace(), authored


class UsdGraph:
    """A node network of UsdShade shaders whose `info:id` names MaterialX node definitions."""

    def __init__(self, conv, lib):
        self.conv, self.lib = conv, lib

    def nodedef(self, node):
        return self.lib.getNodeDef(str(node.GetShaderId() or ""))

    def where(self, node):
        return str(node.GetPath())

    def input(self, node, name):
        inp = node.GetInput(name)
        if inp:
            r = self.conv.resolve(inp)
            if r[0] == "value":
                return ("value", r[1])
            if r[0] == "output":
                return ("node", r[1], r[2])
        nd = self.nodedef(node)
        d = nd.getActiveInput(name) if nd is not None else None
        if d is not None and d.hasValueString():
            return ("default", d.getValue())
        return ("none",)

    def file(self, node):
        inp = node.GetInput("file")
        if not inp:
            return None, "", ""
        r = self.conv.resolve(inp)
        if r[0] != "value" or not isinstance(r[1], self.conv.Sdf.AssetPath) or not r[1].path:
            return None, "", ""
        attr = inp.GetValueProducingAttributes(False)[0]
        path = self.conv.resolve_texture(r[1], attr, node.GetPath())
        cs = attr.GetColorSpace() if attr.HasColorSpace() else ""
        return path, cs, r[1].path


class MtlxReader:
    """MaterialX looks of `Converter` (a mixin: the state lives in `Converter.__init__`)."""

    def mtlx(self):
        """(MaterialX module, its standard library document), or None without the package (warned
        once: MaterialX looks then fall back to UsdPreviewSurface, or render as error materials)."""
        if self._mtlx is None:
            try:
                import MaterialX as mx
                lib = mx.createDocument()
                mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
                self._mtlx = (mx, lib)
            except Exception as e:  # ImportError, or a package without its libraries
                self.warn("/", "the MaterialX package cannot be used (%s; `make setup` installs it): MaterialX "
                          "looks fall back to UsdPreviewSurface where the material has one" % e)
                self._mtlx = False
        return self._mtlx or None

    # ---- finding MaterialX looks ------------------------------------------------------------------
    def mtlx_reference(self, path):
        """A MaterialX document material standing at USD path `path` through a `.mtlx` reference on
        it or an ancestor (e.g. `@X.mtlx@</MaterialX/Materials>` on a scope holding the looks), or
        None."""
        Sdf = self.Sdf
        path = Sdf.Path(str(path))
        anc = path
        found = []
        while anc != Sdf.Path.absoluteRootPath and not anc.isEmpty and not found:
            prim = self.stage.GetPrimAtPath(anc)
            if prim:
                for spec in prim.GetPrimStack():
                    refs = spec.referenceList
                    for ref in list(refs.explicitItems) + list(refs.prependedItems) + list(refs.appendedItems) + list(refs.addedItems):
                        if not ref.assetPath.lower().endswith(".mtlx"):
                            continue
                        file = os.path.normpath(spec.layer.ComputeAbsolutePath(ref.assetPath))
                        root = ref.primPath if not ref.primPath.isEmpty else Sdf.Path("/MaterialX")
                        target = path.ReplacePrefix(anc, root)
                        parts = [str(p) for p in target.GetPrefixes()]
                        # usdMtlx puts a document's materials at /MaterialX/Materials/<name>
                        if len(parts) == 3 and parts[1] == "/MaterialX/Materials":
                            found.append(MtlxRef(file, target.name, str(path)))
            anc = anc.GetParentPath()
        # several documents may be referenced onto one scope: the one that has the material
        for ref in found:
            doc = self.mtlx_document(ref.file, ref.path)
            if doc is not None and doc.getNode(ref.name) is not None:
                return ref
        return found[0] if found else None

    def mtlx_document(self, file, where):
        """The MaterialX document in `file` (with the standard library), or None (warned)."""
        if file in self._mtlx_docs:
            return self._mtlx_docs[file]
        doc = None
        m = self.mtlx()
        if m is not None:
            mx, lib = m
            self.texture_files[os.path.abspath(file)] = True  # a dependency, also when missing
            if not os.path.isfile(file):
                self.warn(where, "MaterialX document %s not found" % file)
            else:
                try:
                    d = mx.createDocument()
                    mx.readFromXmlFile(d, file)
                    d.importLibrary(lib)
                    doc = d
                except Exception as e:
                    self.warn(where, "cannot read the MaterialX document %s: %s" % (file, e))
        self._mtlx_docs[file] = doc
        return doc

    def mtlx_document_material(self, ref):
        """Material index of a material of a MaterialX document (`MtlxRef`)."""
        key = ("mtlx", ref.file, ref.name)
        if key in self._material_index:
            return self._material_index[key]
        doc = self.mtlx_document(ref.file, ref.path)
        mnode = doc.getNode(ref.name) if doc is not None else None
        if mnode is None:
            if doc is not None:
                self.warn(ref.path, "MaterialX document %s has no material %r; rendered as an error material"
                          % (ref.file, ref.name))
            return self.add_material(key, {"kind": "error", "name": ref.path})
        graph = DocGraph(self, doc, ref.file)
        r = graph.input(mnode, "surfaceshader")
        if r[0] != "node":
            self.warn(ref.path, "MaterialX material %r has no surface shader; rendered as an error material" % ref.name)
            return self.add_material(key, {"kind": "error", "name": ref.path})
        m, uvnames, color = self.mx_surface(graph, r[1], ref.path)
        return self.add_material(key, m, uvnames, color)

    def mtlx_usd_shader(self, mat):
        """The shader driving the material's `outputs:mtlx:surface`, if it is a MaterialX node."""
        if self.mtlx() is None:
            return None
        out = mat.GetSurfaceOutput("mtlx")
        if not out:
            return None
        src = mat.ComputeSurfaceSource("mtlx")
        shader = src[0] if src else None
        if shader and str(shader.GetShaderId() or "").startswith("ND_"):
            return shader
        return None

    # ---- the surface ---------------------------------------------------------------------------
    def mx_surface(self, graph, node, mpath):
        """(material dict, st primvar names, vertex-colour primvar) of a MaterialX surface shader."""
        nd = graph.nodedef(node)
        category = nd.getNodeString() if nd is not None else ""
        self._mx_uv = set()
        self._mx_vertex = None
        where = graph.where(node)
        if category == "standard_surface":
            m = self.mx_standard_surface(graph, node, mpath, where)
        elif category == "open_pbr_surface":
            m = self.mx_open_pbr(graph, node, mpath, where)
        elif category == "UsdPreviewSurface":
            m = self.mx_preview(graph, node, mpath, where)
        else:
            self.warn(where, "MaterialX surface %s is not supported (standard_surface, open_pbr_surface and "
                      "UsdPreviewSurface are)" % (category or "of an unknown node"))
            return {"kind": "error", "name": mpath}, set(), None
        return m, set(self._mx_uv), self._mx_vertex

    def mx_in(self, graph, node, name, size):
        """An input of the surface as MxConst / MxTex / MxVertex / MxNormal, or None (no value)."""
        r = graph.input(node, name)
        if r[0] in ("value", "default"):
            v = mx_list(r[1])
            return MxConst(broadcast(v, size)) if isinstance(v, list) else None
        if r[0] == "node":
            v = self.mx_eval(graph, r[1], r[2], 0)
            if v is None:
                nd = graph.nodedef(node)
                d = nd.getActiveInput(name) if nd is not None else None
                if d is not None and d.hasValueString():
                    self.warn(graph.where(r[1]), "drives %s.%s and cannot be mapped; its default is used"
                              % (graph.where(node), name))
                    return MxConst(broadcast(mx_list(d.getValue()), size))
            return v
        return None

    def mx_scalar(self, v, default):
        return v.v[0] if isinstance(v, MxConst) else default

    def mx_weighted(self, weight, color, where, what):
        """`weight · color` (either may be a texture, not both: then the weight is dropped)."""
        if isinstance(weight, MxConst) and isinstance(color, MxConst):
            return MxConst([weight.v[0] * c for c in color.v])
        if isinstance(weight, MxConst):
            return self.mx_affine(color, [weight.v[0]] * 3, [0.0] * 3, where) if color is not None else None
        if isinstance(color, MxConst) and isinstance(weight, MxTex):
            t = self.mx_broadcast(weight, 3)
            return self.mx_affine(t, color.v, [0.0] * 3, where) if t is not None else None
        if color is not None and weight is not None:
            self.warn(where, "%s: a texture times a texture cannot be represented; the weight's texture is dropped"
                      % what)
        return color

    def mx_field(self, v, default, kind, where, name):
        """A material field `{"value", "texture"[, "vertex"]}` from a mapped input."""
        if v is None:
            v = MxConst(list(default) if kind == "color" else [default])
        if isinstance(v, MxVertex):
            if kind == "color":
                self._mx_vertex = v.name
                return {"value": [0.18, 0.18, 0.18], "texture": None, "vertex": True}
            self.warn(where, "%s reads a primvar per vertex, which only diffuse colours can; its default is used"
                      % name)
            v = MxConst(list(default) if kind == "color" else [default])
        if isinstance(v, MxNormal):
            v = MxConst(list(default) if kind == "color" else [default])
        if isinstance(v, MxConst):
            val = broadcast(v.v, 3) if kind == "color" else v.v[0]
            return {"value": val, "texture": None}
        tex = v if kind == "color" else self.mx_channel(v, where, name)
        idx = self.mx_texture(tex, where, name) if tex is not None else None
        fb = tex.desc.get("fallback", [0.0, 0.0, 0.0, 1.0]) if tex is not None else [0.0, 0.0, 0.0, 1.0]
        val = list(default) if kind == "color" else default
        if idx is None:
            return {"value": val, "texture": None}
        return {"value": [float(x) for x in fb[:3]] if kind == "color" else float(fb[0]), "texture": idx}

    def mx_common(self, m, where, s):
        """Fields shared by the surfaces: `s` holds the mapped inputs by meaning."""
        m["diffuse_color"] = self.mx_field(s["diffuse"], (0.18, 0.18, 0.18), "color", where, "base colour")
        m["metallic"] = self.mx_field(s["metallic"], 0.0, "float", where, "metalness")
        m["roughness"] = self.mx_field(s["roughness"], 0.5, "float", where, "specular roughness")
        m["specular_tint"] = self.mx_field(s["specular_tint"], (1.0, 1.0, 1.0), "color", where, "specular colour")
        m["clearcoat"] = self.mx_field(s["coat"], 0.0, "float", where, "coat")
        m["clearcoat_roughness"] = self.mx_field(s["coat_roughness"], 0.01, "float", where, "coat roughness")
        m["emissive_color"] = self.mx_field(s["emission"], (0.0, 0.0, 0.0), "color", where, "emission")
        ior = s["ior"]
        m["ior"] = self.mx_scalar(ior, 1.5) if not isinstance(ior, MxTex) else 1.5
        if isinstance(ior, MxTex):
            self.warn(where, "a textured IOR cannot be represented; 1.5 is used")
        # transmission: the dielectric under the opaque layers, tinted
        t = s["transmission"]
        if isinstance(t, MxTex):
            self.warn(where, "a textured transmission weight cannot be represented; its default is used")
            t = None
        tw = min(max(self.mx_scalar(t, 0.0), 0.0), 1.0)
        opacity = s["opacity"]
        if tw > 0.0:
            m["opacity"] = {"value": 1.0 - tw, "texture": None}
            tc = s["transmission_color"]
            if isinstance(tc, MxConst):
                m["transmission_color"] = broadcast(tc.v, 3)
            elif tc is not None:
                self.warn(where, "a textured transmission colour cannot be represented; white is used")
            if self.mx_scalar(s["roughness"], 0.0) > 0.1:
                self.warn(where, "rough transmission is rendered as smooth refraction (specular roughness %.3g)"
                          % self.mx_scalar(s["roughness"], 0.0))
        # geometric opacity (coverage): a cut-out
        if isinstance(opacity, MxTex):
            m["opacity"] = self.mx_field(opacity, 1.0, "float", where, "opacity")
            m["opacity_threshold"] = 0.5
            self.warn(where, "a textured opacity (coverage) is rendered as a cut-out at 0.5")
        elif isinstance(opacity, MxConst) and min(opacity.v) < 1.0:
            o = sum(opacity.v) / len(opacity.v)
            m["opacity"] = {"value": o, "texture": None}
            m["opacity_threshold"] = 0.5
            self.warn(where, "partial opacity %.3g (coverage) is rendered as a cut-out at 0.5: %s" %
                      (o, "visible" if o >= 0.5 else "a hole"))
        n = s["normal"]
        m["normal_map"] = None
        if isinstance(n, MxNormal):
            m["normal_map"] = self.mx_texture(n.tex, where, "normal")
        elif n is not None and not isinstance(n, MxConst):
            self.warn(where, "the normal is not a normalmap node's; ignored")
        return m

    def mx_nonzero(self, graph, node, where, names, what):
        """Warn that inputs with a non-default value (a weight, a flag) are dropped."""
        for name in names:
            r = graph.input(node, name)
            nd = graph.nodedef(node)
            d = nd.getActiveInput(name) if nd is not None else None
            if r[0] == "node" or (r[0] == "value" and d is not None and mx_list(r[1]) != mx_list(d.getValue())
                                  and mx_list(r[1]) not in ([0.0], 0, False)):
                self.warn(where, "%s (%s) is not supported; ignored" % (name, what))

    def mx_standard_surface(self, graph, node, mpath, where):
        g = lambda n, k: self.mx_in(graph, node, n, k)  # noqa: E731
        base = self.mx_weighted(g("base", 1), g("base_color", 3), where, "base colour")
        sss = g("subsurface", 1)
        if sss is not None and (not isinstance(sss, MxConst) or sss.v[0] > 0.0):
            w = self.mx_scalar(sss, 1.0)
            self.warn(where, "subsurface scattering is rendered as diffuse reflection of subsurface_color "
                      "(weight %.3g)" % w)
            base = self.mx_mix(base, g("subsurface_color", 3), w, where)
        coat = g("coat", 1)
        coat_color = g("coat_color", 3)
        base = self.mx_coat_tint(base, coat, coat_color, where)
        self.mx_coat_ior(coat, g("coat_IOR", 1), g("specular_IOR", 1), where)
        s = {
            "diffuse": base, "metallic": g("metalness", 1), "roughness": g("specular_roughness", 1),
            "specular_tint": self.mx_weighted(g("specular", 1), g("specular_color", 3), where, "specular colour"),
            "coat": coat, "coat_roughness": g("coat_roughness", 1),
            "emission": self.mx_weighted(g("emission", 1), g("emission_color", 3), where, "emission"),
            "ior": g("specular_IOR", 1), "transmission": g("transmission", 1),
            "transmission_color": g("transmission_color", 3), "opacity": g("opacity", 3), "normal": g("normal", 3),
        }
        self.mx_nonzero(graph, node, where, ("sheen", "thin_film_thickness", "specular_anisotropy", "diffuse_roughness",
                                             "transmission_depth", "transmission_dispersion", "thin_walled",
                                             "transmission_extra_roughness"), "standard_surface")
        return self.mx_common({"kind": "preview_surface", "name": mpath}, where, s)

    def mx_open_pbr(self, graph, node, mpath, where):
        g = lambda n, k: self.mx_in(graph, node, n, k)  # noqa: E731
        base = self.mx_weighted(g("base_weight", 1), g("base_color", 3), where, "base colour")
        sss = g("subsurface_weight", 1)
        if sss is not None and (not isinstance(sss, MxConst) or sss.v[0] > 0.0):
            w = self.mx_scalar(sss, 1.0)
            self.warn(where, "subsurface scattering is rendered as diffuse reflection of subsurface_color "
                      "(weight %.3g)" % w)
            base = self.mx_mix(base, g("subsurface_color", 3), w, where)
        coat = g("coat_weight", 1)
        base = self.mx_coat_tint(base, coat, g("coat_color", 3), where)
        self.mx_coat_ior(coat, g("coat_ior", 1), g("specular_ior", 1), where)
        s = {
            "diffuse": base, "metallic": g("base_metalness", 1), "roughness": g("specular_roughness", 1),
            "specular_tint": self.mx_weighted(g("specular_weight", 1), g("specular_color", 3), where, "specular colour"),
            "coat": coat, "coat_roughness": g("coat_roughness", 1),
            "emission": self.mx_weighted(g("emission_luminance", 1), g("emission_color", 3), where, "emission"),
            "ior": g("specular_ior", 1), "transmission": g("transmission_weight", 1),
            "transmission_color": g("transmission_color", 3), "opacity": g("geometry_opacity", 1),
            "normal": g("geometry_normal", 3),
        }
        self.mx_nonzero(graph, node, where, ("fuzz_weight", "thin_film_weight", "specular_roughness_anisotropy",
                                             "base_diffuse_roughness", "transmission_depth",
                                             "transmission_dispersion_scale", "geometry_thin_walled"),
                        "open_pbr_surface")
        return self.mx_common({"kind": "preview_surface", "name": mpath}, where, s)

    def mx_preview(self, graph, node, mpath, where):
        g = lambda n, k: self.mx_in(graph, node, n, k)  # noqa: E731
        spec_wf = self.mx_scalar(g("useSpecularWorkflow", 1), 0.0) != 0.0
        s = {
            "diffuse": g("diffuseColor", 3), "metallic": g("metallic", 1), "roughness": g("roughness", 1),
            "specular_tint": None, "coat": g("clearcoat", 1), "coat_roughness": g("clearcoatRoughness", 1),
            "emission": g("emissiveColor", 3), "ior": g("ior", 1), "transmission": None, "transmission_color": None,
            "opacity": None, "normal": g("normal", 3),
        }
        m = self.mx_common({"kind": "preview_surface", "name": mpath}, where, s)
        op = g("opacity", 1)
        m["opacity"] = self.mx_field(op, 1.0, "float", where, "opacity")
        m["opacity_threshold"] = self.mx_scalar(g("opacityThreshold", 1), 0.0)
        if spec_wf:
            m["use_specular_workflow"] = True
            m["specular_color"] = self.mx_field(g("specularColor", 3), (0.0, 0.0, 0.0), "color", where, "specularColor")
        del m["specular_tint"]
        return m

    def mx_mix(self, a, b, w, where):
        """`a · (1 − w) + b · w` for a constant `w`, where one side at most is a texture."""
        if w >= 1.0 or a is None:
            return b
        if w <= 0.0 or b is None:
            return a
        if isinstance(a, MxConst) and isinstance(b, MxConst):
            return MxConst([x * (1.0 - w) + y * w for x, y in zip(broadcast(a.v, 3), broadcast(b.v, 3))])
        if isinstance(a, MxTex) and isinstance(b, MxConst):
            return self.mx_affine(a, [1.0 - w] * 3, [y * w for y in broadcast(b.v, 3)], where)
        if isinstance(b, MxTex) and isinstance(a, MxConst):
            return self.mx_affine(b, [w] * 3, [x * (1.0 - w) for x in broadcast(a.v, 3)], where)
        self.warn(where, "a blend of two textures cannot be represented; the first is used")
        return a

    def mx_coat_tint(self, base, coat, coat_color, where):
        """A coloured coat filters the base: its colour, at the coat's weight, multiplies it."""
        if not isinstance(coat_color, MxConst) or not isinstance(coat, MxConst) or coat.v[0] <= 0.0:
            if coat_color is not None and not isinstance(coat_color, MxConst):
                self.warn(where, "a textured coat colour cannot be represented; ignored")
            return base
        k = [1.0 - coat.v[0] + coat.v[0] * c for c in broadcast(coat_color.v, 3)]
        if all(abs(x - 1.0) < 1e-7 for x in k):
            return base
        if isinstance(base, MxConst):
            return MxConst([a * b for a, b in zip(broadcast(base.v, 3), k)])
        if isinstance(base, MxTex):
            return self.mx_affine(base, k, [0.0] * 3, where)
        return base

    def mx_coat_ior(self, coat, coat_ior, spec_ior, where):
        if isinstance(coat, MxConst) and coat.v[0] <= 0.0:
            return
        a, b = self.mx_scalar(coat_ior, 1.5), self.mx_scalar(spec_ior, 1.5)
        if abs(a - b) > 1e-3:
            self.warn(where, "the coat's IOR %.3g is rendered as the specular IOR %.3g (one IOR drives both)" % (a, b))

    # ---- values through nodes ------------------------------------------------------------------
    def mx_eval(self, graph, node, output, depth):
        """The value of `node`'s `output` (MxConst / MxTex / MxUV / MxVertex / MxNormal), or None
        (a node the mapping cannot carry; warned)."""
        if depth > 32:
            return None
        nd = graph.nodedef(node)
        where = graph.where(node)
        if nd is None:
            self.warn(where, "no MaterialX node definition; the input it drives uses its default")
            return None
        cat = nd.getNodeString()
        outs = nd.getActiveOutputs()
        otype = outs[0].getType() if outs else ""
        for o in outs:
            if o.getName() == output:
                otype = o.getType()
        size = MX_SIZES.get(otype, 1)

        def inp(name, n=None):
            r = graph.input(node, name)
            if r[0] in ("value", "default"):
                v = mx_list(r[1])
                if isinstance(v, list) and n:
                    v = broadcast(v, n)
                return MxConst(v) if isinstance(v, list) else v
            if r[0] == "node":
                return self.mx_eval(graph, r[1], r[2], depth + 1)
            return None

        if cat == "constant":
            return inp("value", size)
        if cat in ("dot", "convert"):
            v = inp("in")
            if isinstance(v, MxConst):
                return MxConst(broadcast(v.v, size) if len(v.v) == 1 else (v.v + [1.0])[:size])
            if isinstance(v, MxTex):
                return self.mx_broadcast(v, size)
            return v
        if cat in ("image", "tiledimage"):
            return self.mx_image(graph, node, cat, size, inp, where)
        if cat == "texcoord":
            index = inp("index")
            if isinstance(index, MxConst) and index.v[0] != 0:
                self.warn(where, "texcoord index %d: the mesh's texture coordinates are used" % index.v[0])
            return MxUV("st", IDENTITY_2D)
        if cat == "geompropvalue":
            name = inp("geomprop")
            if otype == "vector2":
                return MxUV(str(name) if isinstance(name, str) and name else "st", IDENTITY_2D)
            if otype == "color3" and isinstance(name, str) and name:
                return MxVertex(name)
            self.warn(where, "geompropvalue of type %s is not supported" % otype)
            return None
        if cat == "place2d":
            return self.mx_place2d(inp, where)
        if cat == "extract":
            v, index = inp("in"), inp("index")
            i = int(index.v[0]) if isinstance(index, MxConst) else 0
            if isinstance(v, MxConst):
                return MxConst([v.v[min(i, len(v.v) - 1)]])
            if isinstance(v, MxTex) and i < len(v.channels):
                t = v.copy()
                t.channels = [v.channels[i]]
                return t
            return None
        if cat == "swizzle":
            v, chans = inp("in"), inp("channels")
            if isinstance(chans, str) and isinstance(v, (MxConst, MxTex)):
                idx = ["rgbaxyzw".index(c) % 4 for c in chans if c in "rgbaxyzw"]
                if isinstance(v, MxConst):
                    return MxConst([v.v[min(i, len(v.v) - 1)] for i in idx])
                if all(i < len(v.channels) for i in idx):
                    t = v.copy()
                    t.channels = [v.channels[i] for i in idx]
                    return t
            return None
        if cat in ("multiply", "add", "subtract", "divide"):
            return self.mx_arith(cat, inp("in1"), inp("in2"), size, where)
        if cat == "mix":
            fg, bg, mix = inp("fg", size), inp("bg", size), inp("mix")
            if isinstance(mix, MxConst):
                return self.mx_mix(bg, fg, mix.v[0], where) if size == 3 else self.mx_mix1(bg, fg, mix.v[0], where)
            self.warn(where, "mix by a texture cannot be represented; the input it drives uses its default")
            return None
        if cat == "normalmap":
            v, sc = inp("in"), inp("scale")
            s = sc.v[0] if isinstance(sc, MxConst) else 1.0
            if isinstance(v, MxTex):
                t = self.mx_broadcast(v, 3)
                if t is None:
                    return None
                t = self.mx_affine(t, [2.0 * s, 2.0 * s, 2.0], [-s, -s, -1.0], where)
                return MxNormal(t) if t is not None else None
            return None
        self.warn(where, "MaterialX node %s is not supported; the input it drives uses its default" % cat)
        return None

    def mx_mix1(self, a, b, w, where):
        if isinstance(a, MxConst) and isinstance(b, MxConst):
            return MxConst([x * (1.0 - w) + y * w for x, y in zip(a.v, b.v)])
        return self.mx_mix(a, b, w, where) if w not in (0.0, 1.0) else (b if w >= 1.0 else a)

    def mx_place2d(self, inp, where):
        tc = inp("texcoord")
        if tc is None:
            tc = MxUV("st", IDENTITY_2D)
        if not isinstance(tc, MxUV):
            return None
        c = lambda n, d: inp(n).v if isinstance(inp(n), MxConst) else d  # noqa: E731
        pivot, scale, offset = c("pivot", [0.0, 0.0]), c("scale", [1.0, 1.0]), c("offset", [0.0, 0.0])
        rot = c("rotate", [0.0])[0]
        order = c("operationorder", [0.0])[0]
        if scale[0] == 0.0 or scale[1] == 0.0:
            self.warn(where, "place2d scale 0; ignored")
            return tc
        ca, sa = math.cos(math.radians(rot)), math.sin(math.radians(rot))
        rotate = [[ca, sa, 0.0], [-sa, ca, 0.0]]  # MaterialX's rotate2d turns clockwise
        move = lambda dx, dy: [[1.0, 0.0, dx], [0.0, 1.0, dy]]  # noqa: E731
        div = [[1.0 / scale[0], 0.0, 0.0], [0.0, 1.0 / scale[1], 0.0]]
        steps = ([move(-pivot[0], -pivot[1]), div, rotate, move(-offset[0], -offset[1]), move(pivot[0], pivot[1])]
                 if order == 0 else
                 [move(-pivot[0], -pivot[1]), move(-offset[0], -offset[1]), rotate, div, move(pivot[0], pivot[1])])
        m = tc.m
        for s in steps:
            m = compose_2d(s, m)
        return MxUV(tc.name, m)

    def mx_image(self, graph, node, cat, size, inp, where):
        path, cs, authored = graph.file(node)
        default = inp("default", 4)
        fb = (default.v + [1.0] * 4)[:4] if isinstance(default, MxConst) else [0.0, 0.0, 0.0, 1.0]
        if size < 4 and isinstance(default, MxConst) and len(default.v) == 1:
            fb = [default.v[0]] * 3 + [1.0]
        if not path:
            return MxConst(fb[:size])
        tc = inp("texcoord")
        if tc is None:
            tc = MxUV("st", IDENTITY_2D)
        if not isinstance(tc, MxUV):
            self.warn(where, "texcoord is not a texture coordinate node; the mesh's texture coordinates are used")
            tc = MxUV("st", IDENTITY_2D)
        m = tc.m
        wraps = []
        if cat == "tiledimage":
            c = lambda n, d: inp(n).v if isinstance(inp(n), MxConst) else d  # noqa: E731
            tiling, offset = c("uvtiling", [1.0, 1.0]), c("uvoffset", [0.0, 0.0])
            img, tile = c("realworldimagesize", [1.0, 1.0]), c("realworldtilesize", [1.0, 1.0])
            kx, ky = tiling[0] * tile[0] / img[0], tiling[1] * tile[1] / img[1]
            m = compose_2d([[kx, 0.0, -offset[0] * tile[0] / img[0]], [0.0, ky, -offset[1] * tile[1] / img[1]]], m)
            wraps = ["repeat", "repeat"]
        else:
            for name in ("uaddressmode", "vaddressmode"):
                a = inp(name)
                a = a if isinstance(a, str) and a else "periodic"
                w = MX_ADDRESS.get(a)
                if w is None:
                    self.warn(where, "unknown %s %r; periodic is used" % (name, a))
                    w = "repeat"
                if a == "constant" and any(x != 0.0 for x in fb):
                    self.warn(where, "%s constant with a non-black default: black is used outside the image" % name)
                wraps.append(w)
        color_space = "auto"
        if cs:
            color_space = MX_COLOR_SPACES.get(cs.lower())
            if color_space is None:
                self.warn(where, "colour space %r of %s is not converted; read as linear" % (cs, authored))
                color_space = "raw"
        desc = {"path": path, "wrap_s": wraps[0], "wrap_t": wraps[1], "color_space": color_space,
                "fallback": fb, "prim": where}
        if m != IDENTITY_2D:
            desc["st_transform"] = m
        return MxTex(desc, [1.0] * 4, [0.0] * 4, list(range(min(size, 4))) if size > 1 else [0], tc.name)

    def mx_broadcast(self, t, size):
        """A texture value as `size` components (a scalar repeated; a colour cut to 3)."""
        if len(t.channels) == size:
            return t
        if len(t.channels) == 1:
            r = t.copy()
            r.channels = t.channels * size
            return r
        if len(t.channels) > size:
            r = t.copy()
            r.channels = t.channels[:size]
            return r
        return None

    def mx_affine(self, t, k, c, where):
        """`t · k + c` per component, folded into the texture's scale and bias (None when the
        components of one channel would need different factors)."""
        t = t.copy()
        done = {}
        for i, ch in enumerate(t.channels):
            ki, ci = k[min(i, len(k) - 1)], c[min(i, len(c) - 1)]
            if ch in done:
                if done[ch] != (ki, ci):
                    self.warn(where, "different factors on one texture channel cannot be represented")
                    return None
                continue
            done[ch] = (ki, ci)
            t.scale[ch] *= ki
            t.bias[ch] = t.bias[ch] * ki + ci
        return t

    def mx_arith(self, cat, a, b, size, where):
        if isinstance(a, MxConst) and isinstance(b, MxConst):
            x, y = broadcast(a.v, size), broadcast(b.v, size)
            f = {"multiply": lambda p, q: p * q, "add": lambda p, q: p + q, "subtract": lambda p, q: p - q,
                 "divide": lambda p, q: p / q if q != 0.0 else 0.0}[cat]
            return MxConst([f(p, q) for p, q in zip(x, y)])
        if isinstance(a, MxUV) and isinstance(b, MxConst) and cat in ("multiply", "add", "subtract", "divide"):
            k = broadcast(b.v, 2)
            if cat == "multiply":
                step = [[k[0], 0.0, 0.0], [0.0, k[1], 0.0]]
            elif cat == "divide" and k[0] != 0.0 and k[1] != 0.0:
                step = [[1.0 / k[0], 0.0, 0.0], [0.0, 1.0 / k[1], 0.0]]
            elif cat == "add":
                step = [[1.0, 0.0, k[0]], [0.0, 1.0, k[1]]]
            elif cat == "subtract":
                step = [[1.0, 0.0, -k[0]], [0.0, 1.0, -k[1]]]
            else:
                return None
            return MxUV(a.name, compose_2d(step, a.m))
        if isinstance(a, MxTex) and isinstance(b, MxConst):
            t = self.mx_broadcast(a, size)
            k = broadcast(b.v, size)
            if t is None:
                return None
            if cat == "multiply":
                return self.mx_affine(t, k, [0.0] * size, where)
            if cat == "divide" and all(x != 0.0 for x in k):
                return self.mx_affine(t, [1.0 / x for x in k], [0.0] * size, where)
            if cat in ("add", "subtract"):
                return self.mx_affine(t, [1.0] * size, k if cat == "add" else [-x for x in k], where)
        if isinstance(b, MxTex) and isinstance(a, MxConst):
            t = self.mx_broadcast(b, size)
            k = broadcast(a.v, size)
            if t is None:
                return None
            if cat == "multiply":
                return self.mx_affine(t, k, [0.0] * size, where)
            if cat in ("add", "subtract"):
                return self.mx_affine(t, [1.0 if cat == "add" else -1.0] * size, k, where)
        self.warn(where, "%s of these inputs cannot be represented; the input it drives uses its default" % cat)
        return None

    def mx_channel(self, t, where, name):
        """A texture value as one channel (a scalar field)."""
        if len(t.channels) == 1:
            return t
        self.warn(where, "%s reads a colour texture; its first channel is used" % name)
        r = t.copy()
        r.channels = t.channels[:1]
        return r

    def mx_texture(self, t, where, name):
        """Register a texture value (its channels selecting the output) and note its st primvar."""
        ch = t.channels
        if ch == [0, 1, 2]:
            output = "rgb"
        elif len(set(ch)) == 1 and len(ch) in (1, 3):
            output = "rgba"[ch[0]]
        else:
            self.warn(where, "%s: channels %s of a texture cannot be selected; rgb is used" % (name, ch))
            output = "rgb"
        desc = dict(t.desc)
        prim = desc.pop("prim", where)
        desc.update({"scale": t.scale, "bias": t.bias, "output": output})
        if t.uv:
            self._mx_uv.add(t.uv)
        return self.register_texture(desc, prim)
