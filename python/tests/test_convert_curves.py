"""Tests of the USD -> .rss converter: curves, points, NURBS patches and tet meshes
(`raysplat_curves.py` through the converter). The harness (running the converter as the Rust binary
does, the .rss reader, stage builders) is in `convert_support.py`."""

from convert_support import *  # noqa: F401,F403


class CurveTests(Case):
    def ring_centres(self, m, sides=6, capped=True):
        """The centres of a one-curve tube's rings (an open tube's two end discs left out)."""
        p = m["positions"]
        if capped:
            p = p[:len(p) - 2 * (sides + 1)]
        return [tuple(sum(p[i + j][k] for j in range(sides)) / sides for k in range(3)) for i in range(0, len(p), sides)]

    def curves(self, st, path, points, counts, **kw):
        c = UsdGeom.BasisCurves.Define(st, path)
        c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
        c.CreateCurveVertexCountsAttr(Vt.IntArray(list(counts)))
        for name in ("type", "basis", "wrap"):
            if name in kw:
                c.GetPrim().GetAttribute(name).Set(kw[name])
        if "widths" in kw:
            c.CreateWidthsAttr(Vt.FloatArray(kw["widths"]))
            c.SetWidthsInterpolation(kw.get("interp", "vertex"))
        return c

    def test_linear_curves_become_tubes_of_their_width(self):
        st = self.stage()
        self.curves(st, "/Hair", [(0, 0, 0), (1, 0, 0), (2, 0, 0)], [3], type="linear", widths=[0.2], interp="constant")
        self.curves(st, "/Loop", [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)], [4], type="linear", wrap="periodic",
                    widths=[0.1, 0.1, 0.3, 0.3], interp="vertex")
        rss = self.convert(st)
        m = rss.mesh_named("/Hair")
        # three rings, then a disc (centre and ring) at each end
        self.assertEqual(len(m["positions"]), 3 * 6 + 2 * 7)
        self.assertEqual(len(m["indices"]), 2 * 6 * 2 + 2 * 6)
        for p, n in zip(m["positions"][:18], m["normals"][:18]):
            self.assertAlmostEqual(math.hypot(p[1], p[2]), 0.1, places=5)
            self.assertGreater(n[1] * p[1] + n[2] * p[2], 0.09)
        for t in m["indices"][:24]:
            a, b, c = (m["positions"][i] for i in t)
            centre = [(a[k] + b[k] + c[k]) / 3 for k in range(3)]
            self.assertGreater(tri_normal(a, b, c)[1] * centre[1] + tri_normal(a, b, c)[2] * centre[2], 0)
        # the discs close the ends at x = 0 and x = 2, facing out of the tube, flat-shaded
        for t in m["indices"][24:]:
            a, b, c = (m["positions"][i] for i in t)
            x = a[0]
            self.assertTrue(abs(x) < 1e-6 or abs(x - 2) < 1e-6, t)
            self.assertTrue(all(abs(q[0] - x) < 1e-6 for q in (b, c)))
            self.assertVec(tri_normal(a, b, c), (1 if x > 1 else -1, 0, 0))
            for i in t:
                self.assertVec(m["normals"][i], (1 if x > 1 else -1, 0, 0))
        loop = rss.mesh_named("/Loop")
        self.assertEqual(len(loop["indices"]), 4 * 6 * 2, "a periodic curve's tube closes, without discs")
        radii = [max(math.dist(p, c) for p in loop["positions"][6 * i:6 * i + 6]) for i, c in enumerate(self.ring_centres(loop, capped=False))]
        self.assertEqual([round(r, 4) for r in radii], [0.05, 0.05, 0.15, 0.15])

    def test_cubic_curves_follow_their_basis(self):
        st = self.stage()
        cv = [(0, 0, 0), (1, 2, 0), (3, 2, 0), (4, 0, 0)]
        self.curves(st, "/Bezier", cv, [4], widths=[0.01], interp="constant")
        self.curves(st, "/Pinned", cv, [4], basis="bspline", wrap="pinned", widths=[0.01, 0.02, 0.03], interp="varying")
        self.curves(st, "/Open", cv, [4], basis="catmullRom", widths=[0.01], interp="constant")
        rss = self.convert(st)
        bez = self.ring_centres(rss.mesh_named("/Bezier"))
        self.assertEqual(len(bez), 5)
        self.assertVec(bez[0], cv[0])
        self.assertVec(bez[2], (2.0, 1.5, 0.0))  # (P0 + 3 P1 + 3 P2 + P3) / 8
        self.assertVec(bez[4], cv[3])
        pinned = self.ring_centres(rss.mesh_named("/Pinned"))
        self.assertEqual(len(pinned), 3 * 4 + 1)
        self.assertVec(pinned[0], cv[0])  # pinned: the ends interpolated
        self.assertVec(pinned[-1], cv[3])
        # catmullRom, nonperiodic: one segment from P1 to P2
        cr = self.ring_centres(rss.mesh_named("/Open"))
        self.assertVec(cr[0], cv[1])
        self.assertVec(cr[-1], cv[2])

    def test_points_become_spheres_and_curves_take_vertex_colours(self):
        st = self.stage()
        pts = UsdGeom.Points.Define(st, "/Dots")
        pts.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(5, 0, 0)]))
        pts.CreateWidthsAttr(Vt.FloatArray([0.2, 0.4]))
        pts.SetWidthsInterpolation("vertex")
        c = self.curves(st, "/Hair", [(0, 0, 0), (0, 1, 0)], [2], type="linear", widths=[0.1], interp="constant")
        c.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 0, 1)]))
        rss = self.convert(st)
        dots = rss.mesh_named("/Dots")
        self.assertEqual(len(dots["indices"]), 2 * 80)
        half = len(dots["positions"]) // 2
        for k, (centre, r) in enumerate((((0, 0, 0), 0.1), ((5, 0, 0), 0.2))):
            for p in dots["positions"][k * half:(k + 1) * half]:
                self.assertAlmostEqual(math.dist(p, centre), r, places=5)
        hair = rss.mesh_named("/Hair")
        self.assertEqual(hair["colors"][:6], [(1.0, 0.0, 0.0)] * 6)
        self.assertEqual(hair["colors"][6:12], [(0.0, 0.0, 1.0)] * 6)
        # the end discs take their end's colour
        self.assertEqual(hair["colors"][12:], [(1.0, 0.0, 0.0)] * 7 + [(0.0, 0.0, 1.0)] * 7)
        self.assertFalse(rss.warnings_for("/Hair"), rss.warnings_for("/Hair"))

    def test_nurbs_curves_and_patches_are_tessellated(self):
        st = self.stage()
        # a rational quadratic quarter circle of radius 1
        c = UsdGeom.NurbsCurves.Define(st, "/Arc")
        c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(1, 1, 0), Gf.Vec3f(0, 1, 0)]))
        c.CreateCurveVertexCountsAttr(Vt.IntArray([3]))
        c.CreateOrderAttr(Vt.IntArray([3]))
        c.CreateKnotsAttr(Vt.DoubleArray([0, 0, 0, 1, 1, 1]))
        c.CreatePointWeightsAttr(Vt.DoubleArray([1, math.sqrt(0.5), 1]))
        c.CreateWidthsAttr(Vt.FloatArray([0.02]))
        c.SetWidthsInterpolation("constant")
        # a bicubic Bezier patch: a 4 x 4 grid on z = 0 with the inner four points raised to 1
        p = UsdGeom.NurbsPatch.Define(st, "/Patch")
        p.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(i, j, 1.0 if 0 < i < 3 and 0 < j < 3 else 0.0)
                                          for j in range(4) for i in range(4)]))
        p.CreateUVertexCountAttr(4)
        p.CreateVVertexCountAttr(4)
        p.CreateUOrderAttr(4)
        p.CreateVOrderAttr(4)
        p.CreateUKnotsAttr(Vt.DoubleArray([0, 0, 0, 0, 1, 1, 1, 1]))
        p.CreateVKnotsAttr(Vt.DoubleArray([0, 0, 0, 0, 1, 1, 1, 1]))
        rss = self.convert(st)
        for centre in self.ring_centres(rss.mesh_named("/Arc")):
            self.assertAlmostEqual(math.hypot(centre[0], centre[1]), 1.0, places=5)
        m = rss.mesh_named("/Patch")
        self.assertEqual(len(m["indices"]), 8 * 8 * 2)
        top = max(m["positions"], key=lambda q: q[2])
        self.assertVec(top, (1.5, 1.5, 0.5625))  # (B1 + B2)(1/2)^2 = (3/4)^2
        self.assertIn((0.5, 0.5), {tuple(round(x, 5) for x in u) for u in m["uvs"]})
        for q, n in zip(m["positions"], m["normals"]):
            self.assertGreater(n[2], 0.3)  # dP/du x dP/dv: +z
        # a knot vector of the wrong length is an error naming the prim
        p.CreateUKnotsAttr(Vt.DoubleArray([0, 0, 1, 1]))
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Patch", r.stderr)
        self.assertIn("4 knots", r.stderr)

    def test_nurbs_ranges_outside_the_knots_are_errors(self):
        # a range must lie within [knots[order - 1], knots[count]] (the schema's rule); below it the
        # span search found no span and never returned
        for kind in ("curve", "patch"):
            st = self.stage("%s.usda" % kind)
            if kind == "curve":
                c = UsdGeom.NurbsCurves.Define(st, "/Bad")
                c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(i, i % 2, 0) for i in range(5)]))
                c.CreateCurveVertexCountsAttr(Vt.IntArray([5]))
                c.CreateOrderAttr(Vt.IntArray([3]))
                c.CreateKnotsAttr(Vt.DoubleArray([0, 0, 1, 2, 2, 3, 3, 3]))
                c.CreateRangesAttr(Vt.Vec2dArray([Gf.Vec2d(-0.1, 1.1)]))
                c.CreateWidthsAttr(Vt.FloatArray([0.02]))
                c.SetWidthsInterpolation("constant")
            else:
                p = UsdGeom.NurbsPatch.Define(st, "/Bad")
                p.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(i, j, 0) for j in range(2) for i in range(2)]))
                p.CreateUVertexCountAttr(2)
                p.CreateVVertexCountAttr(2)
                p.CreateUOrderAttr(2)
                p.CreateVOrderAttr(2)
                p.CreateUKnotsAttr(Vt.DoubleArray([0, 0, 1, 1]))
                p.CreateVKnotsAttr(Vt.DoubleArray([0, 0, 1, 1]))
                p.CreateURangeAttr(Gf.Vec2d(0, 1.5))
            r = self.convert(st, expect_ok=False)
            self.assertEqual(r.rc, 2, (kind, r.stderr))
            self.assertIn("/Bad", r.stderr)
            self.assertIn("outside the knots' domain", r.stderr)

    def test_tet_meshes_render_their_surface(self):
        # two tetrahedra sharing a face: the shared face is inside, the other six outside, facing out
        st = self.stage()
        m = UsdGeom.TetMesh.Define(st, "/Tets")
        pts = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)]
        m.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in pts]))
        m.CreateTetVertexIndicesAttr(Vt.Vec4iArray([Gf.Vec4i(0, 1, 2, 3), Gf.Vec4i(1, 2, 3, 4)]))
        out = self.convert(st).mesh_named("/Tets")
        self.assertEqual(len(out["indices"]), 6)
        centre = [sum(p[k] for p in pts) / len(pts) for k in range(3)]
        for t in out["indices"]:
            a, b, c = (out["positions"][i] for i in t)
            mid = [(a[k] + b[k] + c[k]) / 3 - centre[k] for k in range(3)]
            self.assertGreater(sum(x * y for x, y in zip(tri_normal(a, b, c), mid)), 0)

    def test_hermite_curves_follow_their_tangents(self):
        st = self.stage()
        h = UsdGeom.HermiteCurves.Define(st, "/Hermite")
        h.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0)]))
        h.CreateTangentsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 2, 0), Gf.Vec3f(0, 2, 0)]))
        h.CreateCurveVertexCountsAttr(Vt.IntArray([2]))
        h.CreateWidthsAttr(Vt.FloatArray([0.01]))
        h.SetWidthsInterpolation("constant")
        centres = self.ring_centres(self.convert(st).mesh_named("/Hermite"))
        self.assertEqual(len(centres), 5)
        # t = 1/4: h01 = 5/32 along x, (h10 + h11) · 2 = 3/16 along y
        self.assertVec(centres[1], (0.15625, 0.1875, 0.0))
        self.assertVec(centres[2], (0.5, 0.0, 0.0))
        h.CreateTangentsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 2, 0)]))
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Hermite", r.stderr)
        self.assertIn("1 tangents for 2 points", r.stderr)

    def test_bad_curves_are_errors_naming_the_prim(self):
        for case, (kw, msg) in enumerate((({"points": [(0, 0, 0), (1, 0, 0)], "counts": [3]}, "curveVertexCounts sum to 3"),
                        ({"points": [(0, 0, 0)] * 5, "counts": [5]}, "nonperiodic cubic bezier"),
                        ({"points": [(0, 0, 0), (1, 0, 0)], "counts": [2], "type": "linear", "widths": [-1],
                          "interp": "constant"}, "negative"))):
            with self.subTest(msg=msg):
                st = self.stage("bad%d.usda" % case)
                args = dict(kw)
                self.curves(st, "/Bad", args.pop("points"), args.pop("counts"), **args)
                r = self.convert(st, expect_ok=False)
                self.assertEqual(r.rc, 2, r.stderr)
                self.assertIn("/Bad", r.stderr)
                self.assertIn(msg, r.stderr)


if __name__ == "__main__":
    unittest.main()
