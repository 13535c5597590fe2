"""Tests of the USD -> .rss converter: the converter run as files, the repository's scenes and the
shared real scenes. The harness (running the converter as the Rust binary does, the .rss reader,
stage builders) is in `convert_support.py`."""

from convert_support import *  # noqa: F401,F403


def shared_entries():
    """(entry file, documented triangle count) from ../shared/scenes/README.md."""
    readme = SHARED / "README.md"
    out = []
    for line in readme.read_text().splitlines():
        if not line.startswith("| `"):
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        files = re.findall(r"`([^`]+\.usd[acz]?)`", cells[0])
        counts = [int(x.replace(",", "")) for x in re.findall(r"[\d,]+", cells[3])]
        base = os.path.dirname(files[0])
        files = [f if "/" in f else os.path.join(base, f) for f in files]
        out.extend(zip(files, counts))
    return out


class RunAsFilesTests(Case):
    def test_run_as_files_writes_the_same_scene(self):
        """`python3 raysplat_usd.py IN OUT` (the parts importing each other) writes the bytes the
        concatenated text the Rust binary pipes to Python writes: a textured subdivision surface, a
        sphere and a distant light, and the repository's glossy Cornell box."""
        st = self.stage()
        m = add_mesh(st, "/Cube", [(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)], [4] * 6,
                     [0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5], scheme="catmullClark")
        UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, "vertex").Set(
            Vt.Vec2fArray([Gf.Vec2f(x, y) for _ in (0, 1) for y in (0, 1) for x in (0, 1)]))
        (self.dir / "t.png").write_bytes(png_bytes(rgb=(40, 200, 90)))
        mat, sh = preview(st, "/Looks/T", roughness=0.3)
        tex = uv_texture(st, "/Looks/T/Tex", "t.png")
        sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
        bind(m, mat)
        UsdLux.SphereLight.Define(st, "/Lamp").CreateRadiusAttr(0.2)
        UsdLux.DistantLight.Define(st, "/Sun")
        camera(st)
        self.convert(st)
        piped = self.dir / "out.rss"
        for inp, ref in ((self.path, piped), (REPO / "scenes" / "cornell-glossy.usda", None)):
            if ref is None:
                ref = self.dir / "glossy-piped.rss"
                r = convert(inp, ref, extra=())
                self.assertEqual(r.rc, 0, r.stderr)
            files = self.dir / "files.rss"
            proc = subprocess.run([sys.executable, str(HERE.parent / "raysplat_usd.py"), str(inp), str(files)],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=str(self.dir), timeout=600)
            self.assertEqual(proc.returncode, 0, proc.stderr.decode("utf-8", "replace"))
            self.assertEqual(files.read_bytes(), ref.read_bytes(), inp)


