"""raysplat_curves.py: triangle tessellation of UsdGeomBasisCurves (as round tubes) and UsdGeomPoints
(as spheres) for the converter (`raysplat_usd.py`). Standard library only; the Rust binary runs this
file's text before the converter's.

Curves follow the UsdGeomBasisCurves schema: `type` linear or cubic, `basis` bezier, bspline or
catmullRom, `wrap` nonperiodic, periodic or pinned, with `curveVertexCounts` vertices per curve. Each
cubic segment is sampled at `steps` points, each linear segment at its ends; a tube of `sides` sides
follows the samples with a parallel-transported frame, its radius half the interpolated width, and an
open curve's tube is closed by flat discs at its ends. Per-vertex data (widths, colours) follows the
curve's basis; varying data is linear between segment ends.
"""

import math

# Cubic bases as 4x4 matrices: P(t) = [t^3 t^2 t 1] M [P0 P1 P2 P3]^T.
BASES = {
    "bezier": ((-1, 3, -3, 1), (3, -6, 3, 0), (-3, 3, 0, 0), (1, 0, 0, 0)),
    "bspline": tuple(tuple(x / 6.0 for x in row) for row in ((-1, 3, -3, 1), (3, -6, 3, 0), (-3, 0, 3, 0), (1, 4, 1, 0))),
    "catmullRom": tuple(tuple(x / 2.0 for x in row) for row in ((-1, 3, -3, 1), (2, -5, 4, -1), (-1, 0, 1, 0), (0, 2, 0, 0))),
}


class CurveError(ValueError):
    pass


