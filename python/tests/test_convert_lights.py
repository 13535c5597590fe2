"""Tests of the USD -> .rss converter: UsdLux lights (`raysplat_usd_lights.py`). The harness (running
the converter as the Rust binary does, the .rss reader, stage builders) is in `convert_support.py`."""

from convert_support import *  # noqa: F401,F403


class LightTests(Case):
    def light_scene(self, **kw):
        st = self.stage(**kw)
        quad(st, "/Floor")
        return st

    def test_intensity_with_and_without_inputs_prefix(self):
        st = self.light_scene()
        a = UsdLux.RectLight.Define(st, "/New")
        a.CreateIntensityAttr(3.0)
        b = UsdLux.RectLight.Define(st, "/Old")
        b.GetPrim().CreateAttribute("intensity", Sdf.ValueTypeNames.Float).Set(5.0)
        b.GetPrim().CreateAttribute("color", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 0.5, 0.25))
        b.GetPrim().CreateAttribute("width", Sdf.ValueTypeNames.Float).Set(2.0)
        c = UsdLux.RectLight.Define(st, "/Both")
        c.CreateIntensityAttr(7.0)
        c.GetPrim().CreateAttribute("intensity", Sdf.ValueTypeNames.Float).Set(11.0)
        rss = self.convert(st)
        self.assertVec(rss.light("/New")["radiance"], (3, 3, 3))
        self.assertVec(rss.light("/Old")["radiance"], (5, 2.5, 1.25))
        self.assertAlmostEqual(rss.light("/Old")["width"], 2.0)
        self.assertVec(rss.light("/Both")["radiance"], (7, 7, 7), msg="inputs: wins when both are authored")

    def test_an_exposure_beyond_float_range_is_an_error_naming_the_light(self):
        # 2^exposure overflows for exposure > ~1024 stops (it raised OverflowError, a traceback)
        st = self.light_scene()
        a = UsdLux.RectLight.Define(st, "/Blinding")
        a.CreateExposureAttr(1e30)
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Blinding", r.stderr)
        self.assertIn("NaN or infinite", r.stderr)
        self.assertNotIn("Traceback", r.stderr)

    def test_a_non_finite_color_temperature_is_an_error_naming_the_light(self):
        # NaN reached usd-core's blackbody table, which crashed the converter (SIGSEGV)
        for name, temp in (("nan.usda", float("nan")), ("inf.usda", float("inf"))):
            st = self.light_scene(name=name)
            a = UsdLux.DiskLight.Define(st, "/Warm")
            a.CreateEnableColorTemperatureAttr(True)
            a.CreateColorTemperatureAttr(temp)
            r = self.convert(st, expect_ok=False)
            self.assertEqual(r.rc, 2, r.stderr)
            self.assertIn("/Warm", r.stderr)
            self.assertIn("not a finite temperature", r.stderr)

    def test_normalize_divides_by_world_area_in_square_metres(self):
        st = self.light_scene(mpu=0.5)
        r = UsdLux.RectLight.Define(st, "/Rect")
        r.CreateWidthAttr(2.0)
        r.CreateHeightAttr(3.0)
        r.CreateIntensityAttr(6.0)
        r.CreateNormalizeAttr(True)
        r.AddScaleOp().Set(Gf.Vec3f(2, 1, 1))
        d = UsdLux.DiskLight.Define(st, "/Disk")
        d.CreateRadiusAttr(1.0)
        d.CreateNormalizeAttr(True)
        s = UsdLux.SphereLight.Define(st, "/Sphere")
        s.CreateRadiusAttr(2.0)
        s.CreateNormalizeAttr(True)
        u = UsdLux.RectLight.Define(st, "/Unnormalized")
        u.CreateWidthAttr(4.0)
        u.CreateIntensityAttr(6.0)
        rss = self.convert(st)
        rect = rss.light("/Rect")
        # world size: 2*2*0.5 = 2 m by 3*0.5 = 1.5 m -> area 3 m^2
        self.assertAlmostEqual(rect["width"], 2.0)
        self.assertAlmostEqual(rect["height"], 1.5)
        self.assertVec(rect["radiance"], (2, 2, 2))
        self.assertVec(rss.light("/Disk")["radiance"], [1 / (math.pi * 0.25)] * 3)
        self.assertVec(rss.light("/Sphere")["radiance"], [1 / (4 * math.pi * 1.0)] * 3)
        self.assertVec(rss.light("/Unnormalized")["radiance"], (6, 6, 6))

    def test_exposure(self):
        st = self.light_scene()
        l = UsdLux.SphereLight.Define(st, "/L")
        l.CreateIntensityAttr(3.0)
        l.CreateExposureAttr(2.0)
        l.CreateColorAttr(Gf.Vec3f(1, 0.5, 0))
        rss = self.convert(st)
        self.assertVec(rss.light("/L")["radiance"], (12, 6, 0))

    def test_color_temperature(self):
        st = self.light_scene()
        for name, k in (("/K6500", 6500.0), ("/K3000", 3000.0)):
            l = UsdLux.DiskLight.Define(st, name)
            l.CreateEnableColorTemperatureAttr(True)
            l.CreateColorTemperatureAttr(k)
        off = UsdLux.DiskLight.Define(st, "/Off")
        off.CreateColorTemperatureAttr(3000.0)
        rss = self.convert(st)
        w = rss.light("/K6500")["radiance"]
        warm = rss.light("/K3000")["radiance"]
        lum = lambda c: 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
        self.assertAlmostEqual(lum(w), 1.0, places=4)
        self.assertAlmostEqual(lum(warm), 1.0, places=4)
        self.assertLess(max(w) / min(w), 1.1, "6500 K is close to white")
        self.assertTrue(warm[0] > warm[1] > warm[2], "3000 K is reddish: %s" % (warm,))
        self.assertVec(rss.light("/Off")["radiance"], (1, 1, 1))

    def test_spot_cone(self):
        st = self.light_scene()
        l = UsdLux.SphereLight.Define(st, "/Spot")
        l.CreateRadiusAttr(0.1)
        sh = UsdLux.ShapingAPI.Apply(l.GetPrim())
        sh.CreateShapingConeAngleAttr(30.0)
        sh.CreateShapingConeSoftnessAttr(0.2)
        sh.CreateShapingFocusAttr(2.0)
        UsdLux.SphereLight.Define(st, "/Bulb")
        rss = self.convert(st)
        self.assertEqual(rss.light("/Spot")["cone"], {"angle_deg": 30.0, "softness": 0.20000000298023224, "focus": 2.0})
        self.assertIsNone(rss.light("/Bulb")["cone"])

    def test_treat_as_point_keeps_intensity(self):
        st = self.light_scene()
        l = UsdLux.SphereLight.Define(st, "/P")
        l.CreateRadiusAttr(0.5)
        l.CreateTreatAsPointAttr(True)
        l.CreateIntensityAttr(2.0)
        rss = self.convert(st)
        p = rss.light("/P")
        self.assertLessEqual(p["radius"], 1e-3)
        # radiant intensity L * pi r^2 equals the authored sphere's 2 * pi * 0.25
        self.assertAlmostEqual(p["radiance"][0] * math.pi * p["radius"] ** 2, 2 * math.pi * 0.25, places=6)

    def test_distant_light_direction_and_irradiance(self):
        st = self.light_scene()
        d = UsdLux.DistantLight.Define(st, "/Sun")
        d.AddRotateXOp().Set(-90.0)  # local -Z turned to -Y: shining straight down
        d.CreateIntensityAttr(3.0)
        d.CreateAngleAttr(1.0)
        d.CreateColorAttr(Gf.Vec3f(1, 0.5, 1))
        e = UsdLux.DistantLight.Define(st, "/Slanted")
        e.AddRotateYOp().Set(90.0)  # local -Z -> -X
        rss = self.convert(st)
        sun = rss.light("/Sun")
        self.assertVec(sun["direction"], (0, -1, 0))
        self.assertVec(sun["irradiance"], (3, 1.5, 3))
        self.assertAlmostEqual(sun["angle_deg"], 1.0)
        self.assertVec(rss.light("/Slanted")["direction"], (-1, 0, 0))
        self.assertVec(rss.light("/Slanted")["irradiance"], (50000, 50000, 50000), tol=1e-2)

    def test_dome_texture_and_orientation(self):
        st = self.light_scene()
        (self.dir / "sky.png").write_bytes(png_bytes(4, 2, (10, 20, 30)))
        dome = UsdLux.DomeLight.Define(st, "/Dome")
        dome.CreateTextureFileAttr("sky.png")
        dome.CreateIntensityAttr(0.5)
        rss = self.convert(st)
        d = rss.light("/Dome")
        tex = rss["textures"][d["texture"]]
        self.assertEqual(tex["path"], str((self.dir / "sky.png").resolve()))
        self.assertVec(d["radiance"], (0.5, 0.5, 0.5))
        # the renderer's map follows OpenEXR like USD's (local +Z at the centre, +Y up): no turn
        self.assertVec(apply(d["transform"], (0, 0, 1)), (0, 0, 1))
        self.assertVec(apply(d["transform"], (0, 1, 0)), (0, 1, 0))
        deps = {x["path"]: x["sha256"] for x in rss["dependencies"]}
        self.assertEqual(deps[tex["path"]], hashlib.sha256((self.dir / "sky.png").read_bytes()).hexdigest())

    def test_dome_light_1_pole_axis_follows_z_up_stage(self):
        st = self.light_scene(up="Z")
        UsdLux.DomeLight_1.Define(st, "/Dome")
        rss = self.convert(st)
        d = rss.light("/Dome")
        # the pole (+Y of the dome) is the stage's up axis, which is +Y after conversion
        self.assertVec(apply(d["transform"], (0, 1, 0)), (0, 1, 0))

    def test_unsupported_lights_warn(self):
        st = self.light_scene()
        UsdLux.CylinderLight.Define(st, "/Cyl")
        m = quad(st, "/Glow", z=1)
        UsdLux.MeshLightAPI.Apply(m.GetPrim())
        rss = self.convert(st)
        self.assertTrue(rss.warnings_for("/Cyl"))
        self.assertTrue(rss.warnings_for("/Glow"))
        self.assertEqual([l["name"] for l in rss["lights"]], [])

    def test_nan_light_is_exit_2(self):
        st = self.light_scene()
        UsdLux.RectLight.Define(st, "/Bad").CreateIntensityAttr(float("nan"))
        st.GetRootLayer().Save()
        r = self.convert(expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Bad", r.stderr)


if __name__ == "__main__":
    unittest.main()
