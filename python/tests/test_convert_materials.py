"""Tests of the USD -> .rss converter: materials and textures (`raysplat_usd_materials.py`). The
harness (running the converter as the Rust binary does, the .rss reader, stage builders) is in
`convert_support.py`."""

from convert_support import *  # noqa: F401,F403


class MaterialTests(Case):
    def test_texture_connection_scale_bias_wrap(self):
        st = self.stage()
        m = quad(st, "/M")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
        (self.dir / "tex").mkdir()
        (self.dir / "tex" / "albedo.png").write_bytes(png_bytes())
        mat, sh = preview(st, "/Looks/T", roughness=0.25, ior=1.33, clearcoat=0.5)
        tex = uv_texture(st, "/Looks/T/Tex", "./tex/albedo.png")
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("mirror")
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("clamp")
        tex.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2, 2, 2, 1))
        tex.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1, -1, -1, 0))
        tex.CreateInput("fallback", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(0.5, 0.5, 0.5, 1))
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
        rd = primvar_reader(st, "/Looks/T/Reader", "st", Sdf.ValueTypeNames.Token)
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
        tex = uv_texture(st, "/Looks/T/Tex", "missing.png")
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
        tex = uv_texture(st, "/Looks/T/Tex")
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
        tex = uv_texture(st, "/Looks/T/Tex", "t.png")
        rd = primvar_reader(st, "/Looks/T/Reader", "st")
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

    def test_st_without_a_primvar_is_a_constant(self):
        # Unconnected: sampled at st = (0, 0) as the spec and Hydra Storm do (the mesh's own texture
        # coordinates, which may run far outside the image, are not read), with a warning.
        st = self.stage()
        m = quad(st, "/M")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("map1", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(-37.8, 0), Gf.Vec2f(37.8, 0), Gf.Vec2f(37.8, 37.8), Gf.Vec2f(-37.8, 37.8)]))
        (self.dir / "red.png").write_bytes(png_bytes())
        mat, sh = preview(st, "/Looks/Red")
        tex = uv_texture(st, "/Looks/Red/Tex", "./red.png")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        # a second material whose st is an authored constant, through a UsdTransform2d
        m2 = quad(st, "/M2", z=1)
        mat2, sh2 = preview(st, "/Looks/Const")
        tex2 = uv_texture(st, "/Looks/Const/Tex", "./red.png")
        xf = UsdShade.Shader.Define(st, "/Looks/Const/Xf")
        xf.CreateIdAttr("UsdTransform2d")
        xf.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.25, 0.5))
        xf.CreateInput("in", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.125, 0.25))
        tex2.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(xf.ConnectableAPI(), "result")
        sh2.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex2.ConnectableAPI(), "rgb")
        bind(m2, mat2)
        rss = self.convert(st)
        t = rss["textures"][rss.material("/Looks/Red")["diffuse_color"]["texture"]]
        self.assertEqual(t["st_transform"], [[0, 0, 0], [0, 0, 0]])
        self.assertTrue(any("st is not connected; the texture is sampled at st = (0, 0)" in w["message"]
                            for w in rss.warnings_for("/Looks/Red/Tex")), rss["warnings"])
        t2 = rss["textures"][rss.material("/Looks/Const")["diffuse_color"]["texture"]]
        self.assertEqual(t2["st_transform"], [[0, 0, 0.375], [0, 0, 0.75]])
        self.assertFalse(rss.warnings_for("/Looks/Const"))

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

    def test_unknown_shaders_are_error_materials(self):
        st = self.stage()
        a = quad(st, "/A")
        b = quad(st, "/B", z=1)
        c = quad(st, "/C", z=2)
        mx = UsdShade.Material.Define(st, "/Looks/Mtlx")
        s = UsdShade.Shader.Define(st, "/Looks/Mtlx/SS")
        s.CreateIdAttr("ND_gltf_pbr_surfaceshader")  # a MaterialX surface the converter does not map
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
        self.assertTrue(any("gltf_pbr" in w["message"] for w in rss.warnings_for("/Looks/Mtlx")))
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
        tex = uv_texture(a, "/Asset/Looks/T/Tex", "tex.png")
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


if __name__ == "__main__":
    unittest.main()