def curve_samples(counts, kind, basis, wrap, steps):
    """Per curve, its samples as (vertex stencil, varying stencil): [(vertex index, weight)] over all
    curves' vertices and [(varying index, weight)] over all curves' varying values. Also the number of
    varying values. Raises CurveError for a vertex count the type, basis and wrap do not allow."""
    if kind not in ("linear", "cubic"):
        raise CurveError("unknown curve type %r" % kind)
    if wrap not in ("nonperiodic", "periodic", "pinned"):
        raise CurveError("unknown wrap %r" % wrap)
    if kind == "cubic" and basis not in BASES:
        raise CurveError("unknown basis %r" % basis)
    curves, off, voff = [], 0, 0
    for c, n in enumerate(counts):
        if kind == "linear":
            if n < 2:
                raise CurveError("curve %d has %d vertices (a linear curve needs 2)" % (c, n))
            # (periodic: the tube closes from the last vertex to the first)
            curves.append([([(off + i, 1.0)], [(voff + i, 1.0)]) for i in range(n)])
            off, voff = off + n, voff + n
            continue
        m = BASES[basis]
        if wrap == "periodic":
            if n < 3 or (basis == "bezier" and n % 3):
                raise CurveError("curve %d has %d vertices, which a periodic %s curve cannot have" % (c, n, basis))
            step = 3 if basis == "bezier" else 1
            segs = [[off + (s * step + k) % n for k in range(4)] for s in range(n // step)]
            nvar = len(segs)
        else:
            cvs = list(range(off, off + n))
            pts = [[(i, 1.0)] for i in cvs]
            if wrap == "pinned" and basis != "bezier":
                if n < 2:
                    raise CurveError("curve %d has %d vertices (a pinned curve needs 2)" % (c, n))
                # phantom end points 2 P0 − P1 and 2 Pn−1 − Pn−2
                pts = [[(cvs[0], 2.0), (cvs[1], -1.0)]] + pts + [[(cvs[-1], 2.0), (cvs[-2], -1.0)]]
            step = 3 if basis == "bezier" else 1
            if len(pts) < 4 or (len(pts) - 4) % step:
                raise CurveError("curve %d has %d vertices, which a nonperiodic cubic %s curve cannot have"
                                 % (c, n, basis))
            segs = [pts[s:s + 4] for s in range(0, len(pts) - 3, step)]
            nvar = len(segs) + 1
        samples = []
        for s, seg in enumerate(segs):
            seg = [p if isinstance(p, list) else [(p, 1.0)] for p in seg]
            for k in range(0 if s == 0 else 1, steps + 1):
                t = k / steps
                tv = (t ** 3, t ** 2, t, 1.0)
                wts = [sum(tv[r] * m[r][j] for r in range(4)) for j in range(4)]
                st = [(i, wts[j] * wp) for j in range(4) for i, wp in seg[j] if wts[j] * wp != 0.0]
                a, b = voff + s, voff + (s + 1) % nvar
                samples.append((st, [(a, 1.0 - t), (b, t)]))
        if wrap == "periodic":
            samples.pop()  # the last sample is the first again: the tube closes instead
        curves.append(samples)
        off, voff = off + n, voff + nvar
    return curves, voff


def combine(stencil, data, width):
    return [sum(w * data[i * width + c] for i, w in stencil) for c in range(width)]


def tubes(centres, radii, closed, sides):
    """Triangles of tubes along polylines. `centres`: per curve, its sample points; `radii`: per curve,
    per sample; `closed`: per curve. An open tube is closed by a flat disc at each end of non-zero
    radius (its own vertices, with the disc's normal along the curve). Returns (positions, normals,
    triangles, origin) with `origin[v]` = (curve, sample) of each vertex."""
    pos, nrm, tris, origin = [], [], [], []
    ring = [(math.cos(2 * math.pi * j / sides), math.sin(2 * math.pi * j / sides)) for j in range(sides)]
    for c, (pts, rad) in enumerate(zip(centres, radii)):
        n = len(pts)
        if n < 2:
            continue
        base = len(pos)
        normal, t = None, (0.0, 0.0, 1.0)
        ends = []  # the tangents at the first and the last sample
        for i in range(n):
            if closed[c]:
                a, b = pts[(i - 1) % n], pts[(i + 1) % n]
            else:
                a, b = pts[max(i - 1, 0)], pts[min(i + 1, n - 1)]
            t = norm(sub(b, a)) or t  # coincident samples keep the last tangent
            if normal is None:
                normal = perpendicular(t)
            else:
                d = dot(normal, t)
                normal = norm(sub(normal, scale(t, d))) or perpendicular(t)
            binormal = cross(t, normal)
            if i == 0 or i == n - 1:
                ends.append(t)
            for cj, sj in ring:
                r = add(scale(normal, cj), scale(binormal, sj))
                pos.append(add(pts[i], scale(r, rad[i])))
                nrm.append(r)
                origin.append((c, i))
        rings = n if closed[c] else n - 1
        for i in range(rings):
            i1 = (i + 1) % n
            for j in range(sides):
                j1 = (j + 1) % sides
                a, b = base + i * sides + j, base + i * sides + j1
                cc, d = base + i1 * sides + j1, base + i1 * sides + j
                tris.append((a, b, cc))
                tris.append((a, cc, d))
        if closed[c]:
            continue
        # end discs: a fan around the centre, facing back along the curve at its start and
        # forward at its end (the rings run counter-clockwise about the tangent)
        for i, t, sign in ((0, ends[0], -1.0), (n - 1, ends[-1], 1.0)):
            if not rad[i] > 0.0:
                continue
            cn = scale(t, sign)
            centre = len(pos)
            pos.append(pts[i])
            nrm.append(cn)
            origin.append((c, i))
            for j in range(sides):
                pos.append(pos[base + i * sides + j])
                nrm.append(cn)
                origin.append((c, i))
            for j in range(sides):
                a, b = centre + 1 + j, centre + 1 + (j + 1) % sides
                tris.append((centre, a, b) if sign > 0 else (centre, b, a))
    return pos, nrm, tris, origin


def icosphere(levels):
    """Unit sphere: (vertices, triangles), an icosahedron split `levels` times, faces outward."""
    g = (1.0 + math.sqrt(5.0)) / 2.0
    v = [norm(p) for p in ((-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0), (0, -1, g), (0, 1, g), (0, -1, -g),
                            (0, 1, -g), (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1))]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        mid = {}

        def m(a, b):
            k = (min(a, b), max(a, b))
            if k not in mid:
                mid[k] = len(v)
                v.append(norm(add(v[a], v[b])))
            return mid[k]
        f = [t for a, b, c in f for t in ((a, m(a, b), m(c, a)), (b, m(b, c), m(a, b)), (c, m(c, a), m(b, c)),
                                          (m(a, b), m(b, c), m(c, a)))]
    return v, f


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    length = math.sqrt(dot(a, a))
    return scale(a, 1.0 / length) if length > 1e-30 and math.isfinite(length) else None


def perpendicular(t):
    other = (1.0, 0.0, 0.0) if abs(t[0]) < 0.9 else (0.0, 1.0, 0.0)
    return norm(cross(t, other))


# ---- NURBS (UsdGeomNurbsCurves, UsdGeomNurbsPatch) -------------------------------------------------


def nurbs_basis(knots, degree, n, u):
    """(first, [N_first .. N_first+degree]): the non-zero B-spline basis functions of the `n` control
    points at parameter `u` (The NURBS Book, A2.1 and A2.2), `u` clamped into the knots' domain
    `[knots[degree], knots[n]]` (the span search assumes it)."""
    u = max(u, knots[degree])
    if u >= knots[n]:
        span = n - 1
        while span > degree and knots[span] >= knots[span + 1]:
            span -= 1
    else:
        lo, hi = degree, n
        span = (lo + hi) // 2
        while u < knots[span] or u >= knots[span + 1]:
            if u < knots[span]:
                hi = span
            else:
                lo = span
            span = (lo + hi) // 2
    left, right, N = [0.0] * (degree + 1), [0.0] * (degree + 1), [1.0] + [0.0] * degree
    for j in range(1, degree + 1):
        left[j] = u - knots[span + 1 - j]
        right[j] = knots[span + j] - u
        saved = 0.0
        for r in range(j):
            den = right[r + 1] + left[j - r]
            tmp = N[r] / den if den != 0.0 else 0.0
            N[r] = saved + right[r + 1] * tmp
            saved = left[j - r] * tmp
        N[j] = saved
    return span - degree, N


def check_nurbs(n, order, knots, what):
    if order < 2 or n < order:
        raise CurveError("%s has %d control points for order %d (it needs at least the order)" % (what, n, order))
    if len(knots) != n + order:
        raise CurveError("%s has %d knots where %d control points of order %d need %d"
                         % (what, len(knots), n, order, n + order))
    if any(b < a for a, b in zip(knots, knots[1:])):
        raise CurveError("%s has decreasing knots" % what)


def nurbs_params(knots, order, n, rng, steps):
    """Sample parameters over `rng` (or the knots' valid range): `steps` per non-empty knot span."""
    p = order - 1
    lo, hi = (knots[p], knots[n]) if rng is None else rng
    if not hi > lo:
        raise CurveError("empty parameter range [%g, %g]" % (lo, hi))
    if lo < knots[p] or hi > knots[n]:
        raise CurveError("parameter range [%g, %g] reaches outside the knots' domain [%g, %g]" % (lo, hi, knots[p], knots[n]))
    spans = sum(1 for i in range(p, n) if knots[i + 1] > knots[i] and knots[i + 1] > lo and knots[i] < hi)
    count = max(1, spans) * steps
    return [lo + (hi - lo) * k / count for k in range(count + 1)]


def nurbs_curve_samples(counts, orders, knots, ranges, weights, steps):
    """Per NURBS curve, its samples as (vertex stencil, varying stencil) as `curve_samples` gives
    them: rational basis weights over the curve's control points; varying values (one per knot span
    end) linear along the parameter."""
    curves, off, koff, voff = [], 0, 0, 0
    for c, n in enumerate(counts):
        k = orders[c]
        kn = knots[koff:koff + n + k]
        check_nurbs(n, k, kn, "curve %d" % c)
        params = nurbs_params(kn, k, n, ranges[c] if ranges else None, steps)
        nvar = n - k + 2
        samples = []
        for j, u in enumerate(params):
            first, N = nurbs_basis(kn, k - 1, n, u)
            w = [N[i] * (weights[off + first + i] if weights else 1.0) for i in range(k)]
            total = sum(w) or 1.0
            x = (nvar - 1) * j / (len(params) - 1)
            a = min(int(x), nvar - 2)
            samples.append(([(off + first + i, w[i] / total) for i in range(k) if w[i] != 0.0],
                            [(voff + a, 1.0 - (x - a)), (voff + a + 1, x - a)]))
        curves.append(samples)
        off, koff, voff = off + n, koff + n + k, voff + nvar
    return curves, voff


def nurbs_patch(points, weights, nu, nv, uorder, vorder, uknots, vknots, urange, vrange, steps):
    """A NURBS patch tessellated into a grid: (positions, uvs (the normalised parameters), quads as
    (a, b, c, d) with the winding of dP/du x dP/dv)."""
    check_nurbs(nu, uorder, uknots, "the u direction")
    check_nurbs(nv, vorder, vknots, "the v direction")
    us = nurbs_params(uknots, uorder, nu, urange, steps)
    vs = nurbs_params(vknots, vorder, nv, vrange, steps)
    bu = [nurbs_basis(uknots, uorder - 1, nu, u) for u in us]
    bv = [nurbs_basis(vknots, vorder - 1, nv, v) for v in vs]
    pos, uvs = [], []
    for j, (fv, Nv) in enumerate(bv):
        for i, (fu, Nu) in enumerate(bu):
            x = y = z = total = 0.0
            for b, nb in enumerate(Nv):
                if nb == 0.0:
                    continue
                row = (fv + b) * nu
                for a, na in enumerate(Nu):
                    idx = row + fu + a
                    w = na * nb * (weights[idx] if weights else 1.0)
                    x += w * points[3 * idx]
                    y += w * points[3 * idx + 1]
                    z += w * points[3 * idx + 2]
                    total += w
            total = total or 1.0
            pos.append((x / total, y / total, z / total))
            uvs.append((i / (len(us) - 1), j / (len(vs) - 1)))
    su = len(us)
    quads = [(j * su + i, j * su + i + 1, (j + 1) * su + i + 1, (j + 1) * su + i)
             for j in range(len(vs) - 1) for i in range(su - 1)]
    return pos, uvs, quads


def hermite_samples(counts, npts, steps):
    """UsdGeomHermiteCurves: per curve, its samples as `curve_samples` gives them (vertex and
    varying data linear between a segment's two points, as a Hermite curve has one varying value per
    point) and, apart, per curve the position stencils over the points followed by their tangents
    (index `npts + i` is point `i`'s tangent): P(t) = h00 P0 + h10 T0 + h01 P1 + h11 T1."""
    curves, positions, off = [], [], 0
    for c, n in enumerate(counts):
        if n < 2:
            raise CurveError("curve %d has %d points (a Hermite curve needs 2)" % (c, n))
        samples, pos = [], []
        for s in range(n - 1):
            a, b = off + s, off + s + 1
            for k in range(0 if s == 0 else 1, steps + 1):
                t = k / steps
                t2, t3 = t * t, t * t * t
                h = ((a, 2 * t3 - 3 * t2 + 1), (npts + a, t3 - 2 * t2 + t), (b, -2 * t3 + 3 * t2), (npts + b, t3 - t2))
                pos.append([(i, w) for i, w in h if w != 0.0])
                lin = [(a, 1.0 - t), (b, t)]
                samples.append((lin, lin))
        curves.append(samples)
        positions.append(pos)
        off += n
    return curves, positions
