"""raysplat_subdiv.py: uniform refinement of USD subdivision surfaces (UsdGeomMesh
`subdivisionScheme` catmullClark, loop, bilinear) for the converter (`raysplat_usd.py`).

Standard library only. The Rust binary runs this file's text followed by the converter's as one
script, so the converter finds `Refinement` already defined; run as files, the converter imports it.

Each level splits every face (Catmull-Clark and bilinear: an n-gon into n quads; Loop: a triangle
into four) and places the new points by the scheme's rules:
- Catmull-Clark: face points at the face centroid, edge points (v0 + v1 + f0 + f1) / 4, vertex
  points (Q + 2R + (n − 3) v) / n [Catmull & Clark 1978];
- Loop: edge points 3/8 (v0 + v1) + 1/8 (opposite vertices), vertex points (1 − nβ) v + β Σ
  neighbours with Loop's β [Loop 1987];
- bilinear: centroids and midpoints, vertices unchanged.
Sharp features follow DeRose, Kass & Truong 1998 (the rules OpenSubdiv applies): an edge of
sharpness s ≥ 1 is split at its midpoint, 0 < s < 1 blends the smooth and sharp rules by s, and the
two children of an edge have sharpness s − 1; a vertex on two sharp edges takes the crease rule
(6 v + a + b) / 8, on more (or a corner) stays put. Boundary edges are infinitely sharp
(`interpolateBoundary` edgeAndCorner and edgeOnly; with edgeAndCorner a boundary vertex of a single
face is a corner); non-manifold edges too. Holes keep their place in the topology (their
neighbours are shaped by them) and are dropped by the caller.

Per-point data (positions, vertex and varying primvars) follows the vertex rules; face-varying data
is refined linearly within each face (as `faceVaryingLinearInterpolation = all`); uniform data is
inherited by the child faces.
"""

import math


