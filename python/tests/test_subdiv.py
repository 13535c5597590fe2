"""Tests of the subdivision refinement itself (python/raysplat_subdiv.py), without a stage: the
schemes' rules at one level, and the limit masks against refinement carried much further.

Run with `python3 -m unittest discover -s python/tests -v` (standard library only).
"""

import math
import sys
import unittest
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from raysplat_subdiv import Refinement  # noqa: E402

# A cube of side 2 about the origin, faces outward.
CUBE_PTS = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
CUBE_IDX = [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3]
# A regular tetrahedron about the origin.
TET_PTS = [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]
TET_IDX = [0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2]


def flat(points):
    return [float(c) for p in points for c in p]


def point(data, i):
    return tuple(data[3 * i:3 * i + 3])


def bumpy_grid(n=4):
    """An n × n grid of quads over [0, n]², its heights bumpy: (points, counts, indices)."""
    m = n + 1
    pts = [(x, y, 0.3 * math.sin(1.7 * x + 0.9 * y) + 0.05 * x * y) for y in range(m) for x in range(m)]
    quads = [(y * m + x, y * m + x + 1, (y + 1) * m + x + 1, (y + 1) * m + x) for y in range(n) for x in range(n)]
    return pts, [4] * len(quads), [i for q in quads for i in q]


def tags(n=4):
    """Subdivision tags of `bumpy_grid(n)`: an infinitely sharp crease along x = 2 (which ends on
    the boundary) and an infinitely sharp interior corner."""
    m = n + 1
    crease = {(y * m + 2, (y + 1) * m + 2): 100.0 for y in range(n)}
    return crease, {m + 1: 100.0}


def brute_force_limit(ref, boundary):
    """The limit stencils of `ref`'s refined mesh built from that mesh's own topology (`_topology`
    and the tags `_level` would read there): the oracle for `Refinement._limit`, which derives
    them from the last level's input."""
    sharp, corner = ref.tags
    offs, edges, _, edge_faces, _, edge_sharp, vert_edges, vert_faces = ref._topology(sharp)
    loop, fvi = ref.scheme == "loop", ref.fvi
    out = []
    for v in range(ref.npts):
        ve, vf = vert_edges[v], vert_faces[v]
        n = len(ve)
        creased, vs = ref._vertex_tags(v, ve, vf, edge_faces, edge_sharp, corner, boundary)
        nc = len(creased)
        ring = [b if a == v else a for a, b in (edges[e] for e in ve)]
        smooth = [(v, 1.0)]
        if n >= 3 and len(vf) == n and nc <= 2:
            if loop:
                beta = (0.625 - (0.375 + 0.25 * math.cos(2 * math.pi / n)) ** 2) / n
                chi = 1.0 / (3.0 / (8.0 * beta) + n)
                smooth = [(v, 1.0 - n * chi)] + [(x, chi) for x in ring]
            else:
                w = 1.0 / (n * (n + 5.0))
                diag = [fvi[offs[f] + (fvi.index(v, offs[f], offs[f] + 4) - offs[f] + 2) % 4] for f in vf]
                smooth = [(v, n * n * w)] + [(x, 4.0 * w) for x in ring] + [(x, w) for x in diag]
        if n == 0 or nc > 2:
            rule = [(v, 1.0)]
        elif nc < 2:
            rule = smooth
        else:
            a, b = (x for e, x in zip(ve, ring) if e in creased)
            rule = [(v, 4.0 / 6.0), (a, 1.0 / 6.0), (b, 1.0 / 6.0)]
            s = (min(edge_sharp[creased[0]], 1.0) + min(edge_sharp[creased[1]], 1.0)) / 2.0
            if s < 1.0:
                rule = [(i, w * (1.0 - s)) for i, w in smooth] + [(i, w * s) for i, w in rule]
        if vs > 0.0:
            t = min(vs, 1.0)
            rule = [(i, w * (1.0 - t)) for i, w in rule] + [(v, t)]
        out.append(rule)
    return out


def area_normals(ref, points):
    """Area-weighted (Newell) vertex normals of `ref`'s refined mesh at `points`."""
    acc = [[0.0, 0.0, 0.0] for _ in range(ref.npts)]
    off = 0
    for n in ref.fvc:
        vs = ref.fvi[off:off + n]
        off += n
        x = y = z = 0.0
        for k in range(n):
            (ax, ay, az), (bx, by, bz) = point(points, vs[k]), point(points, vs[(k + 1) % n])
            x, y, z = x + (ay - by) * (az + bz), y + (az - bz) * (ax + bx), z + (ax - bx) * (ay + by)
        for v in vs:
            acc[v] = [acc[v][0] + x, acc[v][1] + y, acc[v][2] + z]
    return [[c / math.sqrt(sum(d * d for d in a)) for c in a] for a in acc]


