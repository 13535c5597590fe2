"""Tests of the USD -> .rss converter: subdivision surfaces (catmullClark, loop, bilinear) are written as
their control cages and tags (creases, corners, holes, boundary and face-varying rules, primvars with an
index per face-vertex), which the renderer tessellates or refines (`src/prepare/subdivision.rs`,
`src/subdiv/`; their tests are Rust's). The harness is in `convert_support.py`."""

from convert_support import *  # noqa: F401,F403


class SubdivisionTests(Case):
    # A cube of side 2 about the origin, faces outward.
    CUBE_PTS = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
    CUBE_IDX = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3]

    def cube(self, st, path="/Cube", **kw):
        return add_mesh(st, path, self.CUBE_PTS, [4] * 6, self.CUBE_IDX, scheme=kw.pop("scheme", "catmullClark"), **kw)

    def test_catmull_clark_meshes_are_their_cages(self):
        # the cage's points and faces as authored, no triangles, no normals: the renderer makes the
        # surface; USD's defaults for the rules
        st = self.stage()
        self.cube(st)
        rss = self.convert(st)
        sd = rss.subdivision("/Cube")
        self.assertEqual(sd["scheme"], "catmullClark")
        self.assertEqual(sd["face_counts"], [4] * 6)
        self.assertEqual(sd["face_indices"], self.CUBE_IDX)
        self.assertEqual(sd["positions"], [tuple(float(c) for c in p) for p in self.CUBE_PTS])
        self.assertEqual((sd["boundary"], sd["face_varying"]), ("edgeAndCorner", "cornersPlus1"))
        self.assertEqual((sd["holes"], sd["creases"], sd["corners"]), ([], [], []))
        self.assertIsNone(sd["uvs"])
        m = next(m for m in rss["meshes"] if m["name"] == "/Cube")
        self.assertIsNone(m["indices"])
        self.assertIsNone(m["normals"])
        self.assertEqual(self.result.summary["subdivision_faces"], 6)
        self.assertEqual(self.result.summary["triangles"], 0)
        self.assertFalse(rss.warnings_for("/Cube"), rss.warnings_for("/Cube"))

    def test_creases_corners_holes_and_rules(self):
        st = self.stage()
        c = self.cube(st)
        # two chains: (0 1 2) of sharpness 3 for the chain, and (2 6) of 10; the edge (1 2) named
        # again keeps the larger sharpness
        c.CreateCreaseIndicesAttr([0, 1, 2, 2, 6, 2, 1])
        c.CreateCreaseLengthsAttr([3, 2, 2])
        c.CreateCreaseSharpnessesAttr([3.0, 10.0, 5.0])
        c.CreateCornerIndicesAttr([6, 4])
        c.CreateCornerSharpnessesAttr([10.0, 0.5])
        c.CreateHoleIndicesAttr([5, 2])
        c.CreateInterpolateBoundaryAttr("edgeOnly")
        c.CreateFaceVaryingLinearInterpolationAttr("all")
        # one sharpness per edge, and interpolateBoundary none
        e = self.cube(st, "/PerEdge")
        e.CreateCreaseIndicesAttr([0, 1, 2])
        e.CreateCreaseLengthsAttr([3])
        e.CreateCreaseSharpnessesAttr([1.5, 2.5])
        e.CreateInterpolateBoundaryAttr("none")
        rss = self.convert(st)
        sd = rss.subdivision("/Cube")
        got = dict(zip(sd["creases"], sd["crease_sharpness"]))
        self.assertEqual(got, {(0, 1): 3.0, (1, 2): 5.0, (2, 6): 10.0})
        self.assertEqual(dict(zip(sd["corners"], sd["corner_sharpness"])), {6: 10.0, 4: 0.5})
        self.assertEqual(sd["holes"], [2, 5])
        self.assertEqual((sd["boundary"], sd["face_varying"]), ("edgeOnly", "all"))
        sd = rss.subdivision("/PerEdge")
        self.assertEqual(dict(zip(sd["creases"], sd["crease_sharpness"])), {(0, 1): 1.5, (1, 2): 2.5})
        self.assertEqual(sd["boundary"], "none")
        self.assertFalse(rss.warnings_for("/Cube") + rss.warnings_for("/PerEdge"))

    def test_left_handed_faces_are_reversed_with_their_face_varying_data(self):
        # each face's corners reversed after its first: the front is then counter-clockwise, and
        # the face-varying values move with their corners
        st = self.stage()
        m = self.cube(st, orientation="leftHanded")
        uv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
        uv.Set(Vt.Vec2fArray([Gf.Vec2f(k, 0) for k in range(24)]))
        sd = self.convert(st).subdivision("/Cube")
        want = [i for f in range(6) for i in [self.CUBE_IDX[4 * f]] + self.CUBE_IDX[4 * f + 1:4 * f + 4][::-1]]
        self.assertEqual(sd["face_indices"], want)
        order = [k for f in range(6) for k in (4 * f, 4 * f + 3, 4 * f + 2, 4 * f + 1)]
        self.assertEqual(sd["uvs"]["indices"], order)
        self.assertEqual(sd["uvs"]["mode"], "faceVarying")

    def test_primvars_of_every_interpolation(self):
        # vertex: a value per point (indexed ones resolved); varying: linear over the point indices;
        # uniform and constant: linear with each face's (the one) value; faceVarying: its values and
        # indices (identity when not indexed)
        st = self.stage()
        cases = {"vertex": (UsdGeom.Tokens.vertex, 8), "varying": (UsdGeom.Tokens.varying, 8),
                 "uniform": (UsdGeom.Tokens.uniform, 6), "constant": (UsdGeom.Tokens.constant, 1),
                 "fv": (UsdGeom.Tokens.faceVarying, 24)}
        for name, (interp, n) in cases.items():
            m = self.cube(st, "/" + name)
            pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, interp)
            pv.Set(Vt.Vec2fArray([Gf.Vec2f(k, 1) for k in range(n)]))
        ind = self.cube(st, "/indexed")
        pv = UsdGeom.PrimvarsAPI(ind).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
        pv.Set(Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0)]))
        pv.SetIndices(Vt.IntArray([0, 1, 0, 1, 0, 1, 0, 1]))
        rss = self.convert(st)
        v = rss.subdivision("/vertex")["uvs"]
        self.assertEqual((v["mode"], v["indices"], len(v["values"])), ("vertex", None, 8))
        v = rss.subdivision("/varying")["uvs"]
        self.assertEqual((v["mode"], v["indices"]), ("linear", self.CUBE_IDX))
        v = rss.subdivision("/uniform")["uvs"]
        self.assertEqual((v["mode"], v["indices"]), ("linear", [f for f in range(6) for _ in range(4)]))
        v = rss.subdivision("/constant")["uvs"]
        self.assertEqual(v["mode"], "vertex")
        self.assertEqual(set(v["values"]), {(0.0, 1.0)})
        v = rss.subdivision("/fv")["uvs"]
        self.assertEqual((v["mode"], v["indices"], len(v["values"])), ("faceVarying", list(range(24)), 24))
        v = rss.subdivision("/indexed")["uvs"]
        self.assertEqual(v["values"], [(0.0, 0.0), (1.0, 0.0)] * 4)
        self.assertFalse([w for w in rss["warnings"] if w["prim"] != "/"], rss["warnings"])

    def test_subsets_give_a_material_per_cage_face(self):
        st = self.stage()
        m = self.cube(st)
        red, _ = preview(st, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
        grey, _ = preview(st, "/Looks/Grey")
        bind(m, grey)
        bind(UsdShade.MaterialBindingAPI(m.GetPrim()).CreateMaterialBindSubset("A", Vt.IntArray([1, 4])), red)
        rss = self.convert(st)
        mats = [x["name"] for x in rss["materials"]]
        sd = rss.subdivision("/Cube")
        self.assertEqual([mats[i] for i in sd["material_ids"]],
                         ["/Looks/Grey", "/Looks/Red", "/Looks/Grey", "/Looks/Grey", "/Looks/Red", "/Looks/Grey"])

    def test_authored_normals_are_ignored_with_a_warning(self):
        st = self.stage()
        m = self.cube(st)
        m.CreateNormalsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 1)] * 8))
        rss = self.convert(st)
        self.assertTrue(any("authored normals are ignored" in w["message"] for w in rss.warnings_for("/Cube")))
        self.assertIsNone(next(m for m in rss["meshes"] if m["name"] == "/Cube")["normals"])

    def test_loop_bilinear_and_unknown_schemes(self):
        # Loop and bilinear cages are written as they are (the renderer refines them, and renders
        # a Loop cage of quads as a cage, with a warning); an unknown scheme is a polygon mesh
        st = self.stage()
        tet = [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]
        add_mesh(st, "/Loop", tet, [3] * 4, [0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2], scheme="loop")
        self.cube(st, "/Bilinear", scheme="bilinear")
        self.cube(st, "/LoopQuads", scheme="loop")
        self.cube(st, "/Odd", scheme="butterfly")
        rss = self.convert(st)
        self.assertEqual(rss.subdivision("/Loop")["scheme"], "loop")
        self.assertEqual(rss.subdivision("/Bilinear")["scheme"], "bilinear")
        self.assertEqual(rss.subdivision("/LoopQuads")["face_counts"], [4] * 6)
        odd = rss.mesh_named("/Odd")
        self.assertEqual(len(odd["indices"]), 12)
        self.assertTrue(any("unknown subdivision scheme 'butterfly'" in w["message"] for w in rss.warnings_for("/Odd")))

    def test_negative_sharpness_reads_as_smooth_with_a_warning(self):
        st = self.stage()
        k = self.cube(st, "/Negative")
        k.CreateCreaseIndicesAttr([0, 1])
        k.CreateCreaseLengthsAttr([2])
        k.CreateCreaseSharpnessesAttr([-3.0])
        k.CreateCornerIndicesAttr([6])
        k.CreateCornerSharpnessesAttr([-1.0])
        rss = self.convert(st)
        sd = rss.subdivision("/Negative")
        self.assertEqual(sd["crease_sharpness"] + sd["corner_sharpness"], [0.0, 0.0])
        self.assertTrue(any("2 crease or corner sharpnesses are negative (the least -3)" in w["message"]
                            for w in rss.warnings_for("/Negative")), rss.warnings_for("/Negative"))

    def test_bad_subdivision_tags(self):
        st = self.stage()
        self.cube(st).CreateCornerIndicesAttr([42])
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Cube", r.stderr)
        self.assertIn("out of range", r.stderr)
        # a NaN crease sharpness (which the edge table's max with 0 would swallow)
        st = self.stage("nan.usda")
        c = self.cube(st)
        c.CreateCreaseIndicesAttr([0, 1])
        c.CreateCreaseLengthsAttr([2])
        c.CreateCreaseSharpnessesAttr([float("nan")])
        r = self.convert(st, expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Cube", r.stderr)
        self.assertIn("non-finite sharpnesses", r.stderr)
        # crease arrays that do not fit together
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
        # the converter no longer takes a refinement level
        r = self.convert(expect_ok=False, args=("--subdivision-level", "2"))
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("usage", r.stderr)

    def test_holes_out_of_range_are_warned_about(self):
        st = self.stage()
        self.cube(st).CreateHoleIndicesAttr([1, 9])
        rss = self.convert(st)
        self.assertEqual(rss.subdivision("/Cube")["holes"], [1])
        self.assertTrue(any("1 holeIndices out of range (6 faces)" in w["message"] for w in rss.warnings_for("/Cube")))


if __name__ == "__main__":
    unittest.main()