class Refinement:
    """A mesh refined `levels` times: `fvc`, `fvi` (every face a quad, or a triangle for Loop),
    `npts`, `parent_face` (refined face -> face of the cage), and the data of the cage refined by
    `points(data, width)` (per point) and `face_varying(data, width)` (per face-vertex)."""

    def __init__(self, npts, fvc, fvi, levels, scheme="catmullClark", boundary="edgeAndCorner",
                 creases=(), corners=()):
        if scheme not in ("catmullClark", "loop", "bilinear"):
            raise ValueError("unknown subdivision scheme %r" % scheme)
        if scheme == "loop" and any(c != 3 for c in fvc):
            raise ValueError("the loop scheme needs a mesh of triangles")
        self.scheme = scheme
        self.npts, self.fvc, self.fvi = npts, list(fvc), list(fvi)
        self.parent_face = list(range(len(fvc)))
        # per level: (point stencils, face-vertex stencils); a stencil is [(index, weight), ...]
        self.levels = []
        sharp = dict(creases)  # (a, b) with a < b -> sharpness
        corner = dict(corners)  # vertex -> sharpness
        for _ in range(levels):
            sharp, corner = self._level(sharp, corner, boundary)

    def points(self, data, width):
        """Per-point `data` (flat floats, `width` per point) of the cage, refined."""
        for stencils, _ in self.levels:
            data = apply(stencils, data, width)
        return data

    def face_varying(self, data, width):
        """Per-face-vertex `data` (flat floats) of the cage, refined linearly within each face."""
        for _, stencils in self.levels:
            data = apply(stencils, data, width)
        return data

    def _level(self, sharp, corner, boundary):
        npts, fvc, fvi = self.npts, self.fvc, self.fvi
        loop = self.scheme == "loop"
        linear = self.scheme == "bilinear"
        # Edges, in order of first use, with their faces.
        edge_of, edges, edge_faces = {}, [], []
        face_edges = []  # per face-vertex: the edge from corner k to corner k + 1
        offs = []
        off = 0
        for f, n in enumerate(fvc):
            offs.append(off)
            for k in range(n):
                a, b = fvi[off + k], fvi[off + (k + 1) % n]
                key = (a, b) if a < b else (b, a)
                e = edge_of.get(key)
                if e is None:
                    e = edge_of[key] = len(edges)
                    edges.append(key)
                    edge_faces.append([])
                edge_faces[e].append(f)
                face_edges.append(e)
            off += n
        ne = len(edges)
        infinite = 1e30
        edge_sharp = [0.0] * ne
        for e, key in enumerate(edges):
            s = sharp.get(key, 0.0)
            if len(edge_faces[e]) != 2:
                s = infinite  # boundary (interpolateBoundary) or non-manifold
            edge_sharp[e] = s
        # Per vertex: incident edges and faces.
        vert_edges = [[] for _ in range(npts)]
        for e, (a, b) in enumerate(edges):
            vert_edges[a].append(e)
            vert_edges[b].append(e)
        vert_faces = [[] for _ in range(npts)]
        for f, n in enumerate(fvc):
            for k in range(n):
                vert_faces[fvi[offs[f] + k]].append(f)
        stencils = []
        # Vertex points (new index = old index).
        for v in range(npts):
            ve, vf = vert_edges[v], vert_faces[v]
            n = len(ve)
            if n == 0:
                stencils.append([(v, 1.0)])
                continue
            creased = [e for e in ve if edge_sharp[e] > 0.0]
            vs = corner.get(v, 0.0)
            if boundary == "edgeAndCorner" and len(vf) == 1 and sum(len(edge_faces[e]) == 1 for e in ve) == 2:
                vs = infinite
            if linear:
                smooth = [(v, 1.0)]
            elif loop:
                beta = (0.625 - (0.375 + 0.25 * math.cos(2 * math.pi / n)) ** 2) / n
                smooth = [(v, 1.0 - n * beta)] + [(other(edges[e], v), beta) for e in ve]
            else:
                # (Q + 2R + (n − 3) v) / n: Q the mean face point, R the mean edge midpoint
                smooth = [(v, (n - 3.0) / n)]
                for f in vf:
                    c = fvc[f]
                    smooth += [(fvi[offs[f] + k], 1.0 / (n * len(vf) * c)) for k in range(c)]
                for e in ve:
                    a, b = edges[e]
                    smooth += [(a, 1.0 / (n * n)), (b, 1.0 / (n * n))]
            if len(creased) < 2:
                rule, s = smooth, 0.0  # smooth or dart
            elif len(creased) == 2:
                a, b = (other(edges[e], v) for e in creased)
                rule = [(v, 0.75), (a, 0.125), (b, 0.125)]
                s = sum(min(edge_sharp[e], 1.0) for e in creased) / 2.0
            else:
                rule, s = [(v, 1.0)], 1.0
            if len(creased) >= 2 and s < 1.0:
                rule = blend(smooth, rule, s)
            if vs > 0.0:
                rule = blend(rule, [(v, 1.0)], min(vs, 1.0))
            stencils.append(rule)
        # Edge points.
        for e, (a, b) in enumerate(edges):
            mid = [(a, 0.5), (b, 0.5)]
            s = edge_sharp[e]
            if s >= 1.0 or linear:
                stencils.append(mid)
                continue
            fs = edge_faces[e]
            if loop:
                smooth = [(a, 0.375), (b, 0.375)] + [(third(fvi, offs[f], a, b), 0.125) for f in fs]
            else:
                smooth = [(a, 0.25), (b, 0.25)]
                for f in fs:
                    c = fvc[f]
                    smooth += [(fvi[offs[f] + k], 0.25 / c) for k in range(c)]
            stencils.append(blend(smooth, mid, s) if s > 0.0 else smooth)
        # Face points (Catmull-Clark and bilinear).
        if not loop:
            for f, n in enumerate(fvc):
                stencils.append([(fvi[offs[f] + k], 1.0 / n) for k in range(n)])
        # Child faces, their face-vertex stencils, and the children's sharpness.
        new_fvc, new_fvi, new_parent, fv_stencils = [], [], [], []
        for f, n in enumerate(fvc):
            o = offs[f]
            ev = [npts + face_edges[o + k] for k in range(n)]  # edge point after corner k
            if loop:
                v0, v1, v2 = fvi[o], fvi[o + 1], fvi[o + 2]
                e01, e12, e20 = ev
                m = lambda i, j: [(o + i, 0.5), (o + j, 0.5)]  # noqa: E731
                kids = ([v0, e01, e20], [v1, e12, e01], [v2, e20, e12], [e01, e12, e20])
                fvs = (([(o, 1.0)], m(0, 1), m(2, 0)), ([(o + 1, 1.0)], m(1, 2), m(0, 1)),
                       ([(o + 2, 1.0)], m(2, 0), m(1, 2)), (m(0, 1), m(1, 2), m(2, 0)))
                for kid, fv in zip(kids, fvs):
                    new_fvc.append(3)
                    new_fvi.extend(kid)
                    fv_stencils.extend(fv)
                    new_parent.append(self.parent_face[f])
                continue
            fp = npts + ne + f
            centre = [(o + k, 1.0 / n) for k in range(n)]
            for k in range(n):
                km = (k - 1) % n
                new_fvc.append(4)
                new_fvi.extend((fvi[o + k], ev[k], fp, ev[km]))
                fv_stencils.extend(([(o + k, 1.0)], [(o + k, 0.5), (o + (k + 1) % n, 0.5)], centre,
                                    [(o + km, 0.5), (o + k, 0.5)]))
                new_parent.append(self.parent_face[f])
        new_sharp = {}
        for e, (a, b) in enumerate(edges):
            s = sharp.get((a, b), 0.0) - 1.0
            if s > 0.0:
                m = npts + e
                new_sharp[(a, m) if a < m else (m, a)] = s
                new_sharp[(b, m) if b < m else (m, b)] = s
        new_corner = {v: s - 1.0 for v, s in corner.items() if s > 1.0}
        self.levels.append((stencils, fv_stencils))
        self.npts = len(stencils)
        self.fvc, self.fvi, self.parent_face = new_fvc, new_fvi, new_parent
        return new_sharp, new_corner


