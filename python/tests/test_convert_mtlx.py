"""Tests of the USD -> .rss converter: MaterialX looks (`raysplat_usd_mtlx.py`): `.mtlx` documents
referenced from USD (which usd-core cannot compose) and `outputs:mtlx:surface` networks of
UsdShade shaders, `standard_surface` and `open_pbr_surface` mapped onto the renderer's material,
image nodes with their colour spaces, UV transforms and normal maps. The documents are our own,
written here. Needs the MaterialX package (`make setup` installs it)."""

from convert_support import *  # noqa: F401,F403

LOOKS_MTLX = """<?xml version="1.0"?>
<materialx version="1.39" colorspace="lin_rec709">
  <standard_surface name="painted_ss" type="surfaceshader">
    <input name="base" type="float" value="0.8" />
    <input name="base_color" type="color3" value="0.9, 0.1, 0.1" />
    <input name="metalness" type="float" value="0.25" />
    <input name="specular" type="float" value="0.5" />
    <input name="specular_color" type="color3" value="1, 0.5, 0.5" />
    <input name="specular_roughness" type="float" value="0.3" />
    <input name="specular_IOR" type="float" value="1.6" />
    <input name="coat" type="float" value="0.5" />
    <input name="coat_roughness" type="float" value="0.2" />
    <input name="coat_IOR" type="float" value="1.6" />
    <input name="emission" type="float" value="2" />
    <input name="emission_color" type="color3" value="0.1, 0.2, 0.3" />
  </standard_surface>
  <surfacematerial name="painted" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="painted_ss" />
  </surfacematerial>

  <standard_surface name="glass_ss" type="surfaceshader">
    <input name="base" type="float" value="0" />
    <input name="specular_roughness" type="float" value="0.02" />
    <input name="specular_IOR" type="float" value="1.45" />
    <input name="transmission" type="float" value="1" />
    <input name="transmission_color" type="color3" value="0.9, 1, 0.8" />
  </standard_surface>
  <surfacematerial name="glass" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="glass_ss" />
  </surfacematerial>

  <standard_surface name="skin_ss" type="surfaceshader">
    <input name="base_color" type="color3" value="0.5, 0.5, 0.5" />
    <input name="subsurface" type="float" value="1" />
    <input name="subsurface_color" type="color3" value="1, 0.5, 0.4" />
  </standard_surface>
  <surfacematerial name="skin" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="skin_ss" />
  </surfacematerial>

  <nodegraph name="textured_ng">
    <texcoord name="uv" type="vector2" />
    <place2d name="tiling" type="vector2">
      <input name="texcoord" type="vector2" nodename="uv" />
      <input name="scale" type="vector2" value="0.5, 0.25" />
      <input name="offset" type="vector2" value="0.1, 0.2" />
    </place2d>
    <image name="albedo" type="color3">
      <input name="file" type="filename" value="albedo.png" colorspace="srgb_texture" />
      <input name="texcoord" type="vector2" nodename="tiling" />
      <input name="uaddressmode" type="string" value="clamp" />
      <input name="vaddressmode" type="string" value="mirror" />
    </image>
    <image name="rough" type="vector3">
      <input name="file" type="filename" value="rough.png" />
      <input name="texcoord" type="vector2" nodename="tiling" />
    </image>
    <extract name="rough_g" type="float">
      <input name="in" type="vector3" nodename="rough" />
      <input name="index" type="integer" value="1" />
    </extract>
    <image name="nmap" type="vector3">
      <input name="file" type="filename" value="normal.png" />
    </image>
    <normalmap name="bump" type="vector3">
      <input name="in" type="vector3" nodename="nmap" />
      <input name="scale" type="float" value="0.5" />
    </normalmap>
    <output name="base_color_out" type="color3" nodename="albedo" />
    <output name="rough_out" type="float" nodename="rough_g" />
    <output name="normal_out" type="vector3" nodename="bump" />
  </nodegraph>
  <standard_surface name="textured_ss" type="surfaceshader">
    <input name="base_color" type="color3" nodegraph="textured_ng" output="base_color_out" />
    <input name="specular_roughness" type="float" nodegraph="textured_ng" output="rough_out" />
    <input name="normal" type="vector3" nodegraph="textured_ng" output="normal_out" />
  </standard_surface>
  <surfacematerial name="textured" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="textured_ss" />
  </surfacematerial>
</materialx>
"""