class RepoSceneTests(unittest.TestCase):
    def test_scenes_are_reproducible_and_convert(self):
        with tempfile.TemporaryDirectory() as d:
            proc = subprocess.run([sys.executable, str(REPO / "scripts" / "make_scenes.py"), d],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            self.assertEqual(proc.returncode, 0, proc.stderr.decode())
            names = sorted(p.name for p in Path(d).glob("*.usda"))
            self.assertEqual(names, ["bumpy-box.usda", "concave-corners.usda", "cornell-box.usda",
                                     "cornell-glossy.usda", "furnace.usda", "plane-distant.usda", "plane-rect.usda",
                                     "secondary-light.usda"])
            for name in names:
                committed = REPO / "scenes" / name
                self.assertTrue(committed.exists(), "scenes/%s is missing: run make scenes" % name)
                self.assertEqual(committed.read_text(), (Path(d) / name).read_text(),
                                 "scenes/%s is stale: run scripts/make_scenes.py" % name)
                out = Path(d) / (name + ".rss")
                r = convert(committed, out)
                self.assertEqual(r.rc, 0, r.stderr)
                rss = Rss(out)
                self.assertEqual(rss["warnings"], [], name)
                self.assertIsNotNone(rss["camera"])
                self.assertIsNotNone(rss["resolution"])

    def test_cornell_box_contents(self):
        with tempfile.TemporaryDirectory() as d:
            out = Path(d) / "cb.rss"
            r = convert(REPO / "scenes" / "cornell-box.usda", out)
            self.assertEqual(r.rc, 0, r.stderr)
            rss = Rss(out)
            self.assertEqual(rss["resolution"], [256, 256])
            self.assertEqual(rss.triangles(), 30)
            light = rss["lights"][0]
            self.assertEqual(light["type"], "rect")
            down = [-x for x in light["transform"][2][:3]]
            for a, b in zip(down, (0, -1, 0)):
                self.assertAlmostEqual(a, b, places=6)
            for a, b in zip(light["radiance"], (17, 12, 4)):
                self.assertAlmostEqual(a, b, places=5)
            kinds = {m["name"]: m["diffuse_color"]["value"] for m in rss["materials"]}
            self.assertEqual(sorted(kinds), ["/World/Looks/Green", "/World/Looks/Red", "/World/Looks/White"])

    def test_analytic_expectations(self):
        stage = Usd.Stage.Open(str(REPO / "scenes" / "plane-rect.usda"))
        e = stage.GetRootLayer().customLayerData["raysplat:expected"]
        x = 0.5 * e["side"] / e["distance"]
        f = 2 * x / math.sqrt(1 + x * x) * math.atan(x / math.sqrt(1 + x * x)) / (2 * math.pi)
        self.assertAlmostEqual(e["irradiance"], math.pi * e["light_radiance"] * 4 * f, places=9)
        self.assertAlmostEqual(e["pixel_radiance"], e["albedo"] * e["irradiance"] / math.pi, places=9)
        stage = Usd.Stage.Open(str(REPO / "scenes" / "furnace.usda"))
        self.assertAlmostEqual(stage.GetRootLayer().customLayerData["raysplat:expected"]["pixel_radiance"], 2.0)
        stage = Usd.Stage.Open(str(REPO / "scenes" / "plane-distant.usda"))
        e = stage.GetRootLayer().customLayerData["raysplat:expected"]
        self.assertAlmostEqual(e["pixel_radiance"], 0.6 * 3 * math.cos(math.radians(30)) / math.pi, places=9)


@unittest.skipUnless((SHARED / "README.md").exists(), "shared scenes not present (%s)" % SHARED)
class SharedSceneTests(unittest.TestCase):
    def test_every_entry_converts_with_the_documented_triangle_count(self):
        entries = shared_entries()
        self.assertGreaterEqual(len(entries), 7)
        with tempfile.TemporaryDirectory() as d:
            for entry, tris in entries:
                with self.subTest(entry=entry):
                    out = Path(d) / (Path(entry).stem + ".rss")
                    t0 = time.time()
                    # (subdivision surfaces are written as their cages: counted as polygons, the
                    # documented counts)
                    r = convert(SHARED / entry, out, extra=())
                    dt = time.time() - t0
                    self.assertEqual(r.rc, 0, r.stderr)
                    self.assertNotIn("Traceback", r.stderr)
                    rss = Rss(out)
                    print("\n%s: %.2fs, %d triangles, %d meshes, %d instances, %d materials, %d lights, %d warnings"
                          % (entry, dt, rss.triangles(), len(rss["meshes"]), len(rss["instances"]),
                             len(rss["materials"]), len(rss["lights"]), len(rss["warnings"])), file=sys.stderr)
                    for w in rss["warnings"]:
                        print("    warning: %s: %s" % (w["prim"], w["message"][:200]), file=sys.stderr)
                    self.assertEqual(rss.triangles(), tris)
                    self.assertIsNotNone(rss["camera"])
                    self.assertTrue(rss["lights"])
                    if "sponza" in entry:
                        # (its conversion time is a benchmark: `raysplat-bench load`, `make bench`)
                        self.assertEqual(len(rss["meshes"]), 381)


if __name__ == "__main__":
    unittest.main()
