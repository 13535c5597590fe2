"""Tests of the USD -> .rss converter: stage metrics, transforms, instancing, skinning, cameras, render
settings, errors, dependencies and the summary (`raysplat_usd.py`). The harness (running the
converter as the Rust binary does, the .rss reader, stage builders) is in `convert_support.py`."""

from convert_support import *  # noqa: F401,F403


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

    def test_camera_exposure_is_usds_linear_scale(self):
        st = self.stage()
        quad(st, "/M")
        cam = camera(st, "/Cam")
        # the defaults (and a depth-of-field fStop, which is not the exposure's): no scaling
        cam.CreateFStopAttr(8.0)
        cam.CreateFocusDistanceAttr(5.0)
        self.assertEqual(self.convert(st)["camera"]["exposure_scale"], 1.0)
        cam.CreateExposureAttr(0.5)
        cam.CreateExposureIsoAttr(400.0)
        cam.CreateExposureTimeAttr(0.5)
        cam.CreateExposureFStopAttr(2.0)
        cam.CreateExposureResponsivityAttr(1.5)
        # 2^exposure · time · iso / 100 / fStop² · responsivity
        self.assertAlmostEqual(self.convert(st)["camera"]["exposure_scale"], 2 ** 0.5 * 0.5 * 4 / 4 * 1.5, places=6)
        cam.GetExposureFStopAttr().Set(0.0)
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Cam: the camera's exposure scale", r.stderr)

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
        self.assertEqual(rss.version, FORMAT_VERSION)
        self.assertEqual([p.name for p in self.dir.iterdir() if p.name.startswith(".out.rss")], [])

    def test_json_summary_and_stderr_warnings(self):
        st = self.stage()
        quad(st, "/M", scheme="butterfly")  # an unknown scheme: its cage's polygons, with a warning
        UsdLux.SphereLight.Define(st, "/L")
        camera(st)
        rss = self.convert(st)
        s = self.result.summary
        for k in ("meshes", "instances", "triangles", "materials", "lights", "warnings", "dependencies"):
            self.assertIn(k, s)
        self.assertEqual((s["meshes"], s["instances"], s["triangles"], s["lights"]), (1, 1, 2, 1))
        self.assertEqual(s["warnings"], len(rss["warnings"]))
        self.assertTrue(any(l.startswith("warning: /M: ") for l in self.result.stderr_warnings))


if __name__ == "__main__":
    unittest.main()