OPENPBR_MTLX = """<?xml version="1.0"?>
<materialx version="1.39">
  <open_pbr_surface name="metal_pbr" type="surfaceshader">
    <input name="base_weight" type="float" value="1" />
    <input name="base_color" type="color3" value="0.2, 0.4, 0.6" />
    <input name="base_metalness" type="float" value="1" />
    <input name="specular_weight" type="float" value="0.8" />
    <input name="specular_roughness" type="float" value="0.25" />
    <input name="specular_ior" type="float" value="1.7" />
    <input name="coat_weight" type="float" value="0.3" />
    <input name="coat_roughness" type="float" value="0.1" />
    <input name="coat_ior" type="float" value="1.7" />
    <input name="emission_luminance" type="float" value="5" />
    <input name="emission_color" type="color3" value="1, 0.5, 0.25" />
  </open_pbr_surface>
  <surfacematerial name="metal" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="metal_pbr" />
  </surfacematerial>
  <open_pbr_surface name="glass_pbr" type="surfaceshader">
    <input name="base_weight" type="float" value="0" />
    <input name="specular_roughness" type="float" value="0.01" />
    <input name="specular_ior" type="float" value="1.5" />
    <input name="transmission_weight" type="float" value="1" />
    <input name="transmission_color" type="color3" value="0.95, 1, 0.98" />
  </open_pbr_surface>
  <surfacematerial name="glass" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="glass_pbr" />
  </surfacematerial>
  <open_pbr_surface name="wax_pbr" type="surfaceshader">
    <input name="base_color" type="color3" value="0.7, 0.7, 0.2" />
    <input name="subsurface_weight" type="float" value="0.5" />
    <input name="subsurface_color" type="color3" value="0.9, 0.3, 0.1" />
  </open_pbr_surface>
  <surfacematerial name="wax" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="wax_pbr" />
  </surfacematerial>
</materialx>
"""


def near(test, a, b, tol=1e-5):
    test.assertEqual(len(a), len(b), "%s vs %s" % (a, b))
    for x, y in zip(a, b):
        test.assertAlmostEqual(x, y, delta=tol, msg="%s vs %s" % (a, b))