def other(edge, v):
    return edge[1] if edge[0] == v else edge[0]


def third(fvi, o, a, b):
    """The vertex of triangle `o` that is neither `a` nor `b`."""
    return next(x for x in fvi[o:o + 3] if x != a and x != b)


def blend(p, q, s):
    """(1 − s) p + s q of two stencils."""
    return [(i, w * (1.0 - s)) for i, w in p] + [(i, w * s) for i, w in q]


def apply(stencils, data, width):
    out = [0.0] * (len(stencils) * width)
    if width == 2:
        for n, st in enumerate(stencils):
            x = y = 0.0
            for i, w in st:
                x += w * data[2 * i]
                y += w * data[2 * i + 1]
            out[2 * n], out[2 * n + 1] = x, y
        return out
    if width == 3:
        for n, st in enumerate(stencils):
            x = y = z = 0.0
            for i, w in st:
                j = 3 * i
                x += w * data[j]
                y += w * data[j + 1]
                z += w * data[j + 2]
            out[3 * n], out[3 * n + 1], out[3 * n + 2] = x, y, z
        return out
    for n, st in enumerate(stencils):
        for c in range(width):
            out[n * width + c] = sum(w * data[i * width + c] for i, w in st)
    return out


def crease_edges(indices, lengths, sharpnesses):
    """UsdGeomMesh creases as {(a, b) with a < b: sharpness}: `creaseLengths` chains of
    `creaseIndices`, one sharpness per chain or one per edge of the chains."""
    per_edge = len(sharpnesses) != len(lengths)
    out, off, k = {}, 0, 0
    for c, n in enumerate(lengths):
        for j in range(n - 1):
            a, b = indices[off + j], indices[off + j + 1]
            s = sharpnesses[k] if per_edge else sharpnesses[c]
            k += 1
            key = (a, b) if a < b else (b, a)
            out[key] = max(out.get(key, 0.0), float(s))
        off += n
    return out