def angle(a, b):
    """Degrees between unit vectors."""
    return math.degrees(math.acos(max(-1.0, min(1.0, sum(x * y for x, y in zip(a, b))))))


def as_weights(stencil):
    """A stencil as {index: summed weight} (the order and the splitting of terms aside)."""
    out = {}
    for i, w in stencil:
        out[i] = out.get(i, 0.0) + w
    return {i: w for i, w in out.items() if abs(w) > 1e-15}


class RuleTests(unittest.TestCase):
    def test_catmull_clark_rules_at_one_level(self):
        # face points at the face centres, edge points (v0 + v1 + f0 + f1)/4, a corner of valence 3
        # at (Q + 2R)/3 = 5/9 of it
        r = Refinement(8, [4] * 6, CUBE_IDX, 1)
        p = r.points(flat(CUBE_PTS), 3)
        pts = {tuple(round(c, 9) for c in point(p, i)) for i in range(r.npts)}
        self.assertEqual(len(pts), 8 + 12 + 6)
        self.assertIn((1.0, 0.0, 0.0), pts)
        self.assertIn((0.75, 0.75, 0.0), pts)
        self.assertIn((round(5 / 9, 9),) * 3, pts)

    def test_loop_rule_at_one_level(self):
        # Loop's vertex rule at valence 3 (beta = 3/16): a tip moves to (1 - 9/16) v + 3/16 (sum of
        # the others) = v / 4
        r = Refinement(4, [3] * 4, TET_IDX, 1, "loop")
        for c in point(r.points(flat(TET_PTS), 3), 0):
            self.assertAlmostEqual(c, 0.25, places=12)


    def test_faces_no_rule_covers_are_refused(self):
        for scheme, fvc, fvi in (("loop", [3, 3], [0, 1, 2, 1, 1, 3]), ("catmullClark", [4], [0, 1, 1, 2])):
            with self.assertRaisesRegex(ValueError, "names a vertex twice"):
                Refinement(4, fvc, fvi, 1, scheme)
        for fvc, fvi in (([4, 0], [0, 1, 2, 3]), ([2], [0, 1])):
            with self.assertRaisesRegex(ValueError, "fewer than 3 vertices"):
                Refinement(4, fvc, fvi, 1, "bilinear")


