"""The converter against hostile input: crate files whose counts claim more than they hold are
refused before usd-core allocates (raysplat_crate.py), naming the prim; a valid crate file passes
the check and its paths decode as usd-core reads them; the memory limit turns exhaustion into one
clear error line; no failure prints a traceback."""

import struct
import sys
import unittest

from convert_support import HERE, Case, add_mesh, camera, convert, quad
from pxr import Sdf, Usd, UsdGeom, UsdLux, Vt

sys.path.insert(0, str(HERE.parent))
import raysplat_crate  # noqa: E402


def crate_paths(data):
    """The spec paths check_crate visits (those with fields), by spying on its value check."""
    seen = set()
    orig = raysplat_crate._check_value

    def spy(d, rep, header, where, depth=0):
        if depth == 0:
            seen.add(where()[1].split(" of ", 1)[1])
        return orig(d, rep, header, where, depth)

    raysplat_crate._check_value = spy
    try:
        raysplat_crate.check_crate(data)
    finally:
        raysplat_crate._check_value = orig
    return seen


class CrateChecks(Case):
    def rich_crate(self):
        """A crate file with compressed arrays, time samples of arrays, list ops, dictionaries,
        variants and relationships."""
        path = self.dir / "rich.usdc"
        st = Usd.Stage.CreateNew(str(path))
        UsdGeom.SetStageMetersPerUnit(st, 1.0)
        n = 40
        pts = [(i % 7, i // 7, (i * 13) % 5) for i in range(n * n)]
        counts = [3] * (len(pts) // 3)
        idx = list(range(len(counts) * 3))
        m = add_mesh(st, "/World/Big", pts, counts, idx)
        m.GetPrim().SetCustomDataByKey("note", "hello")
        m.GetPointsAttr().Set(Vt.Vec3fArray(pts[:30]), 2.0)
        m.GetPointsAttr().Set(Vt.Vec3fArray(pts[:60]), 3.0)
        vs = m.GetPrim().GetVariantSets().AddVariantSet("look")
        for v in ("a", "b"):
            vs.AddVariant(v)
        vs.SetVariantSelection("a")
        with vs.GetVariantEditContext():
            UsdGeom.Xform.Define(st, "/World/Big/Inside")
        UsdLux.SphereLight.Define(st, "/World/L")
        m.GetPrim().CreateRelationship("rel").AddTarget("/World/L")
        m.GetPrim().CreateAttribute("ints", Sdf.ValueTypeNames.IntArray).Set(list(range(5000)))
        m.GetPrim().CreateAttribute("floats", Sdf.ValueTypeNames.FloatArray).Set([float(i % 10) for i in range(5000)])
        st.GetRootLayer().Save()
        return path

    def test_valid_crate_files_pass_and_their_paths_decode_as_usd_reads_them(self):
        path = self.rich_crate()
        seen = crate_paths(path.read_bytes())
        layer = Sdf.Layer.FindOrOpen(str(path))
        want = set()
        layer.Traverse("/", lambda p: want.add(str(p)))
        # every spec with fields (relationship target specs and an empty variant have none)
        with_fields = {p for p in want if p != "/" and "[" not in p and not p.endswith("{look=b}")}
        self.assertTrue(with_fields, want)
        self.assertEqual(with_fields - seen, set())
        self.assertEqual(seen - want, set())

    def tri(self):
        path = self.dir / "tri.usdc"
        st = Usd.Stage.CreateNew(str(path))
        add_mesh(st, "/World/Tri", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [3], [0, 1, 2])
        UsdLux.DistantLight.Define(st, "/Sun")
        st.GetRootLayer().Save()
        return path.read_bytes()

    def test_counts_the_file_cannot_hold_are_refused_naming_the_prim(self):
        data = self.tri()
        # every 4-byte word of the file patched to 2^30 in turn: the check refuses it (naming the
        # prim whose field holds it, when it is a value's count) or lets it pass, nothing else
        flagged, passed = {}, []
        for off in range(0, len(data) - 4, 4):
            b = bytearray(data)
            b[off:off + 4] = struct.pack("<I", 1 << 30)
            try:
                raysplat_crate.check_crate(bytes(b))
                passed.append(off)
            except raysplat_crate.CrateError as e:
                flagged.setdefault(e.prim, off)
        self.assertTrue({"-", "/", "/World", "/World/Tri"} <= set(flagged), flagged)
        # through the converter, under a memory limit only a count that escaped the check would
        # reach: one error line naming the file and the prim (or a conversion), never a traceback
        for off in sorted(flagged.values()) + passed[::8]:
            b = bytearray(data)
            b[off:off + 4] = struct.pack("<I", 1 << 30)
            p = self.dir / ("c%d.usdc" % off)
            p.write_bytes(bytes(b))
            r = convert(p, self.dir / "out.rss", extra=("--memory-limit", str(1 << 30)))
            self.assertNotIn("Traceback", r.stderr, off)
            self.assertNotIn("out of memory", r.stderr, "offset %d escaped the check: %s" % (off, r.stderr))
            if r.rc != 0:
                self.assertEqual(r.rc, 2, r.stderr)
                line = [l for l in r.stderr.splitlines() if l.startswith("error: ")]
                self.assertEqual(len(line), 1, r.stderr)
                self.assertTrue(line[0].startswith("error: %s: " % p), line[0])
            if off in flagged.values():
                self.assertIn("the crate file declares", r.stderr)


class Limits(Case):
    def test_memory_running_out_is_one_error_line(self):
        # 199 000 points become spheres of 20 triangles each (just under the tessellation cap):
        # more than a 250 MiB data segment holds beside usd-core, which itself fits; as a text
        # layer the stage cannot even be opened in it
        import numpy as np
        st = self.stage("scene.usdc")
        cloud = UsdGeom.Points.Define(st, "/Cloud")
        n = 199_000
        cloud.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.random.default_rng(1).random((n, 3)).astype(np.float32)))
        cloud.CreateWidthsAttr(Vt.FloatArray([0.01] * n))
        camera(st)
        r = self.convert(st, expect_ok=False, args=("--memory-limit", str(250 << 20)))
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertNotIn("Traceback", r.stderr)
        self.assertIn("out of memory", r.stderr)
        self.assertIn("/Cloud", r.stderr)
        text = self.stage()
        text.GetRootLayer().TransferContent(st.GetRootLayer())
        r = self.convert(text, expect_ok=False, args=("--memory-limit", str(250 << 20)))
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertIn("out of memory opening the stage", r.stderr)

    def test_an_unexpected_failure_is_one_line_naming_the_prim(self):
        st = self.stage()
        quad(st, "/M")
        camera(st)
        st.GetRootLayer().Save()
        # the output's directory is a file: the converter's write fails inside Python
        blocker = self.dir / "blocker"
        blocker.write_bytes(b"x")
        r = convert(self.path, blocker / "out.rss")
        self.assertEqual(r.rc, 2, r.stderr)
        self.assertNotIn("Traceback", r.stderr)
        self.assertTrue(r.stderr.strip().splitlines()[-1].startswith("error: %s: " % self.path), r.stderr)

    def test_internal_references_pass_the_layer_check(self):
        # an internal reference (`references = </A>`) is a composition dependency with an empty
        # asset path: the layer check must pass it over, not fail on it
        st = self.stage()
        quad(st, "/A")
        UsdGeom.Xform.Define(st, "/B").GetPrim().GetReferences().AddInternalReference("/A")
        camera(st)
        self.convert(st)  # exit 0


if __name__ == "__main__":
    unittest.main()
