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

Per-point data (positions and vertex primvars) follows the vertex rules; varying primvars are
refined linearly (`varying`: bilinearly over each face, as USD and OpenSubdiv interpolate them on
subdivision surfaces); face-varying data follows the scheme over its own topology (seams are
boundaries) as `faceVaryingLinearInterpolation` says, or linearly within each face (`all`);
uniform data is inherited by the child faces.

The surface USD means is the limit of the refinement. After the last level the converter moves each
refined point onto it (`points(..., limit=True)`, the limit masks of `_limit`): the rendered mesh is
inscribed in the limit surface instead of lying inside it (without the projection the corners of
a cube of side 2 are 0.016 from the limit at level 2). Face-varying data is projected by the same
masks over its own topology. Smooth points also get the limit surface's normal from its tangent
masks (`limit_normals`).
"""

import math
from itertools import repeat

# The sharpness of boundary and non-manifold edges and of pinned points.
INFINITE = 1e30


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
        if any(c < 3 for c in fvc):
            raise ValueError("a face has fewer than 3 vertices")
        bad = repeated_vertex_face(fvc, fvi)
        if bad is not None:
            raise ValueError("face %d names a vertex twice (%s)" % bad)
        self.scheme = scheme
        self.level_count = levels
        # (a level replaces these lists, never changes them: the cage's stay as they are)
        self.npts, self.fvc, self.fvi = npts, list(fvc), list(fvi)
        self.parent_face = list(range(len(fvc)))
        self.cage = (self.fvc, self.fvi)
        # per level: (point stencils, face-vertex stencils, the faces (offsets, counts, indices) whose
        # centroids the point stencils read, the level's point count); a stencil is
        # [(index, weight), ...]
        self.levels = []
        # per level, its edges (in the order of its edge points): with `levels`' point count and
        # faces, what the linear refinement of per-point data reads (`varying`)
        self._level_edges = []
        sharp = dict(creases)  # (a, b) with a < b -> sharpness
        corner = dict(corners)  # vertex -> sharpness
        for _ in range(levels):
            sharp, corner = self._level(sharp, corner, boundary)
        # the limit stencils (`_limit`, from the last level's topology, computed on first use)
        self._limit_stencils = None
        # the refined mesh's edges that are still sharp (s >= 1 at the last level: creases that
        # stay hard), as (a, b) with a < b
        self.hard_edges = {e for e, s in sharp.items() if s >= 1.0}
        # the refined mesh's creases and corners ((a, b) -> sharpness, point -> sharpness)
        self.tags = (sharp, corner)

    def corner_normals(self, points, holes=(), exact=None):
        """Normals of the refined mesh per face-vertex, as (normals, indices): area-weighted over
        the faces around each point (not `holes`, refined faces that are not rendered), but not
        across `hard_edges` (a sharp crease stays a hard edge in the shading as in the surface);
        a point's `exact` normal (per point, None: none) where it has one (such a point has no
        sharp edge: one fan). `points`: the refined points (flat floats)."""
        fvc, fvi = self.fvc, self.fvi
        offs, off = [], 0
        for n in fvc:
            offs.append(off)
            off += n
        # face normals (Newell's method: area-weighted, any polygon)
        fn = []
        for f, n in enumerate(fvc):
            o = offs[f]
            x = y = z = 0.0
            for k in range(n):
                a, b = 3 * fvi[o + k], 3 * fvi[o + (k + 1) % n]
                ax, ay, az, bx, by, bz = points[a], points[a + 1], points[a + 2], points[b], points[b + 1], points[b + 2]
                x += (ay - by) * (az + bz)
                y += (az - bz) * (ax + bx)
                z += (ax - bx) * (ay + by)
            fn.append((x, y, z))
        # corners joined across every edge that is not hard: one group per smooth fan of a point
        parent = list(range(len(fvi)))

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i
        first = {}
        for f, n in enumerate(fvc):
            o = offs[f]
            for k in range(n):
                a, b = fvi[o + k], fvi[o + (k + 1) % n]
                key = (a, b) if a < b else (b, a)
                if key in self.hard_edges:
                    continue
                ca, cb = o + k, o + (k + 1) % n  # this face's corners at a and b
                other = first.setdefault(key, (ca, cb, a))
                if other[0] == ca:
                    continue
                oa, ob = (other[0], other[1]) if other[2] == a else (other[1], other[0])
                for c, d in ((ca, oa), (cb, ob)):
                    rc, rd = find(c), find(d)
                    if rc != rd:
                        parent[rc] = rd
        groups, idx, sums, point_of = {}, [], [], []
        for f, n in enumerate(fvc):
            for k in range(n):
                g = groups.setdefault(find(offs[f] + k), len(sums))
                if g == len(sums):
                    sums.append([0.0, 0.0, 0.0])
                    point_of.append(fvi[offs[f] + k])
                idx.append(g)
                if f in holes:
                    continue
                acc, nf = sums[g], fn[f]
                acc[0] += nf[0]
                acc[1] += nf[1]
                acc[2] += nf[2]
        out = []
        for (x, y, z), v in zip(sums, point_of):
            e = exact[v] if exact is not None else None
            if e is not None:
                s = -1.0 if e[0] * x + e[1] * y + e[2] * z < 0.0 else 1.0
                x, y, z = s * e[0], s * e[1], s * e[2]
            ln = math.sqrt(x * x + y * y + z * z)
            out.extend((x / ln, y / ln, z / ln) if ln > 0 and math.isfinite(ln) else (0.0, 0.0, 0.0))
        return out, idx

    def limit_normals(self, points):
        """Unit normals of the limit surface at the refined points, from `points` (the refined
        points as `points` gives them without `limit`, flat floats: these masks, like the limit
        position masks, weigh the last level's points), where the tangent masks hold: at smooth
        points (no sharp edge, no corner tag) whose faces close a fan around them (Catmull-Clark:
        quads; Loop: triangles). Over the ring e₀ … eₙ₋₁ and the quads' diagonal points dᵢ
        (between eᵢ and eᵢ₊₁): Catmull-Clark t₁ = Σ Aₙ cos(2πi/n) eᵢ + (cos(2πi/n) +
        cos(2π(i+1)/n)) dᵢ and t₂ the same turned by one, Aₙ = 1 + cos(2π/n) + cos(π/n)
        √(2 (9 + cos(2π/n))) [Halstead, Kass & DeRose 1993]; Loop t₁ = Σ cos(2πi/n) eᵢ,
        t₂ = Σ sin(2πi/n) eᵢ; the normal their cross product, on the faces' front side. None
        elsewhere (creases, corners, darts, boundaries, and the cage and bilinear refinements,
        which have no tangent masks of this kind)."""
        out = [None] * self.npts
        if not self.levels or self.scheme == "bilinear":
            return out
        loop = self.scheme == "loop"
        side = 3 if loop else 4
        sharp, corner = self.tags
        # per point, its corners as (previous point, next point, diagonal point) around each face
        around = [[] for _ in range(self.npts)]
        fvi, off = self.fvi, 0
        for n in self.fvc:
            if n == side:
                for k in range(n):
                    around[fvi[off + k]].append((fvi[off + k - 1 if k else off + n - 1], fvi[off + (k + 1) % n],
                                                 fvi[off + (k + 2) % n]))
            off += n
        masks = {}  # valence -> ring weights of t₁ and t₂, diagonal weights of t₁ and t₂
        for v, cs in enumerate(around):
            n = len(cs)
            if n < 3 or (corner and corner.get(v, 0.0) > 0.0):
                continue
            # the fan in order: the face after a face (across the edge to its next point b) has b
            # as its previous point; the ring e₀ = the first face's previous point, dᵢ the
            # diagonal between eᵢ and eᵢ₊₁
            by_prev = {}
            for a, b, d in cs:
                by_prev.setdefault(a, (b, d))
            if len(by_prev) != n:
                continue  # two faces leave v by the same edge: not a fan
            order, e = [], cs[0][0]
            for _ in range(n):
                b, d = by_prev.get(e, (None, None))
                if b is None:
                    break
                order.append((e, d))
                e = b
            if len(order) != n or e != cs[0][0]:
                continue  # the fan does not close (a boundary) or visits v twice
            if sharp and any(sharp.get((v, e) if v < e else (e, v), 0.0) > 0.0 for e, _ in order):
                continue
            c = masks.get(n)
            if c is None:
                cos = [math.cos(2 * math.pi * i / n) for i in range(n)]
                sin = [math.sin(2 * math.pi * i / n) for i in range(n)]
                if loop:
                    c = masks[n] = (cos, sin, None, None)
                else:
                    an = 1 + math.cos(2 * math.pi / n) + math.cos(math.pi / n) * math.sqrt(2 * (9 + math.cos(2 * math.pi / n)))
                    c = masks[n] = ([an * x for x in cos], [an * cos[i - 1] for i in range(n)],
                                    [cos[i] + cos[(i + 1) % n] for i in range(n)],
                                    [cos[i - 1] + cos[i] for i in range(n)])
            w1, w2, u1, u2 = c
            ax = ay = az = bx = by = bz = 0.0
            for i, (e, dg) in enumerate(order):
                x, y, z = points[3 * e], points[3 * e + 1], points[3 * e + 2]
                p1, p2 = w1[i], w2[i]
                ax, ay, az, bx, by, bz = ax + p1 * x, ay + p1 * y, az + p1 * z, bx + p2 * x, by + p2 * y, bz + p2 * z
                if u1 is not None:
                    x, y, z = points[3 * dg], points[3 * dg + 1], points[3 * dg + 2]
                    p1, p2 = u1[i], u2[i]
                    ax, ay, az, bx, by, bz = ax + p1 * x, ay + p1 * y, az + p1 * z, bx + p2 * x, by + p2 * y, bz + p2 * z
            # t₂ × t₁: the ring is walked from each face's previous point to its next one, against
            # the faces' winding seen from their front
            nx, ny, nz = by * az - bz * ay, bz * ax - bx * az, bx * ay - by * ax
            ln = math.sqrt(nx * nx + ny * ny + nz * nz)
            if ln > 0.0 and math.isfinite(ln):
                out[v] = (nx / ln, ny / ln, nz / ln)
        return out

    def points(self, data, width, limit=False):
        """Per-point `data` (flat floats, `width` per point) of the cage, refined; with `limit`,
        then moved to the limit surface (see `_limit`)."""
        for stencils, _, faces, npts in self.levels:
            if faces is not None:
                data = data + centroids(faces, data, width)
            data = apply(stencils, data, width)
        return self.project(data, width) if limit else data

    def varying(self, data, width):
        """Per-point `data` of the cage refined linearly, as USD interpolates `varying` primvars
        on subdivision surfaces (bilinearly over each face, as OpenSubdiv's varying interpolation
        does): a vertex point keeps its value, an edge point takes its edge's midpoint, a face point
        its face's centroid. No limit projection: the linear refinement is its own limit."""
        for (_, _, faces, npts), edges in zip(self.levels, self._level_edges):
            stencils = [[(v, 1.0)] for v in range(npts)] + [[(a, 0.5), (b, 0.5)] for a, b in edges]
            if faces is not None:
                data = data + centroids(faces, data, width)
                stencils.extend([(npts + f, 1.0)] for f in range(len(faces[1])))
            data = apply(stencils, data, width)
        return data

    def project(self, data, width):
        """Refined per-point `data` (from `points`) moved to the limit surface (see `_limit`)."""
        if self.levels and self.scheme != "bilinear":
            # (the cage and bilinear refinements lie on their limit surfaces already)
            if self._limit_stencils is None:
                self._limit_stencils = self._limit()
            data = apply(self._limit_stencils, data, width)
        return data

    def face_varying(self, data, width, rule="all", limit=False):
        """Per-face-vertex `data` (flat floats) of the cage, refined, as (values, indices): the
        refined values and, per refined face-vertex, its value's index (None: one value per
        face-vertex). Linearly within each face for
        `faceVaryingLinearInterpolation` "all" (and the bilinear scheme), else smoothly, by the mesh's
        scheme over the face-varying topology: corners of equal values are one point, an edge whose
        two faces disagree at an end is a seam, and seams are boundaries. Pinned (linear) there:
        "none" nothing, "cornersOnly" corners of a single face, "cornersPlus1" and "cornersPlus2" also
        points where three or more values meet, "boundaries" every seam point."""
        if rule == "all" or self.scheme == "bilinear" or not self.levels:
            for _, stencils, _, _ in self.levels:
                data = apply(stencils, data, width)
            return data, None
        fvc, fvi = self.cage
        ids, values = {}, []
        fv_ids = []
        for k, v in enumerate(fvi):
            key = (v, tuple(data[k * width:(k + 1) * width]))
            i = ids.get(key)
            if i is None:
                i = ids[key] = len(values)
                values.append(key[1])
            fv_ids.append(i)
        per_vertex = {}
        for v, _ in ids:
            per_vertex[v] = per_vertex.get(v, 0) + 1
        if rule in ("cornersPlus1", "cornersPlus2"):
            pinned = {i for (v, _), i in ids.items() if per_vertex[v] >= 3}
        elif rule == "boundaries":
            # every point of a seam (an edge of the face-varying topology with one face)
            uses, off = {}, 0
            for n in fvc:
                for k in range(n):
                    a, b = fv_ids[off + k], fv_ids[off + (k + 1) % n]
                    e = (a, b) if a < b else (b, a)
                    uses[e] = uses.get(e, 0) + 1
                off += n
            pinned = {i for e, u in uses.items() if u == 1 for i in e}
        else:
            pinned = set()
        boundary = "edgeOnly" if rule == "none" else "edgeAndCorner"
        fref = Refinement(len(values), fvc, fv_ids, self.level_count, self.scheme, boundary, (),
                          {i: 1e30 for i in pinned})
        return fref.points([x for v in values for x in v], width, limit), fref.fvi

    def _topology(self, sharp):
        """The current mesh's face offsets, edges (in order of first use, as (a, b) with a < b), the
        edge of each key `a * npts + b`, each edge's faces, each face-vertex's following edge, each
        edge's sharpness (boundary and non-manifold edges infinite) and each point's edges and
        faces."""
        npts, fvc, fvi = self.npts, self.fvc, self.fvi
        nf = len(fvc)
        offs = [0] * nf
        off = 0
        for f, n in enumerate(fvc):
            offs[f] = off
            off += n
        edge_of, edges, edge_faces, face_edges = {}, [], [], []
        for f, n in enumerate(fvc):
            o = offs[f]
            for k in range(n):
                a, b = fvi[o + k], fvi[o + (k + 1) % n]
                key = a * npts + b if a < b else b * npts + a
                e = edge_of.get(key)
                if e is None:
                    e = edge_of[key] = len(edges)
                    edges.append((a, b) if a < b else (b, a))
                    edge_faces.append([f])
                else:
                    edge_faces[e].append(f)
                face_edges.append(e)
        edge_sharp = [INFINITE if len(fs) != 2 else sharp.get(edges[e], 0.0) if sharp else 0.0
                      for e, fs in enumerate(edge_faces)]
        vert_edges = [[] for _ in range(npts)]
        for e, (a, b) in enumerate(edges):
            vert_edges[a].append(e)
            vert_edges[b].append(e)
        vert_faces = [[] for _ in range(npts)]
        for f, n in enumerate(fvc):
            o = offs[f]
            for k in range(n):
                vert_faces[fvi[o + k]].append(f)
        return offs, edges, edge_of, edge_faces, face_edges, edge_sharp, vert_edges, vert_faces

    @staticmethod
    def _vertex_tags(v, ve, vf, edge_faces, edge_sharp, corner, boundary):
        """A point's sharp edges (sharpness > 0) and its own sharpness (a corner tag; with
        edgeAndCorner a boundary point of a single face is an infinitely sharp corner)."""
        creased = [e for e in ve if edge_sharp[e] > 0.0]
        vs = corner.get(v, 0.0) if corner else 0.0
        if boundary == "edgeAndCorner" and len(vf) == 1 and len(creased) == 2 and \
                len(edge_faces[creased[0]]) == 1 and len(edge_faces[creased[1]]) == 1:
            vs = INFINITE
        return creased, vs

    def _limit(self):
        """Stencils moving each point of the refined mesh to its position on the limit surface,
        by the rule its tags give it at the last level (as `_level` would choose them):
        - smooth (or dart): Catmull-Clark (n² v + 4 Σ eᵢ + Σ dᵢ) / (n (n + 5)) over the edge
          neighbours eᵢ and the quads' diagonal points dᵢ [Halstead, Kass & DeRose 1993]; Loop
          (1 − nχ) v + χ Σ eᵢ with χ = 1 / (3 / (8β) + n);
        - crease (two sharp edges to a and b): (a + 4 v + b) / 6, the cubic B-spline's limit; a
          semi-sharp crease (s < 1) blends the smooth and crease rules by s;
        - corner (three or more sharp edges, or a corner tag): v; a semi-sharp corner blends.
        Sharpness left at the last level takes the sharp rule, as OpenSubdiv's limit masks do (the
        exact limit of a semi-sharp feature lies between), and a dart (one sharp edge, where a
        crease ends inside the surface) the smooth mask (its exact limit differs by about 3e-4 of
        the edge length). A point whose faces do not close a fan around it (non-manifold) keeps
        its refined position.

        The last level's points are its input's points, edge points and (Catmull-Clark) face
        points, so their neighbourhoods follow from the input's topology, kept by `_level`, without
        building the refined mesh's (which costs as much as a level)."""
        (npts, fvc, fvi, offs, edges, edge_faces, face_edges, edge_sharp, vert_edges, vert_faces,
         corner, boundary) = self._last
        loop = self.scheme == "loop"
        ne = len(edges)
        fbase = npts + ne  # face points (Catmull-Clark)

        # the sharpness of each edge's two children (boundary and non-manifold: infinite)
        child_sharp = [s if s >= INFINITE else s - 1.0 if s > 1.0 else 0.0 for s in edge_sharp]

        weights = {}  # valence -> (centre, ring, diagonal) weights

        def smooth_mask(v, ring, diagonals):
            n = len(ring)
            c = weights.get(n)
            if c is None:
                if loop:
                    beta = (0.625 - (0.375 + 0.25 * math.cos(2 * math.pi / n)) ** 2) / n
                    chi = 1.0 / (3.0 / (8.0 * beta) + n)
                    c = weights[n] = (1.0 - n * chi, chi, 0.0)
                else:
                    w = 1.0 / (n * (n + 5.0))
                    c = weights[n] = (n * n * w, 4.0 * w, w)
            mask = [(v, c[0])]
            mask.extend(zip(ring, repeat(c[1])))
            if not loop:
                mask.extend(zip(diagonals, repeat(c[2])))
            return mask

        def crease_mask(v, a, b, s, smooth):
            rule = [(v, 4.0 / 6.0), (a, 1.0 / 6.0), (b, 1.0 / 6.0)]
            return blend(smooth, rule, s) if s < 1.0 else rule

        out = []
        # Vertex points: the same edges (to their edge points) and faces (their face points the
        # diagonals) as before the level, the edges' sharpness that of their children.
        for v in range(npts):
            ve, vf = vert_edges[v], vert_faces[v]
            n = len(ve)
            # (an edge's children have its faces' count: boundary stays boundary)
            creased, vs = self._vertex_tags(v, ve, vf, edge_faces, child_sharp, corner, boundary)
            nc = len(creased)
            smooth = [(v, 1.0)]
            if n >= 3 and len(vf) == n and nc <= 2:
                smooth = smooth_mask(v, [npts + e for e in ve], [fbase + f for f in vf])
            if n == 0 or nc > 2:
                rule = [(v, 1.0)]
            elif nc < 2:
                rule = smooth
            else:
                a, b = (npts + e for e in creased)
                s = (min(child_sharp[creased[0]], 1.0) + min(child_sharp[creased[1]], 1.0)) / 2.0
                rule = crease_mask(v, a, b, s, smooth)
            if vs > 0.0:
                rule = blend(rule, [(v, 1.0)], min(vs, 1.0))
            out.append(rule)
        # Edge points: edges to the old edge's ends (its children) and, per face of the edge, to
        # the face point (Catmull-Clark) or to the face's two other edge points (Loop); the
        # diagonals of a Catmull-Clark edge point are the face's neighbouring edge points.
        for e, (a, b) in enumerate(edges):
            fs = edge_faces[e]
            c = child_sharp[e]
            m = npts + e
            smooth = [(m, 1.0)]
            if len(fs) == 2:
                ring, diagonals = [a, b], []
                for f in fs:
                    o, n = offs[f], fvc[f]
                    k = face_edges.index(e, o, o + n) - o
                    before, after = npts + face_edges[o + (k - 1) % n], npts + face_edges[o + (k + 1) % n]
                    if loop:
                        ring.extend((before, after))
                    else:
                        ring.append(fbase + f)
                        diagonals.extend((before, after))
                smooth = smooth_mask(m, ring, diagonals)
            out.append(crease_mask(m, a, b, min(c, 1.0), smooth) if c > 0.0 else smooth)
        # Face points (Catmull-Clark): n edges to the face's edge points, the face's corners the
        # diagonals; never sharp.
        if not loop:
            for f, n in enumerate(fvc):
                o = offs[f]
                out.append(smooth_mask(fbase + f, [npts + face_edges[o + k] for k in range(n)], fvi[o:o + n])
                           if n >= 3 else [(fbase + f, 1.0)])
        return out

    def _level(self, sharp, corner, boundary):
        """One level: its stencils, the child faces, and the children's sharpness. Point stencils
        index the old points and then (Catmull-Clark and bilinear) the old faces' centroids, which
        `points` computes first: index `npts + f` is face `f`'s centroid."""
        npts, fvc, fvi = self.npts, self.fvc, self.fvi
        loop = self.scheme == "loop"
        linear = self.scheme == "bilinear"
        nf = len(fvc)
        offs, edges, edge_of, edge_faces, face_edges, edge_sharp, vert_edges, vert_faces = self._topology(sharp)
        ne = len(edges)
        stencils = []
        # Vertex points (new index = old index).
        for v in range(npts):
            ve, vf = vert_edges[v], vert_faces[v]
            n = len(ve)
            if n == 0:
                stencils.append([(v, 1.0)])
                continue
            if linear:
                stencils.append([(v, 1.0)])
                continue
            creased, vs = self._vertex_tags(v, ve, vf, edge_faces, edge_sharp, corner, boundary)
            nc = len(creased)
            if nc < 2 or nc == 2 and (edge_sharp[creased[0]] < 1.0 or edge_sharp[creased[1]] < 1.0):
                if loop:
                    beta = (0.625 - (0.375 + 0.25 * math.cos(2 * math.pi / n)) ** 2) / n
                    smooth = [(v, 1.0 - n * beta)] + [(other(edges[e], v), beta) for e in ve]
                else:
                    # (Q + 2R + (n − 3) v) / n = (n − 2)/n v + Σ others / n² + Σ centroids / (n |faces|)
                    wq = 1.0 / (n * len(vf))
                    smooth = [(v, (n - 2.0) / n)] + [(other(edges[e], v), 1.0 / (n * n)) for e in ve] + \
                             [(npts + f, wq) for f in vf]
            if nc < 2:
                rule = smooth  # smooth or dart
            elif nc == 2:
                a, b = (other(edges[e], v) for e in creased)
                rule = [(v, 0.75), (a, 0.125), (b, 0.125)]
                s = (min(edge_sharp[creased[0]], 1.0) + min(edge_sharp[creased[1]], 1.0)) / 2.0
                if s < 1.0:
                    rule = blend(smooth, rule, s)
            else:
                rule = [(v, 1.0)]
            if vs > 0.0:
                rule = blend(rule, [(v, 1.0)], min(vs, 1.0))
            stencils.append(rule)
        # Edge points.
        for e, (a, b) in enumerate(edges):
            s = edge_sharp[e]
            if s >= 1.0 or linear:
                stencils.append([(a, 0.5), (b, 0.5)])
                continue
            fs = edge_faces[e]
            if loop:
                smooth = [(a, 0.375), (b, 0.375)] + [(third(fvi, offs[f], a, b), 0.125) for f in fs]
            else:
                smooth = [(a, 0.25), (b, 0.25), (npts + fs[0], 0.25), (npts + fs[1], 0.25)]
            stencils.append(blend(smooth, [(a, 0.5), (b, 0.5)], s) if s > 0.0 else smooth)
        # Face points: the centroids themselves.
        if not loop:
            stencils.extend([(npts + f, 1.0)] for f in range(nf))
        # Child faces, their face-vertex stencils, and the children's sharpness.
        new_fvc, new_fvi, new_parent, fv_stencils = [], [], [], []
        parent = self.parent_face
        for f, n in enumerate(fvc):
            o = offs[f]
            ev = [npts + face_edges[o + k] for k in range(n)]  # edge point after corner k
            if loop:
                v0, v1, v2 = fvi[o], fvi[o + 1], fvi[o + 2]
                e01, e12, e20 = ev
                m01, m12, m20 = [(o, 0.5), (o + 1, 0.5)], [(o + 1, 0.5), (o + 2, 0.5)], [(o + 2, 0.5), (o, 0.5)]
                new_fvc.extend((3, 3, 3, 3))
                new_fvi.extend((v0, e01, e20, v1, e12, e01, v2, e20, e12, e01, e12, e20))
                fv_stencils.extend(([(o, 1.0)], m01, m20, [(o + 1, 1.0)], m12, m01, [(o + 2, 1.0)], m20, m12,
                                    m01, m12, m20))
                new_parent.extend((parent[f],) * 4)
                continue
            fp = npts + ne + f
            centre = [(o + k, 1.0 / n) for k in range(n)]
            for k in range(n):
                km = k - 1 if k else n - 1
                k1 = k + 1 if k + 1 < n else 0
                new_fvi.extend((fvi[o + k], ev[k], fp, ev[km]))
                fv_stencils.extend(([(o + k, 1.0)], [(o + k, 0.5), (o + k1, 0.5)], centre,
                                    [(o + km, 0.5), (o + k, 0.5)]))
            new_fvc.extend((4,) * n)
            new_parent.extend((parent[f],) * n)
        new_sharp = {}
        for (a, b), s in sharp.items():
            e = edge_of.get(a * npts + b)
            if e is not None and s > 1.0:
                m = npts + e
                new_sharp[(a, m) if a < m else (m, a)] = s - 1.0
                new_sharp[(b, m) if b < m else (m, b)] = s - 1.0
        new_corner = {v: s - 1.0 for v, s in corner.items() if s > 1.0}
        faces = None if loop else (offs, fvc, fvi)
        self.levels.append((stencils, fv_stencils, faces, npts))
        self._level_edges.append(edges)
        self._last = (npts, fvc, fvi, offs, edges, edge_faces, face_edges, edge_sharp, vert_edges, vert_faces,
                      new_corner, boundary)
        self.npts = len(stencils)
        self.fvc, self.fvi, self.parent_face = new_fvc, new_fvi, new_parent
        return new_sharp, new_corner


def repeated_vertex_face(fvc, fvi):
    """(face, its vertex indices) of the first face that names a vertex twice, or None."""
    off = 0
    for f, n in enumerate(fvc):
        vs = fvi[off:off + n]
        if len(set(vs)) != len(vs):
            return f, " ".join(map(str, vs))
        off += n
    return None


def other(edge, v):
    return edge[1] if edge[0] == v else edge[0]


def third(fvi, o, a, b):
    """The vertex of triangle `o` that is neither `a` nor `b`."""
    return next(x for x in fvi[o:o + 3] if x != a and x != b)


def centroids(faces, data, width):
    """Flat centroids of `faces` ((offsets, counts, indices)) over per-point `data`."""
    offs, counts, idx = faces
    out = []
    for o, n in zip(offs, counts):
        inv = 1.0 / n
        for c in range(width):
            out.append(sum(data[idx[o + k] * width + c] for k in range(n)) * inv)
    return out


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
    if any(n < 0 for n in lengths) or sum(lengths) != len(indices):
        raise ValueError("creaseLengths add up to %d where creaseIndices has %d" % (sum(lengths), len(indices)))
    edges = sum(max(n - 1, 0) for n in lengths)
    if len(sharpnesses) not in (len(lengths), edges):
        raise ValueError("%d creaseSharpnesses for %d creases of %d edges (one per crease or one per edge)"
                         % (len(sharpnesses), len(lengths), edges))
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
