"""raysplat_usd_mtlx.py: MaterialX looks, read with the `MaterialX` package (PyPI, installed by
`make setup`): `.mtlx` documents that USD references (`@X.mtlx@</MaterialX/Materials>`, which the
PyPI usd-core cannot compose: it has no usdMtlx plugin) and `outputs:mtlx:surface` networks of
UsdShade shaders whose `info:id` names a MaterialX node definition. `standard_surface`,
`open_pbr_surface` and `UsdPreviewSurface` shaders map onto the renderer's UsdPreviewSurface
material (`docs/looks.md`); the values of their inputs come from `raysplat_usd_mtlx_nodes.py`. A part
of the converter (`raysplat_usd.py`)."""

import os
import sys

if "UserError" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_usd_common import *  # noqa: F401,F403
    from raysplat_usd_mtlx_nodes import *  # noqa: F401,F403


class MtlxRef:
    """A material in a MaterialX document: `path` is the bound USD path it stands for."""

    def __init__(self, file, name, path):
        self.file, self.name, self.path = file, name, path


class MtlxReader(MtlxNodes):
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