class LimitTests(unittest.TestCase):
    def test_cage_corners_have_their_analytic_limits(self):
        # Catmull-Clark, a cube's corner (valence 3): (9 v + 4 Σ e + Σ d) / 24 = v / 2;
        # Loop, a tetrahedron's tip (valence 3, χ = 1/5): (1 - 3/5) v + (Σ e) / 5 = v / 5;
        # the same at every level, and the refined points without the projection are not there
        for levels in (1, 2, 3):
            cc = Refinement(8, [4] * 6, CUBE_IDX, levels)
            lp = Refinement(4, [3] * 4, TET_IDX, levels, "loop")
            for ref, pts, scale in ((cc, CUBE_PTS, 0.5), (lp, TET_PTS, 0.2)):
                lim, raw = ref.points(flat(pts), 3, limit=True), ref.points(flat(pts), 3)
                for i, v in enumerate(pts):
                    for c, x in zip(point(lim, i), v):
                        self.assertAlmostEqual(c, scale * x, places=12)
                    self.assertGreater(math.dist(point(raw, i), [scale * x for x in v]), 1e-4)

    def test_limit_masks_equal_those_of_the_refined_mesh_itself(self):
        # `_limit` reads each refined point's neighbourhood off the last level's input; the masks
        # built from the refined mesh's own topology must be the same, for every rule: smooth
        # points of every valence, darts, creases (infinite, semi-sharp left over, blended),
        # corners (tagged, semi-sharp, edgeAndCorner's single-face corners), boundaries, holes'
        # neighbours, n-gons, a non-manifold edge
        pts, counts, idx = bumpy_grid(4)
        crease = {(2, 7): 100.0, (7, 12): 1.5, (12, 17): 2.4, (17, 22): 0.6, (6, 7): 1.2}
        corner = {6: 1.3, 18: 100.0, 16: 0.4}
        tris = [i for k in range(0, len(idx), 4) for i in (idx[k], idx[k + 1], idx[k + 2], idx[k], idx[k + 2], idx[k + 3])]
        # a pentagon and a triangle beside the grid, and a fin on the edge (0, 1): non-manifold
        more_pts = pts + [(-1.0, 0.5, 0.2), (-1.5, 2.0, 0.0), (-0.8, 3.5, 0.1), (0.5, -1.0, 0.5)]
        fin = len(pts) + 3
        ngons = (counts + [5, 3], idx + [0, 5, 10, len(pts) + 2, len(pts) + 1, 0, len(pts) + 1, len(pts)])
        cases = [("catmullClark", pts, counts, idx, "edgeAndCorner", crease, corner),
                 ("catmullClark", pts, counts, idx, "edgeOnly", crease, corner),
                 ("catmullClark", more_pts, ngons[0] + [3], ngons[1] + [0, 1, fin], "edgeAndCorner", crease, corner),
                 ("loop", pts, [3] * (len(tris) // 3), tris, "edgeAndCorner", crease, corner),
                 ("loop", more_pts, [3] * (len(tris) // 3 + 1), tris + [0, 1, fin], "edgeOnly", crease, corner)]
        for scheme, p, fvc, fvi, boundary, cr, co in cases:
            for levels in (1, 2):
                ref = Refinement(len(p), fvc, fvi, levels, scheme, boundary, cr, co)
                ref.points(flat(p), 3, limit=True)
                got, want = ref._limit_stencils, brute_force_limit(ref, boundary)
                self.assertEqual(len(got), len(want))
                for i, (g, w) in enumerate(zip(got, want)):
                    g, w = as_weights(g), as_weights(w)
                    self.assertEqual(set(g), set(w), (scheme, boundary, levels, i))
                    for k in g:
                        self.assertAlmostEqual(g[k], w[k], places=12, msg=(scheme, boundary, levels, i))

    def test_limit_is_where_further_refinement_converges(self):
        # every refined point's limit position against the same point refined five levels more
        # (the refinement converges to the limit as 4^-levels): boundaries (both interpolateBoundary
        # rules), an infinitely sharp crease and corner, Catmull-Clark and Loop
        pts, counts, idx = bumpy_grid()
        tris = [i for k in range(0, len(idx), 4) for i in (idx[k], idx[k + 1], idx[k + 2], idx[k], idx[k + 2], idx[k + 3])]
        crease, corner = tags()
        cases = [("catmullClark", counts, idx, "edgeAndCorner", crease, corner),
                 ("catmullClark", counts, idx, "edgeOnly", {}, {}),
                 ("loop", [3] * (len(tris) // 3), tris, "edgeAndCorner", crease, corner)]
        for scheme, fvc, fvi, boundary, cr, co in cases:
            ref = Refinement(len(pts), fvc, fvi, 1, scheme, boundary, cr, co)
            deep = Refinement(len(pts), fvc, fvi, 6, scheme, boundary, cr, co)
            lim, far, raw = ref.points(flat(pts), 3, limit=True), deep.points(flat(pts), 3), ref.points(flat(pts), 3)
            worst = max(math.dist(point(lim, i), point(far, i)) for i in range(ref.npts))
            before = max(math.dist(point(raw, i), point(far, i)) for i in range(ref.npts))
            self.assertLess(worst, 3e-4, (scheme, boundary))
            self.assertGreater(before, 30 * worst, (scheme, boundary))
            # the sharp corner and the crease's ends on the boundary stay put
            if co:
                self.assertEqual(point(lim, 6), tuple(float(c) for c in pts[6]))
                self.assertEqual(point(lim, 2), tuple(float(c) for c in pts[2]))

    def test_limit_positions_do_not_depend_on_the_level(self):
        # a point's limit is a point of the surface: the cage's points (which keep their indices
        # at every level) and the level-1 points land on the same place from levels 1, 2 and 3
        # (a crease across the grid, from boundary to boundary, and a corner; a dart, where a crease
        # ends inside the surface, takes the smooth mask and is not exact)
        pts, counts, idx = bumpy_grid(3)
        crease, corner = {(1, 5): 100.0, (5, 9): 100.0, (9, 13): 100.0}, {10: 100.0}
        levels = [Refinement(len(pts), counts, idx, k, "catmullClark", "edgeAndCorner", crease, corner) for k in (1, 2, 3)]
        lims = [r.points(flat(pts), 3, limit=True) for r in levels]
        for lim in lims[1:]:
            for i in range(levels[0].npts):
                for a, b in zip(point(lims[0], i), point(lim, i)):
                    self.assertAlmostEqual(a, b, places=9)

    def test_limit_normals_are_those_of_the_limit_surface(self):
        # the tangent masks' normals at smooth points against the area-weighted normals of the
        # limit points six levels deeper (within 0.02°; the area-weighted normals of the level's
        # own limit points are off by tenths of a degree to degrees); creases, corners and the
        # boundary get none
        pts, counts, idx = bumpy_grid(3)
        tris = [i for k in range(0, len(idx), 4) for i in (idx[k], idx[k + 1], idx[k + 2], idx[k], idx[k + 2], idx[k + 3])]
        crease, corner = {(1, 5): 100.0, (5, 9): 100.0, (9, 13): 100.0}, {10: 100.0}
        for scheme, fvc, fvi in (("catmullClark", counts, idx), ("loop", [3] * (len(tris) // 3), tris),
                                 ("catmullClark", [4] * 6, CUBE_IDX)):
            p = pts if len(fvc) != 6 else CUBE_PTS
            tags = (crease, corner) if len(fvc) != 6 else ({}, {})
            ref = Refinement(len(p), fvc, fvi, 1, scheme, "edgeAndCorner", *tags)
            deep = Refinement(len(p), fvc, fvi, 5, scheme, "edgeAndCorner", *tags)
            want = area_normals(deep, deep.points(flat(p), 3, limit=True))
            raw = ref.points(flat(p), 3)
            got, approx = ref.limit_normals(raw), area_normals(ref, ref.project(raw, 3))
            smooth = [i for i in range(ref.npts) if got[i] is not None]
            self.assertGreater(len(smooth), ref.npts // 3, scheme)
            worst = max(angle(got[i], want[i]) for i in smooth)
            before = max(angle(approx[i], want[i]) for i in smooth)
            self.assertLess(worst, 0.02, scheme)
            if len(fvc) != 6:  # (the cube's level-1 points lie on its symmetry planes)
                self.assertGreater(before, 0.5, scheme)
                for v in (1, 5, 9, 13, 10, 0, 4):  # the crease, the corner, the boundary
                    self.assertIsNone(got[v], (scheme, v))

    def test_face_varying_data_takes_the_limit_over_its_own_topology(self):
        # a grid whose texture coordinates are its own x, y: smooth face-varying refinement with
        # the limit gives every refined corner the (x, y) of its limit point
        pts, counts, idx = bumpy_grid(3)
        ref = Refinement(len(pts), counts, idx, 2)
        lim = ref.points(flat(pts), 3, limit=True)
        uv, uidx = ref.face_varying([c for i in idx for c in pts[i][:2]], 2, "cornersPlus1", limit=True)
        for corner, v in enumerate(ref.fvi):
            self.assertAlmostEqual(uv[2 * uidx[corner]], lim[3 * v], places=9)
            self.assertAlmostEqual(uv[2 * uidx[corner] + 1], lim[3 * v + 1], places=9)

    def test_varying_data_is_refined_linearly(self):
        # Catmull-Clark with creases and a corner: varying data refines as the bilinear scheme
        # refines the same data (same topology, same point order), at every level, and unlike the
        # smooth rules keeps a lone peak at its vertex
        pts, counts, idx = bumpy_grid(4)
        crease, corner = tags(4)
        hat = [1.0 if i == 13 else 0.0 for i in range(len(pts))]  # a smooth interior vertex, (3, 2)
        for levels in (1, 2, 3):
            ref = Refinement(len(pts), counts, idx, levels, "catmullClark", "edgeAndCorner", crease, corner)
            lin = Refinement(len(pts), counts, idx, levels, "bilinear")
            self.assertEqual((ref.fvc, ref.fvi), (lin.fvc, lin.fvi))
            got = ref.varying(hat, 1)
            self.assertEqual(got, lin.points(hat, 1))
            self.assertEqual(got[13], 1.0)
            self.assertLess(ref.points(hat, 1, limit=True)[13], 0.5)
            # values of a bilinear hat at dyadic points: multiples of 1/4^levels
            step = 4 ** levels
            for x in got:
                self.assertAlmostEqual(x * step, round(x * step), places=9)
        # Loop: vertex points keep their value, edge points take the edge's midpoint
        ref = Refinement(4, [3] * 4, TET_IDX, 1, "loop")
        data = [1.0, 2.0, 4.0, 8.0]
        got = ref.varying(data, 1)
        self.assertEqual(got[:4], data)
        mids = sorted(got[4:])
        self.assertEqual(mids, sorted((data[a] + data[b]) / 2 for a in range(4) for b in range(a + 1, 4)))
        # two levels: every value an average of the cage's with weights in quarters
        got = Refinement(4, [3] * 4, TET_IDX, 2, "loop").varying(data, 1)
        self.assertEqual(len(got), 4 + 6 + 24)
        self.assertEqual(min(got), 1.0)
        self.assertEqual(max(got), 8.0)


if __name__ == "__main__":
    unittest.main()
