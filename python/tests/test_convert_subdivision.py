"""Tests of the USD -> .rss converter: subdivision surfaces (catmullClark, loop, bilinear; creases,
corners, face-varying data; `raysplat_subdiv.py` through the converter). The harness (running the
converter as the Rust binary does, the .rss reader, stage builders) is in `convert_support.py`."""

from convert_support import *  # noqa: F401,F403


class SubdivisionTests(Case):
    # A cube of side 2 about the origin, faces outward.
    CUBE_PTS = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
    CUBE_IDX = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3]

    def cube(self, st, path="/Cube", **kw):
        return add_mesh(st, path, self.CUBE_PTS, [4] * 6, self.CUBE_IDX, scheme="catmullClark", **kw)

    def test_subdivision_level_0_is_the_cage_with_warning_and_smooth_normals(self):
        st = self.stage()
        quad(st, "/Sub", scheme="catmullClark")
        rss = self.convert(st, args=("--subdivision-level", "0"))
        m = rss.mesh_named("/Sub")
        self.assertEqual(len(m["indices"]), 2)
        self.assertTrue(any("control cage" in w["message"] for w in rss.warnings_for("/Sub")))
        for n in m["normals"]:
            self.assertVec(n, (0, 0, 1))

    def test_catmull_clark_points_lie_on_the_limit_surface(self):
        # one level on a cube (the rules themselves: test_subdiv.py), its points then moved onto the
        # limit surface: a corner of valence 3 to (9 v + 4 Σ e + Σ d) / 24 = v / 2, a face centre
        # (regular: the bicubic B-spline's mask) to 68/81 of the half side; the points of level 1
        # are points of level 2 too (a limit point is where every further level puts it)
        st = self.stage()
        self.cube(st)
        rss = self.convert(st, args=("--subdivision-level", "1"))
        m = rss.mesh_named("/Cube")
        self.assertEqual(len(m["indices"]), 6 * 4 * 2)
        pts = {tuple(round(c, 5) for c in p) for p in m["positions"]}
        self.assertEqual(len(pts), 8 + 12 + 6)
        self.assertIn((0.5, 0.5, 0.5), pts)
        self.assertIn((-0.5, 0.5, -0.5), pts)
        self.assertIn((round(68 / 81, 5), 0.0, 0.0), pts)
        self.assertFalse(rss.warnings_for("/Cube"), rss.warnings_for("/Cube"))
        level2 = {tuple(round(c, 5) for c in p) for p in self.convert(st).mesh_named("/Cube")["positions"]}
        self.assertLessEqual(pts, level2)
        # winding kept: every triangle faces away from the centre; normals are smooth and outward
        for t in m["indices"]:
            a, b, c = (m["positions"][i] for i in t)
            centre = [(a[k] + b[k] + c[k]) / 3 for k in range(3)]
            self.assertGreater(sum(x * y for x, y in zip(tri_normal(a, b, c), centre)), 0)
        for p, n in zip(m["positions"], m["normals"]):
            self.assertGreater(sum(x * y for x, y in zip(p, n)), 0.5)

    def test_catmull_clark_converges_toward_the_limit_surface(self):
        # the default level (2): 96 quads, every point between the cube's limit surface bounds
        st = self.stage()
        self.cube(st)
        m = self.convert(st).mesh_named("/Cube")
        self.assertEqual(len(m["indices"]), 6 * 16 * 2)
        for p in m["positions"]:
            r = math.sqrt(sum(c * c for c in p))
            self.assertGreater(r, 0.6)
            self.assertLess(r, 1.0)

    def test_subdivision_normals_are_the_limit_surfaces(self):
        # the converted cube's points lie on its limit surface, and their normals are the surface's:
        # against the area-weighted normals of the same points refined four levels further (they
        # are points of every finer level too), within 0.02° (area-weighted normals of level 2
        # itself: up to 1.8°)
        from test_subdiv import Refinement, angle, area_normals, flat
        st = self.stage()
        self.cube(st)
        m = self.convert(st).mesh_named("/Cube")
        deep = Refinement(8, [4] * 6, self.CUBE_IDX, 6)
        dp = deep.points(flat(self.CUBE_PTS), 3, limit=True)
        want = dict(zip((tuple(round(c, 4) for c in dp[3 * i:3 * i + 3]) for i in range(deep.npts)), area_normals(deep, dp)))
        worst = max(angle(n, want[tuple(round(c, 4) for c in q)]) for q, n in zip(m["positions"], m["normals"]))
        self.assertLess(worst, 0.02)

    def test_boundaries_and_sharp_creases_keep_their_shape(self):
        st = self.stage()
        # a flat 2x1 grid of quads: edgeAndCorner keeps the corners and the boundary on its lines
        add_mesh(st, "/Grid", [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)], [4, 4],
                 [0, 1, 4, 3, 1, 2, 5, 4], scheme="catmullClark")
        # a cube whose every edge is infinitely sharp stays a cube
        c = self.cube(st, "/Sharp")
        chain = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
        c.CreateCreaseIndicesAttr([v for e in chain for v in e])
        c.CreateCreaseLengthsAttr([2] * 12)
        c.CreateCreaseSharpnessesAttr([10.0] * 12)
        # a cube with one infinitely sharp corner
        k = self.cube(st, "/Corner")
        k.CreateCornerIndicesAttr([6])
        k.CreateCornerSharpnessesAttr([10.0])
        rss = self.convert(st, args=("--subdivision-level", "3"))
        g = rss.mesh_named("/Grid")["positions"]
        self.assertTrue(all(abs(p[2]) < 1e-6 for p in g))
        for corner in [(0, 0), (2, 0), (0, 1), (2, 1)]:
            self.assertTrue(any(abs(p[0] - corner[0]) < 1e-6 and abs(p[1] - corner[1]) < 1e-6 for p in g), corner)
        self.assertAlmostEqual(min(p[0] for p in g), 0.0, places=6)
        self.assertAlmostEqual(max(p[0] for p in g), 2.0, places=6)
        sharp = rss.mesh_named("/Sharp")["positions"]
        self.assertTrue(all(abs(max(abs(c) for c in p) - 1.0) < 1e-5 for p in sharp))
        self.assertIn((1.0, 1.0, 1.0), {tuple(round(c, 5) for c in p) for p in sharp})
        # the sharp cube's shading is flat on each face, hard at its edges (smooth normals would
        # tilt toward the neighbouring faces there)
        sm = rss.mesh_named("/Sharp")
        for t in sm["indices"]:
            a, b, c = (sm["positions"][i] for i in t)
            face = tri_normal(a, b, c)
            for i in t:
                self.assertVec(sm["normals"][i], face, tol=1e-4)
        corner = rss.mesh_named("/Corner")["positions"]
        self.assertIn((1.0, 1.0, 1.0), {tuple(round(c, 5) for c in p) for p in corner})
        self.assertNotIn((-1.0, -1.0, -1.0), {tuple(round(c, 5) for c in p) for p in corner})

    def test_refined_holes_subsets_and_face_varying_uvs(self):
        st = self.stage()
        m = add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0), (3, 0, 0), (3, 1, 0)],
                     [4, 4, 4], [0, 1, 2, 3, 1, 4, 5, 2, 4, 6, 7, 5], scheme="catmullClark")
        m.CreateHoleIndicesAttr([2])
        uv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
        uv.Set(Vt.Vec2fArray([Gf.Vec2f(*c) for c in [(0, 0), (1, 0), (1, 1), (0, 1)] * 3]))
        red, _ = preview(st, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
        grey, _ = preview(st, "/Looks/Grey")
        bind(m, grey)
        bind(UsdShade.MaterialBindingAPI(m.GetPrim()).CreateMaterialBindSubset("A", Vt.IntArray([1])), red)
        rss = self.convert(st, args=("--subdivision-level", "1"))
        out = rss.mesh_named("/M")
        # the hole's four children are dropped; face 1's children keep its subset's material
        self.assertEqual(len(out["indices"]), 2 * 4 * 2)
        mats = [x["name"] for x in rss["materials"]]
        self.assertEqual([mats[i] for i in out["material_ids"]], ["/Looks/Grey"] * 8 + ["/Looks/Red"] * 8)
        # the face points carry the centre of each face's texture square
        uvs = {tuple(round(c, 5) for c in u) for u in out["uvs"]}
        self.assertIn((0.5, 0.5), uvs)
        self.assertIn((0.5, 0.0), uvs)
        self.assertFalse(rss.warnings_for("/M"), rss.warnings_for("/M"))

    def test_face_varying_primvars_follow_the_smooth_rules_inside_their_islands(self):
        # a 3x3 grid of quads whose texture coordinates are its own x, y (one island, face-varying):
        # refined smoothly (cornersPlus1, USD's default) they stay the refined points' x, y, where
        # refined linearly ("all") they do not
        st = self.stage()
        pts = [(x + 0.3 * (x == 1 and y == 1), y - 0.2 * (x == 2), 0.1 * ((x * 7 + y * 3) % 4))
               for y in range(4) for x in range(4)]
        faces = [(y * 4 + x, y * 4 + x + 1, (y + 1) * 4 + x + 1, (y + 1) * 4 + x) for y in range(3) for x in range(3)]
        for name, rule in (("/Smooth", None), ("/Linear", "all")):
            m = add_mesh(st, name, pts, [4] * 9, [i for f in faces for i in f], scheme="catmullClark")
            if rule:
                m.CreateFaceVaryingLinearInterpolationAttr(rule)
            uv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
            uv.Set(Vt.Vec2fArray([Gf.Vec2f(pts[i][0], pts[i][1]) for f in faces for i in f]))
        rss = self.convert(st, args=("--subdivision-level", "2"))
        smooth, linear = rss.mesh_named("/Smooth"), rss.mesh_named("/Linear")
        for p, u in zip(smooth["positions"], smooth["uvs"]):
            self.assertAlmostEqual(p[0], u[0], places=5)
            self.assertAlmostEqual(p[1], u[1], places=5)
        worst = max(abs(p[0] - u[0]) + abs(p[1] - u[1]) for p, u in zip(linear["positions"], linear["uvs"]))
        self.assertGreater(worst, 0.01)

    def test_varying_primvars_are_refined_linearly(self):
        # a 4x4 grid of quads with one texture coordinate 1 at an interior vertex, 0 elsewhere:
        # varying, it is interpolated bilinearly over the faces (its peak stays 1, every refined
        # value a multiple of 1/16 at level 2); vertex, it follows the smooth rules and the limit
        st = self.stage()
        pts = [(x, y, 0.1 * ((x * 7 + y * 3) % 4)) for y in range(5) for x in range(5)]
        faces = [(y * 5 + x, y * 5 + x + 1, (y + 1) * 5 + x + 1, (y + 1) * 5 + x) for y in range(4) for x in range(4)]
        for name, interp in (("/Varying", UsdGeom.Tokens.varying), ("/Vertex", UsdGeom.Tokens.vertex)):
            m = add_mesh(st, name, pts, [4] * 16, [i for f in faces for i in f], scheme="catmullClark")
            uv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, interp)
            uv.Set(Vt.Vec2fArray([Gf.Vec2f(1.0 if i == 13 else 0.0, 0.0) for i in range(len(pts))]))
        rss = self.convert(st, args=("--subdivision-level", "2"))
        varying = [u[0] for u in rss.mesh_named("/Varying")["uvs"]]
        self.assertEqual(max(varying), 1.0)
        for x in varying:
            self.assertAlmostEqual(x * 16, round(x * 16), places=4)
        self.assertLess(max(u[0] for u in rss.mesh_named("/Vertex")["uvs"]), 0.5)
        self.assertFalse(rss.warnings_for("/Varying"), rss.warnings_for("/Varying"))

    def test_loop_and_bilinear_schemes(self):
        st = self.stage()
        tet = [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]
        add_mesh(st, "/Loop", tet, [3] * 4, [0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2], scheme="loop")
        add_mesh(st, "/Bilinear", self.CUBE_PTS, [4] * 6, self.CUBE_IDX, scheme="bilinear")
        add_mesh(st, "/LoopQuads", self.CUBE_PTS, [4] * 6, self.CUBE_IDX, scheme="loop")
        rss = self.convert(st, args=("--subdivision-level", "1"))
        loop = rss.mesh_named("/Loop")
        self.assertEqual(len(loop["indices"]), 16)
        # a tip's limit (valence 3, χ = 1/5): (1 - 3/5) v + (sum of the others) / 5 = v / 5
        self.assertIn((0.2, 0.2, 0.2), {tuple(round(c, 5) for c in p) for p in loop["positions"]})
        bil = rss.mesh_named("/Bilinear")
        self.assertEqual(len(bil["indices"]), 48)
        self.assertTrue(all(abs(max(abs(c) for c in p) - 1.0) < 1e-6 for p in bil["positions"]))
        self.assertEqual(len(rss.mesh_named("/LoopQuads")["indices"]), 12)
        self.assertTrue(any("loop scheme needs triangles" in w["message"] for w in rss.warnings_for("/LoopQuads")))

    def test_faces_no_subdivision_rule_covers_leave_the_cage_unrefined(self):
        # no subdivision rule covers a face that names a vertex twice (Loop's edge rule has no
        # opposite vertex for it): the cage is rendered, with a warning naming the prim and the face
        st = self.stage()
        add_mesh(st, "/Loop", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)], [3, 3], [0, 1, 2, 1, 1, 3], scheme="loop")
        add_mesh(st, "/CC", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4, 4], [0, 1, 2, 3, 0, 1, 1, 2], scheme="catmullClark")
        # nor a face of fewer than three vertices (a face of none divided by zero for its centroid)
        add_mesh(st, "/Small", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4, 0, 2], [0, 1, 2, 3, 0, 1], scheme="bilinear")
        rss = self.convert(st)
        self.assertEqual(len(rss.mesh_named("/Small")["indices"]), 2)
        self.assertTrue(any("face 1 has 0 vertices" in w["message"] and "control cage" in w["message"]
                            for w in rss.warnings_for("/Small")), rss.warnings_for("/Small"))
        # the cages' triangles (the loader drops the zero-area ones, with a warning of its own)
        self.assertEqual(len(rss.mesh_named("/Loop")["indices"]), 2)
        self.assertEqual(len(rss.mesh_named("/CC")["indices"]), 4)
        for path, face in (("/Loop", "face 1 names a vertex twice (1 1 3)"), ("/CC", "face 1 names a vertex twice (0 1 1 2)")):
            self.assertTrue(any(face in w["message"] and "control cage" in w["message"] for w in rss.warnings_for(path)),
                            rss.warnings_for(path))

    def test_negative_sharpness_reads_as_smooth_with_a_warning(self):
        # a negative sharpness is no sharpness (OpenSubdiv's reading): the same surface as untagged
        st = self.stage()
        self.cube(st, "/Plain")
        k = self.cube(st, "/Negative")
        k.CreateCreaseIndicesAttr([0, 1])
        k.CreateCreaseLengthsAttr([2])
        k.CreateCreaseSharpnessesAttr([-3.0])
        k.CreateCornerIndicesAttr([6])
        k.CreateCornerSharpnessesAttr([-1.0])
        rss = self.convert(st)
        self.assertEqual(rss.mesh_named("/Plain")["positions"], rss.mesh_named("/Negative")["positions"])
        self.assertTrue(any("2 crease or corner sharpnesses are negative (the least -3)" in w["message"]
                            for w in rss.warnings_for("/Negative")), rss.warnings_for("/Negative"))
        self.assertFalse(rss.warnings_for("/Plain"))

    def test_bad_subdivision_tags_and_levels(self):
        st = self.stage()
        self.cube(st).CreateCornerIndicesAttr([42])
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Cube", r.stderr)
        self.assertIn("out of range", r.stderr)
        # a NaN crease sharpness (which the edge table's max with 0 used to swallow)
        st = self.stage("nan.usda")
        c = self.cube(st)
        c.CreateCreaseIndicesAttr([0, 1])
        c.CreateCreaseLengthsAttr([2])
        c.CreateCreaseSharpnessesAttr([float("nan")])
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Cube", r.stderr)
        self.assertIn("non-finite sharpnesses", r.stderr)
        # crease arrays that do not fit together (they raised IndexError, a traceback)
        for name, lengths, sharp, what in (("short.usda", [2, 2], [], "0 creaseSharpnesses for 2 creases"),
                                           ("long.usda", [2, 3], [1.0, 1.0], "add up to 5 where creaseIndices has 4")):
            st = self.stage(name)
            c = self.cube(st)
            c.CreateCreaseIndicesAttr([0, 1, 2, 3])
            c.CreateCreaseLengthsAttr(lengths)
            c.CreateCreaseSharpnessesAttr(sharp)
            r = self.convert(st, expect_ok=False)
            self.assertEqual(r.rc, 2, r.stderr)
            self.assertIn("/Cube", r.stderr)
            self.assertIn(what, r.stderr)
            self.assertNotIn("Traceback", r.stderr)
        r = self.convert(expect_ok=False, args=("--subdivision-level", "99"))
        self.assertEqual(r.rc, 2, r.stderr)
        r = self.convert(expect_ok=False, args=("--subdivision-level", "-1"))
        self.assertEqual(r.rc, 2, r.stderr)


if __name__ == "__main__":
    unittest.main()