class MaterialXTests(Case):
    def setUp(self):
        super().setUp()
        try:
            import MaterialX  # noqa: F401
        except ImportError:
            self.fail("the MaterialX package is missing from this Python (make setup installs it)")

    def referenced(self, documents, bindings):
        """A stage whose /Looks scope references `documents` (name -> XML) as usdMtlx would, and
        one quad per (mesh, material name) in `bindings`, bound to /Looks/<material>."""
        st = self.stage()
        for name, xml in documents.items():
            (self.dir / name).write_text(xml)
        looks = st.DefinePrim("/Looks", "Scope")
        for name in documents:
            looks.GetReferences().AddReference("./" + name, "/MaterialX/Materials")
        for i, (mesh, material) in enumerate(bindings):
            q = quad(st, mesh, z=float(i))
            UsdGeom.PrimvarsAPI(q).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
                Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
            UsdShade.MaterialBindingAPI.Apply(q.GetPrim()).GetDirectBindingRel().SetTargets([Sdf.Path("/Looks/" + material)])
        return st

    def test_standard_surface_documents_map_to_the_material(self):
        (self.dir / "albedo.png").write_bytes(png_bytes(rgb=(200, 100, 50)))
        (self.dir / "rough.png").write_bytes(png_bytes())
        (self.dir / "normal.png").write_bytes(png_bytes(rgb=(128, 128, 255)))
        st = self.referenced({"looks.mtlx": LOOKS_MTLX},
                             [("/Painted", "painted"), ("/Glass", "glass"), ("/Skin", "skin"), ("/Textured", "textured")])
        rss = self.convert(st)
        p = rss.material("/Looks/painted")
        self.assertEqual(p["kind"], "preview_surface")
        near(self, p["diffuse_color"]["value"], [0.72, 0.08, 0.08])
        near(self, [p["metallic"]["value"], p["roughness"]["value"], p["ior"]], [0.25, 0.3, 1.6])
        near(self, p["specular_tint"]["value"], [0.5, 0.25, 0.25])
        near(self, [p["clearcoat"]["value"], p["clearcoat_roughness"]["value"]], [0.5, 0.2])
        near(self, p["emissive_color"]["value"], [0.2, 0.4, 0.6])
        self.assertFalse(p.get("use_specular_workflow", False))
        g = rss.material("/Looks/glass")
        near(self, [g["opacity"]["value"], g["ior"]], [0.0, 1.45])
        near(self, g["transmission_color"], [0.9, 1.0, 0.8])
        near(self, g["diffuse_color"]["value"], [0.0, 0.0, 0.0])
        s = rss.material("/Looks/skin")
        near(self, s["diffuse_color"]["value"], [1.0, 0.5, 0.4])
        self.assertTrue(any("subsurface scattering is rendered as diffuse" in w["message"] for w in rss["warnings"]),
                        rss["warnings"])
        t = rss.material("/Looks/textured")
        albedo = rss["textures"][t["diffuse_color"]["texture"]]
        self.assertEqual(albedo["path"], str((self.dir / "albedo.png").resolve()))
        self.assertEqual((albedo["color_space"], albedo["output"], albedo["wrap_s"], albedo["wrap_t"]),
                         ("sRGB", "rgb", "clamp", "mirror"))
        # place2d: ((uv - pivot) / scale, rotated, - offset): u' = 2u - 0.1, v' = 4v - 0.2
        near(self, albedo["st_transform"][0], [2.0, 0.0, -0.1])
        near(self, albedo["st_transform"][1], [0.0, 4.0, -0.2])
        rough = rss["textures"][t["roughness"]["texture"]]
        self.assertEqual((rough["output"], rough["color_space"]), ("g", "raw"))
        normal = rss["textures"][t["normal_map"]]
        # normalmap: (2 texel - 1) with x and y scaled by 0.5
        near(self, normal["scale"], [1.0, 1.0, 2.0, 1.0])
        near(self, normal["bias"], [-0.5, -0.5, -1.0, 0.0])
        self.assertNotIn("st_transform", normal)
        self.assertIsNotNone(rss.mesh_named("/Textured")["uvs"])
        deps = [d["path"] for d in rss["dependencies"]]
        self.assertIn(str((self.dir / "looks.mtlx").resolve()), deps)
        self.assertIn(albedo["path"], deps)
        # the references usd-core cannot compose are named, with what the converter does instead
        self.assertTrue(any("USD cannot compose MaterialX documents" in w["message"] for w in rss["warnings"]))

    def test_open_pbr_documents_map_to_the_material(self):
        st = self.referenced({"openpbr.mtlx": OPENPBR_MTLX, "looks.mtlx": LOOKS_MTLX},
                             [("/Metal", "metal"), ("/Glass", "glass"), ("/Wax", "wax"), ("/Painted", "painted")])
        rss = self.convert(st)
        m = rss.material("/Looks/metal")
        near(self, m["diffuse_color"]["value"], [0.2, 0.4, 0.6])
        near(self, [m["metallic"]["value"], m["roughness"]["value"], m["ior"]], [1.0, 0.25, 1.7])
        near(self, m["specular_tint"]["value"], [0.8, 0.8, 0.8])
        near(self, [m["clearcoat"]["value"], m["clearcoat_roughness"]["value"]], [0.3, 0.1])
        near(self, m["emissive_color"]["value"], [5.0, 2.5, 1.25])
        g = rss.material("/Looks/glass")
        near(self, [g["opacity"]["value"], g["ior"]], [0.0, 1.5])
        near(self, g["transmission_color"], [0.95, 1.0, 0.98])
        w = rss.material("/Looks/wax")
        near(self, w["diffuse_color"]["value"], [0.8, 0.5, 0.15])  # halfway to the subsurface colour
        # two documents on one scope: each material from the one that has it
        near(self, rss.material("/Looks/painted")["diffuse_color"]["value"], [0.72, 0.08, 0.08])

    def test_missing_document_material_is_an_error_material(self):
        st = self.referenced({"openpbr.mtlx": OPENPBR_MTLX}, [("/A", "nosuch")])
        rss = self.convert(st)
        self.assertEqual(rss.material("/Looks/nosuch")["kind"], "error")
        self.assertTrue(rss.warnings_for("/Looks/nosuch"))

    def usd_network(self, st, path, node_id, inputs, preview_color=None):
        """A Material with an outputs:mtlx:surface network (`node_id` with constant `inputs`), and a
        UsdPreviewSurface on outputs:surface when `preview_color` is given."""
        mat = UsdShade.Material.Define(st, path)
        sh = UsdShade.Shader.Define(st, path + "/Mtlx")
        sh.CreateIdAttr(node_id)
        for k, (ty, v) in inputs.items():
            sh.CreateInput(k, ty).Set(v)
        mat.CreateSurfaceOutput("mtlx").ConnectToSource(sh.ConnectableAPI(), "out")
        if preview_color is not None:
            pv = UsdShade.Shader.Define(st, path + "/Preview")
            pv.CreateIdAttr("UsdPreviewSurface")
            pv.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*preview_color))
            mat.CreateSurfaceOutput().ConnectToSource(pv.ConnectableAPI(), "surface")
        return mat

    def test_usd_mtlx_networks_win_over_the_preview_surface(self):
        st = self.stage()
        C, F = Sdf.ValueTypeNames.Color3f, Sdf.ValueTypeNames.Float
        ss = self.usd_network(st, "/Looks/SS", "ND_standard_surface_surfaceshader",
                              {"base_color": (C, Gf.Vec3f(0.1, 0.2, 0.9)), "specular_roughness": (F, 0.4),
                               "metalness": (F, 0.5)}, preview_color=(0.0, 1.0, 0.0))
        pbr = self.usd_network(st, "/Looks/PBR", "ND_open_pbr_surface_surfaceshader",
                               {"base_color": (C, Gf.Vec3f(0.3, 0.6, 0.1)), "specular_weight": (F, 0.0),
                                "transmission_weight": (F, 0.25)})
        bind(quad(st, "/A"), ss)
        bind(quad(st, "/B", z=1), pbr)
        rss = self.convert(st)
        a = rss.material("/Looks/SS")
        near(self, a["diffuse_color"]["value"], [0.1, 0.2, 0.9])
        near(self, [a["roughness"]["value"], a["metallic"]["value"]], [0.4, 0.5])
        b = rss.material("/Looks/PBR")
        near(self, b["diffuse_color"]["value"], [0.3, 0.6, 0.1])
        near(self, b["specular_tint"]["value"], [0.0, 0.0, 0.0])
        near(self, [b["roughness"]["value"], b["opacity"]["value"]], [0.3, 0.75])  # the node's default roughness
        self.assertFalse([w for w in rss["warnings"] if "is not supported; using the material's UsdPreviewSurface"
                          in w["message"]])

    def test_usd_mtlx_image_network(self):
        st = self.stage()
        m = quad(st, "/M")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("uvmap", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
        (self.dir / "albedo.png").write_bytes(png_bytes(rgb=(10, 200, 30)))
        mat = UsdShade.Material.Define(st, "/Looks/Img")
        sh = UsdShade.Shader.Define(st, "/Looks/Img/Surface")
        sh.CreateIdAttr("ND_standard_surface_surfaceshader")
        img = UsdShade.Shader.Define(st, "/Looks/Img/Image")
        img.CreateIdAttr("ND_image_color3")
        img.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("./albedo.png")
        img.GetInput("file").GetAttr().SetColorSpace("srgb_texture")
        uv = UsdShade.Shader.Define(st, "/Looks/Img/Uv")
        uv.CreateIdAttr("ND_geompropvalue_vector2")
        uv.CreateInput("geomprop", Sdf.ValueTypeNames.String).Set("uvmap")
        img.CreateInput("texcoord", Sdf.ValueTypeNames.Float2).ConnectToSource(uv.ConnectableAPI(), "out")
        mul = UsdShade.Shader.Define(st, "/Looks/Img/Half")
        mul.CreateIdAttr("ND_multiply_color3FA")
        mul.CreateInput("in1", Sdf.ValueTypeNames.Color3f).ConnectToSource(img.ConnectableAPI(), "out")
        mul.CreateInput("in2", Sdf.ValueTypeNames.Float).Set(0.5)
        sh.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).ConnectToSource(mul.ConnectableAPI(), "out")
        mat.CreateSurfaceOutput("mtlx").ConnectToSource(sh.ConnectableAPI(), "out")
        bind(m, mat)
        rss = self.convert(st)
        t = rss["textures"][rss.material("/Looks/Img")["diffuse_color"]["texture"]]
        self.assertEqual((t["color_space"], t["output"]), ("sRGB", "rgb"))
        near(self, t["scale"], [0.5, 0.5, 0.5, 1.0])
        self.assertEqual(t["prim"], "/Looks/Img/Image")
        # the mesh's uvs are the primvar the geompropvalue names
        uvs = rss.mesh_named("/M")["uvs"]
        self.assertEqual([tuple(round(c, 6) for c in u) for u in uvs][:2], [(0.0, 0.0), (1.0, 0.0)])


if __name__ == "__main__":
    unittest.main()
