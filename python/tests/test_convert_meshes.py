"""Tests of the USD -> .rss converter: meshes (polygons, holes, subsets, normals, texture coordinates,
winding, implicit gprims; `raysplat_usd_meshes.py`). The harness (running the converter as the Rust
binary does, the .rss reader, stage builders) is in `convert_support.py`."""

from convert_support import *  # noqa: F401,F403


class MeshTests(Case):
    def test_ngon_triangulation_counts_and_shared_vertices(self):
        st = self.stage()
        pts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0), (3, 0, 0), (3, 1, 0), (2.5, 2, 0)]
        # a triangle, a quad, a pentagon: 1 + 2 + 3 triangles
        add_mesh(st, "/M", pts, [3, 4, 5], [0, 1, 2, 1, 4, 5, 2, 4, 6, 7, 8, 5])
        camera(st)
        rss = self.convert(st)
        m = rss.mesh_named("/M")
        self.assertEqual(len(m["indices"]), 6)
        self.assertEqual(len(m["positions"]), 9, "vertex-interpolated data shares vertices")
        self.assertEqual(m["normals"], None)
        self.assertEqual(m["uvs"], None)
        # fan triangulation keeps the winding: all triangles face +Z
        for t in m["indices"]:
            self.assertVec(tri_normal(*[m["positions"][i] for i in t]), (0, 0, 1))
        self.assertEqual(self.result.summary["triangles"], 6)

    def test_hole_faces_are_skipped(self):
        st = self.stage()
        m = add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)], [4, 4],
                     [0, 1, 2, 3, 1, 4, 5, 2])
        m.CreateHoleIndicesAttr([1])
        rss = self.convert(st)
        self.assertEqual(len(rss.mesh_named("/M")["indices"]), 2)

    def test_degenerate_faces_warn(self):
        st = self.stage()
        add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [3, 2], [0, 1, 2, 0, 1])
        rss = self.convert(st)
        self.assertEqual(len(rss.mesh_named("/M")["indices"]), 1)
        self.assertTrue(any("fewer than 3" in w["message"] for w in rss.warnings_for("/M")))

    def test_geomsubset_material_ids_per_triangle(self):
        st = self.stage()
        mesh = add_mesh(st, "/M", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0), (3, 0, 0)],
                        [3, 4, 3, 3], [0, 1, 2, 1, 4, 5, 2, 4, 6, 5, 0, 2, 3])
        red, _ = preview(st, "/Looks/Red", diffuseColor=Gf.Vec3f(1, 0, 0))
        green, _ = preview(st, "/Looks/Green", diffuseColor=Gf.Vec3f(0, 1, 0))
        grey, _ = preview(st, "/Looks/Grey")
        bind(mesh, grey)
        api = UsdShade.MaterialBindingAPI(mesh.GetPrim())
        a = api.CreateMaterialBindSubset("A", Vt.IntArray([0, 2]))
        b = api.CreateMaterialBindSubset("B", Vt.IntArray([1]))
        bind(a, red)
        bind(b, green)
        rss = self.convert(st)
        mats = [m["name"] for m in rss["materials"]]
        m = rss.mesh_named("/M")
        ids = [mats[i] for i in m["material_ids"]]
        # faces: tri(0)=A, quad(1)=B (two triangles), tri(2)=A, tri(3) unassigned -> mesh binding
        self.assertEqual(ids, ["/Looks/Red", "/Looks/Green", "/Looks/Green", "/Looks/Red", "/Looks/Grey"])
        self.assertEqual(rss.material("/Looks/Red")["diffuse_color"]["value"], [1.0, 0.0, 0.0])

    def _normals_mesh(self, interp, values, indices=None, use_attr=False):
        st = self.stage()
        # two quads sharing an edge: points 0..5, faces (0 1 4 3) and (1 2 5 4)
        pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
        m = add_mesh(st, "/M", pts, [4, 4], [0, 1, 4, 3, 1, 2, 5, 4])
        vals = Vt.Vec3fArray([Gf.Vec3f(*v) for v in values])
        if use_attr:
            m.CreateNormalsAttr(vals)
            m.SetNormalsInterpolation(interp)
        else:
            pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray, interp)
            pv.Set(vals)
            if indices is not None:
                pv.SetIndices(Vt.IntArray(indices))
        rss = self.convert(st)
        return rss.mesh_named("/M")

    def corner_normals(self, m):
        """Normals per triangle corner, in triangle order."""
        return [[m["normals"][i] for i in t] for t in m["indices"]]

    def test_normals_constant(self):
        m = self._normals_mesh("constant", [(0, 0, 1)])
        self.assertEqual(len(m["positions"]), 6)
        for tri in self.corner_normals(m):
            for n in tri:
                self.assertVec(n, (0, 0, 1))

    def test_normals_uniform(self):
        m = self._normals_mesh("uniform", [(1, 0, 0), (0, 1, 0)])
        cn = self.corner_normals(m)
        self.assertEqual(len(cn), 4)
        for tri in cn[:2]:
            for n in tri:
                self.assertVec(n, (1, 0, 0))
        for tri in cn[2:]:
            for n in tri:
                self.assertVec(n, (0, 1, 0))
        # the shared edge's points are split: 8 vertices
        self.assertEqual(len(m["positions"]), 8)

    def test_normals_vertex_and_varying(self):
        vals = [(i, 0, 1) for i in range(6)]
        for interp in ("vertex", "varying"):
            m = self._normals_mesh(interp, vals)
            self.assertEqual(len(m["positions"]), 6)
            pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
            for p, n in zip(m["positions"], m["normals"]):
                self.assertVec(n, vals[pts.index(tuple(p))], msg=interp)

    def test_normals_vertex_indexed(self):
        m = self._normals_mesh("vertex", [(0, 0, 1), (0, 1, 0)], indices=[0, 1, 0, 1, 0, 1])
        pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
        for p, n in zip(m["positions"], m["normals"]):
            k = pts.index(tuple(p))
            self.assertVec(n, (0, 0, 1) if k % 2 == 0 else (0, 1, 0))

    def test_normals_facevarying(self):
        vals = [(c, 0, 1) for c in range(8)]  # corner c of the face-vertex list
        m = self._normals_mesh("faceVarying", vals)
        fvi = [0, 1, 4, 3, 1, 2, 5, 4]
        pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
        # every triangle corner carries the normal of its face-vertex
        for t in m["indices"]:
            for i in t:
                c = int(round(m["normals"][i][0]))
                self.assertEqual(tuple(m["positions"][i]), pts[fvi[c]])

    def test_normals_facevarying_indexed_dedupes(self):
        m = self._normals_mesh("faceVarying", [(0, 0, 1), (1, 0, 0)], indices=[0, 0, 0, 0, 1, 1, 1, 1])
        self.assertEqual(len(m["positions"]), 8)  # shared edge split by differing normals
        cn = self.corner_normals(m)
        for tri in cn[:2]:
            for n in tri:
                self.assertVec(n, (0, 0, 1))
        for tri in cn[2:]:
            for n in tri:
                self.assertVec(n, (1, 0, 0))
        m = self._normals_mesh("faceVarying", [(0, 0, 1)], indices=[0] * 8)
        self.assertEqual(len(m["positions"]), 6, "equal face-varying values share vertices")

    def test_normals_attribute_without_primvar(self):
        m = self._normals_mesh("uniform", [(1, 0, 0), (0, 1, 0)], use_attr=True)
        cn = self.corner_normals(m)
        self.assertVec(cn[0][0], (1, 0, 0))
        self.assertVec(cn[3][2], (0, 1, 0))

    def test_bad_primvar_length_warns(self):
        st = self.stage()
        m = quad(st, "/M")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray, "vertex").Set(
            Vt.Vec3fArray([Gf.Vec3f(0, 0, 1)] * 3))
        rss = self.convert(st)
        self.assertIsNone(rss.mesh_named("/M")["normals"])
        self.assertTrue(any("normals" in w["message"] for w in rss.warnings_for("/M")))

    def test_uv_facevarying_indexed_expansion(self):
        st = self.stage()
        pts = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
        m = add_mesh(st, "/M", pts, [4, 4], [0, 1, 4, 3, 1, 2, 5, 4])
        uvs = [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0.5)]
        pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "faceVarying")
        pv.Set(Vt.Vec2fArray([Gf.Vec2f(*u) for u in uvs]))
        # face 0 maps 0..3; face 1 reuses (1,0)->corner of point 1 but (0.5,0.5) elsewhere
        pv.SetIndices(Vt.IntArray([0, 1, 2, 3, 1, 4, 4, 2]))
        rss = self.convert(st)
        mm = rss.mesh_named("/M")
        fvi = [0, 1, 4, 3, 1, 2, 5, 4]
        uvi = [0, 1, 2, 3, 1, 4, 4, 2]
        expected = {}  # (point, uv) pairs that must exist
        for c in range(8):
            expected[(pts[fvi[c]], uvs[uvi[c]])] = True
        got = {(tuple(p), tuple(u)) for p, u in zip(mm["positions"], mm["uvs"])}
        self.assertEqual(got, {(p, tuple(float(x) for x in u)) for p, u in expected})
        # corners (point 1, uv 1) and (point 4, uv 2) are shared by both faces: 8 corners -> 6 vertices
        self.assertEqual(len(mm["positions"]), 6)
        self.assertEqual(len(mm["indices"]), 4)

    def test_uv_vertex_and_uniform(self):
        st = self.stage()
        m = quad(st, "/M")
        pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex")
        pv.Set(Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
        m2 = quad(st, "/U", z=1)
        pv = UsdGeom.PrimvarsAPI(m2).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "uniform")
        pv.Set(Vt.Vec2fArray([Gf.Vec2f(0.25, 0.75)]))
        rss = self.convert(st)
        mm = rss.mesh_named("/M")
        for p, u in zip(mm["positions"], mm["uvs"]):
            self.assertVec(u, (p[0], p[1]))
        for u in rss.mesh_named("/U")["uvs"]:
            self.assertVec(u, (0.25, 0.75))

    def test_uv_primvar_named_by_the_material(self):
        st = self.stage()
        m = quad(st, "/M")
        api = UsdGeom.PrimvarsAPI(m)
        api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(Vt.Vec2fArray([Gf.Vec2f(9, 9)] * 4))
        api.CreatePrimvar("uvmap", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
        (self.dir / "t.png").write_bytes(png_bytes())
        mat, sh = preview(st, "/Looks/T")
        tex = uv_texture(st, "/Looks/T/Tex", "t.png")
        rd = primvar_reader(st, "/Looks/T/Reader", "uvmap")
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(rd.ConnectableAPI(), "result")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        # a second mesh without that primvar: warned, falls back to st
        m2 = quad(st, "/N", z=1)
        UsdGeom.PrimvarsAPI(m2).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(7, 7)] * 4))
        bind(m2, mat)
        rss = self.convert(st)
        mm = rss.mesh_named("/M")
        for p, u in zip(mm["positions"], mm["uvs"]):
            self.assertVec(u, (p[0], p[1]))
        self.assertEqual(rss.mesh_named("/N")["uvs"][0], (7.0, 7.0))
        self.assertTrue(any("uvmap" in w["message"] for w in rss.warnings_for("/N")))

    def test_left_handed_winding_is_flipped(self):
        st = self.stage()
        add_mesh(st, "/R", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
        add_mesh(st, "/L", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2], orientation="leftHanded")
        q = add_mesh(st, "/LQ", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [4], [0, 1, 2, 3], orientation="leftHanded")
        rss = self.convert(st)
        r, l, lq = rss.mesh_named("/R"), rss.mesh_named("/L"), rss.mesh_named("/LQ")
        self.assertVec(tri_normal(*[r["positions"][i] for i in r["indices"][0]]), (0, 0, 1))
        self.assertVec(tri_normal(*[l["positions"][i] for i in l["indices"][0]]), (0, 0, -1))
        for t in lq["indices"]:
            self.assertVec(tri_normal(*[lq["positions"][i] for i in t]), (0, 0, -1))

    def test_double_sided(self):
        st = self.stage()
        quad(st, "/S")
        quad(st, "/D", z=1).CreateDoubleSidedAttr(True)
        rss = self.convert(st)
        self.assertFalse(rss.mesh_named("/S")["double_sided"])
        self.assertTrue(rss.mesh_named("/D")["double_sided"])

    def test_nan_points_still_convert(self):
        st = self.stage()
        add_mesh(st, "/Tri", [(0, 0, 0), (1, 0, 0), (0, float("nan"), 0)], [3], [0, 1, 2])
        rss = self.convert(st)
        p = rss.mesh_named("/Tri")["positions"]
        self.assertTrue(math.isnan(p[2][1]))

    def test_out_of_range_index_is_exit_2(self):
        st = self.stage()
        add_mesh(st, "/Tri", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 7])
        st.GetRootLayer().Save()
        r = self.convert(expect_ok=False)
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("/Tri", r.stderr)
        self.assertIn(str(self.path), r.stderr)
        self.assertFalse(r.out.exists())

    def test_gprims_are_tessellated(self):
        st = self.stage()
        c = UsdGeom.Cube.Define(st, "/Cube")
        c.CreateSizeAttr(2.0)
        s = UsdGeom.Sphere.Define(st, "/Sphere")
        s.CreateRadiusAttr(0.5)
        cy = UsdGeom.Cylinder.Define(st, "/Cyl")
        cy.CreateAxisAttr("Y")
        UsdGeom.Cone.Define(st, "/Cone")
        UsdGeom.Capsule.Define(st, "/Capsule")
        UsdGeom.Plane.Define(st, "/Plane")
        UsdVol.Volume.Define(st, "/Curves")
        UsdGeom.BasisCurves.Define(st, "/Empty")
        rss = self.convert(st)
        cube = rss.mesh_named("/Cube")
        self.assertEqual(len(cube["indices"]), 12)
        for k in range(3):
            self.assertAlmostEqual(max(p[k] for p in cube["positions"]), 1.0)
            self.assertAlmostEqual(min(p[k] for p in cube["positions"]), -1.0)
        for t in cube["indices"]:  # outward winding
            a, b, cc = [cube["positions"][i] for i in t]
            n = tri_normal(a, b, cc)
            centre = [(a[i] + b[i] + cc[i]) / 3 for i in range(3)]
            self.assertGreater(sum(n[i] * centre[i] for i in range(3)), 0)
        sph = rss.mesh_named("/Sphere")
        for p in sph["positions"]:
            self.assertAlmostEqual(math.sqrt(sum(x * x for x in p)), 0.5, places=5)
        for t in sph["indices"]:
            a, b, cc = [sph["positions"][i] for i in t]
            n = tri_normal(a, b, cc)
            centre = [(a[i] + b[i] + cc[i]) / 3 for i in range(3)]
            self.assertGreater(sum(n[i] * centre[i] for i in range(3)), 0)
        cyl = rss.mesh_named("/Cyl")
        self.assertAlmostEqual(max(p[1] for p in cyl["positions"]), 1.0)  # height 2 along Y
        self.assertAlmostEqual(max(p[0] for p in cyl["positions"]), 1.0)
        for name in ("/Cone", "/Capsule", "/Plane"):
            self.assertGreater(len(rss.mesh_named(name)["indices"]), 1)
        self.assertTrue(any("not supported" in w["message"] for w in rss.warnings_for("/Curves")))
        self.assertTrue(any("has no points" in w["message"] for w in rss.warnings_for("/Empty")))


    def test_numpy_and_pure_python_paths_write_the_same_bytes(self):
        # triangulation, face-varying expansion and gathering run with numpy when it is there and
        # in pure Python otherwise (RAYSPLAT_NO_NUMPY): the same scene either way, byte for byte,
        # on meshes of triangles, quads and n-gons, holes, a leftHanded one, degenerate faces,
        # indexed face-varying normals and uvs, uniform uvs and vertex normals
        try:
            import numpy  # noqa: F401
        except ImportError:
            self.skipTest("numpy is not installed: only the pure-Python path exists")
        st = self.stage()
        n = 9
        pts = [(x, 0.1 * ((x * 7 + y * 3) % 5), y) for y in range(n + 1) for x in range(n + 1)]
        counts, idx = [], []
        for y in range(n):
            for x in range(n):
                q = [y * (n + 1) + x, (y + 1) * (n + 1) + x, (y + 1) * (n + 1) + x + 1, y * (n + 1) + x + 1]
                if (x + y) % 3 == 0:
                    counts += [3, 3]
                    idx += [q[0], q[1], q[2], q[0], q[2], q[3]]
                else:
                    counts.append(4)
                    idx += q
        counts += [5, 2]
        idx += [0, 1, 2, 3, 4, 5, 6]
        for name, left in (("/Right", False), ("/Left", True)):
            m = add_mesh(st, name, pts, counts, idx, **({"orientation": "leftHanded"} if left else {}))
            m.CreateHoleIndicesAttr([4, 17])
            api = UsdGeom.PrimvarsAPI(m)
            uv = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
            uv.Set(Vt.Vec2fArray([Gf.Vec2f(k % 7, k % 5) for k in range(31)]))
            uv.SetIndices(Vt.IntArray([(k * 13) % 31 for k in range(len(idx))]))
            nr = api.CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray, UsdGeom.Tokens.faceVarying)
            nr.Set(Vt.Vec3fArray([Gf.Vec3f(0, 1, 0), Gf.Vec3f(0, 0.8, 0.6)]))
            nr.SetIndices(Vt.IntArray([k % 2 for k in range(len(idx))]))
        u = add_mesh(st, "/Uniform", pts, counts[:-2], idx[:-7])
        UsdGeom.PrimvarsAPI(u).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.uniform).Set(
            Vt.Vec2fArray([Gf.Vec2f(f, 0) for f in range(len(counts) - 2)]))
        # points become spheres: per-point widths and colours, and constant ones
        for name, interp, k in (("/Dots", UsdGeom.Tokens.vertex, 7), ("/Dot", UsdGeom.Tokens.constant, 1)):
            dots = UsdGeom.Points.Define(st, name)
            dots.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(0.3 * i, 0.1 * i * i, -0.7 * i) for i in range(7)]))
            dots.CreateWidthsAttr(Vt.FloatArray([0.05 + 0.01 * i for i in range(k)]))
            dots.SetWidthsInterpolation(interp)
            dots.CreateDisplayColorPrimvar(interp).Set(Vt.Vec3fArray([Gf.Vec3f(0.1 * i, 0.5, 1 - 0.1 * i)
                                                                     for i in range(k)]))
        st.GetRootLayer().Save()
        outs = []
        for env in ({}, {"RAYSPLAT_NO_NUMPY": "1"}):
            out = self.dir / ("out%d.rss" % len(outs))
            proc = subprocess.run([sys.executable, str(HERE.parent / "raysplat_usd.py"), str(self.path), str(out)],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, env={**os.environ, **env}, timeout=600)
            self.assertEqual(proc.returncode, 0, proc.stderr.decode("utf-8", "replace"))
            outs.append(out.read_bytes())
        self.assertEqual(outs[0], outs[1])
        rss = Rss(self.dir / "out0.rss")
        self.assertEqual(len(rss.mesh_named("/Left")["indices"]), len(rss.mesh_named("/Right")["indices"]))
        self.assertEqual(len(rss.mesh_named("/Dots")["colors"]), 7 * 42)
        self.assertEqual(len(rss.mesh_named("/Dot")["indices"]), 7 * 80)

if __name__ == "__main__":
    unittest.main()
