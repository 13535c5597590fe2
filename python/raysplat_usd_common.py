"""raysplat_usd_common.py: what every part of the USD converter shares: imports, limits and
policies, the bad-input error, small helpers, the Geometry record, tessellation of implicit gprims,
progress lines and the atomic file write. The Rust binary runs it (after `raysplat_curves.py`)
before the converter's parts, `raysplat_usd.py` last."""

import array
import hashlib
import io
import json
import math
import os
import re
import sys
import tempfile
import time
import zipfile
import zlib

try:  # the heavy loops over large meshes use numpy when it is there (`make setup` installs it)
    import numpy as np
except ImportError:
    np = None
if os.environ.get("RAYSPLAT_NO_NUMPY"):  # the pure-Python paths (the tests compare the two)
    np = None

if "CurveError" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_curves import CurveError, combine, curve_samples, hermite_samples, icosphere, nurbs_curve_samples, nurbs_patch, tubes
    from raysplat_crate import CrateError, check_crate

CONVERTER_VERSION = "2"
# the .rss format version written (the Rust side: scene::format::VERSION; usd::tests checks they agree)
FORMAT_VERSION = 3
MAGIC = b"RAYSPLAT"

# Tessellation of implicit gprims (segments around, rings from pole to pole).
SEGMENTS = 32
RINGS = 16
# Subdivision schemes written as cages (the renderer tessellates or refines them) and the
# interpolateBoundary rules.
SUBDIVISION_SCHEMES = {"catmullClark", "loop", "bilinear"}
BOUNDARY_RULES = {"none", "edgeOnly", "edgeAndCorner"}
# A progress line (`progress: ...` on stderr) once a conversion has run this long, then at most this
# often; the Rust binary shows them as they come.
PROGRESS_AFTER = 2.0
# Tessellation of curves (tube sides, samples per cubic segment) and points (icosphere levels), and
# the most triangles one curves or points prim may become (more: skipped, with a warning).
CURVE_SIDES = 6
CURVE_STEPS = 4
POINT_LEVELS = 1
MAX_TESSELLATED_TRIANGLES = 4000000
# The largest image side a render accepts (the renderer's limit): a larger stage resolution is ignored.
MAX_RESOLUTION = 65536
# The largest texture packaged in a .usdz that is extracted (its declared size; a larger one, as a
# zip bomb would claim, is not read and its fallback is used).
MAX_PACKAGED_TEXTURE_BYTES = 1 << 30
# Radius of a sphere light that stands for a point light (treatAsPoint or radius 0), metres.
POINT_LIGHT_RADIUS = 1e-3

# Before pxr loads: bindings on prims without MaterialBindingAPI applied still count (older assets).
os.environ.setdefault("USD_SHADE_MATERIAL_BINDING_API_CHECK", "allowMissingAPI")


class UserError(Exception):
    """Bad input: reported as `error: <file>: <prim>: <message>`, exit status 2."""

    def __init__(self, prim, message):
        super().__init__(message)
        self.prim = prim or "-"
        self.message = message


# --------------------------------------------------------------------------------------------------
# Small helpers
# --------------------------------------------------------------------------------------------------


def sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def f32_bytes(vt, width):
    """Raw little-endian f32 bytes of a Vt array of floats / float vectors (any float precision)."""
    if vt is None or len(vt) == 0:
        return b""
    mv = memoryview(vt)
    if mv.format == "f" and sys.byteorder == "little":
        return mv.tobytes()
    flat = mv.tolist()
    if flat and isinstance(flat[0], list):
        flat = [x for row in flat for x in row]
    a = array.array("f", flat)
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def int_list(vt):
    if vt is None:
        return []
    if isinstance(vt, list):
        return vt
    return memoryview(vt).tolist() if len(vt) else []


def fan_triangles(fvc, holes, left):
    """Fan triangulation of faces `fvc` (vertex counts), leaving out `holes` (a set of faces) and
    faces of fewer than 3 vertices: (corners, faces, degenerate), the corners a flat list (or numpy
    array) of face-vertex indices, three per triangle, wound the other way round when `left`; the
    face of each triangle; the number of faces of fewer than 3 vertices."""
    if np is not None:
        c = np.asarray(fvc, dtype=np.int64)
        off = np.cumsum(c) - c
        keep = c >= 3
        if holes:
            h = np.fromiter((f for f in holes if 0 <= f < len(c)), dtype=np.int64)
            keep[h] = False
        n = np.where(keep, c - 2, 0)
        face = np.repeat(np.arange(len(c)), n)
        start = np.repeat(np.cumsum(n) - n, n)
        k = np.arange(len(face)) - start + 1
        base = off[face]
        b, d = (base + k + 1, base + k) if left else (base + k, base + k + 1)
        return np.stack([base, b, d], axis=1).reshape(-1), face, int(np.count_nonzero(c < 3))
    corners, faces, degenerate, off = [], [], 0, 0
    for f, c in enumerate(fvc):
        if c >= 3 and f not in holes:
            if c == 3:
                corners.extend((off, off + 2, off + 1) if left else (off, off + 1, off + 2))
                faces.append(f)
            else:
                for k in range(1, c - 1):
                    corners.extend((off, off + k + 1, off + k) if left else (off, off + k, off + k + 1))
                    faces.append(f)
        elif c < 3:
            degenerate += 1
        off += c
    return corners, faces, degenerate


def unique_rows(columns):
    """Equal tuples across the int lists `columns` merged, numbered in order of first appearance:
    (remap, keys), remap the number of each position's tuple and keys the distinct tuples (each a
    list of column values; numpy arrays with numpy)."""
    if np is not None:
        a = np.stack([np.asarray(c, dtype=np.int64) for c in columns], axis=1)
        # one integer per tuple where they fit (sorting integers is several times faster than rows)
        span = [int(c.max()) + 1 if len(c) else 1 for c in a.T]
        if math.prod(span) < 2 ** 62:
            key = np.zeros(len(a), dtype=np.int64)
            for k, col in enumerate(a.T):
                key = key * span[k] + col
            _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
        else:
            _, first, inverse = np.unique(a, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first, kind="stable")
        rank = np.empty(len(order), dtype=np.int64)
        rank[order] = np.arange(len(order))
        return rank[inverse.reshape(-1)], a[first[order]]
    uniq = {}
    remap = [uniq.setdefault(k, len(uniq)) for k in zip(*columns)]
    return remap, list(uniq)


def take(values, idx):
    """`values[i]` for each i of `idx` (lists or numpy arrays)."""
    if np is not None:
        return np.asarray(values)[np.asarray(idx, dtype=np.int64)]
    return [values[i] for i in idx]


def chunks(data, width):
    return [data[i:i + width] for i in range(0, len(data), width)]


def gather(data, width, idx):
    """Elements `idx` of a packed array of `width`-byte elements."""
    if idx is None:
        return data
    if np is not None:
        rows = np.frombuffer(data, dtype=np.uint8).reshape(-1, width)
        return rows[np.asarray(idx, dtype=np.int64)].tobytes()
    c = chunks(data, width)
    return b"".join([c[i] for i in idx])


def u32_bytes(ints):
    if np is not None and isinstance(ints, np.ndarray):
        return ints.astype("<u4").tobytes()
    a = array.array("I", ints)
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def finite(*xs):
    return all(isinstance(x, (int, float)) and math.isfinite(x) for x in xs)


IDENTITY_2D = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
# Shaders that read a colour primvar (a material's diffuse colour per vertex).
COLOR_READERS = ("UsdPrimvarReader_float3", "UsdPrimvarReader_vector", "UsdPrimvarReader_point", "UsdPrimvarReader_normal")


def compose_2d(outer, inner):
    """The 2D affine map `outer ∘ inner` (each `[[a, b, c], [d, e, f]]`)."""
    (a, b, c), (d, e, f) = outer
    (g, h, i), (j, k, l) = inner
    return [[a * g + b * j, a * h + b * k, a * i + b * l + c], [d * g + e * j, d * h + e * k, d * i + e * l + f]]


def constant_2d(st):
    """The 2D affine map that sends every point to `st` (a texture sampled at one coordinate)."""
    return [[0.0, 0.0, float(st[0])], [0.0, 0.0, float(st[1])]]


def zero_scale(m):
    """Whether a GfMatrix4d's linear part (upper-left 3 × 3) collapses space: a finite determinant
    of (almost) zero, USD's usual way to hide a prim. A non-finite matrix is not (it is an error)."""
    det = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
           - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
           + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    return finite(det) and abs(det) < 1e-30


def luminance(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def fl(x):
    return float(x)


def vec(v, n):
    return [float(v[i]) for i in range(n)]


def clean_usd_message(text):
    text = re.sub(r"pxrInternal_v\d+_\d+(_\d+)?__pxrReserved__::", "", text)
    return " ".join(text.split())


def parse_tf_error(exc):
    """One readable line from a Tf.ErrorException (which lists every error in the chain)."""
    text = str(exc)
    msgs = re.findall(r":\s*'(.*?)'\s*(?=\n|$)", text, flags=re.S)
    msgs = [clean_usd_message(m) for m in msgs if m.strip()]
    if not msgs:
        return clean_usd_message(text) or "cannot open the stage"
    # The first error is the cause (e.g. the parse error); the last is "Failed to open layer".
    return msgs[0] if len(msgs) == 1 else "%s (%s)" % (msgs[0], msgs[-1])


class CaptureStderr:
    """Redirect fd 2 (where USD's C++ diagnostics go) into a temp file; `text` holds what was written."""

    def __init__(self):
        self.text = ""

    def __enter__(self):
        sys.stderr.flush()
        self._saved = os.dup(2)
        self._tmp = tempfile.TemporaryFile(mode="w+b")
        os.dup2(self._tmp.fileno(), 2)
        return self

    def __exit__(self, *exc):
        try:
            sys.stderr.flush()
        except Exception:
            pass
        os.dup2(self._saved, 2)
        os.close(self._saved)
        self._tmp.seek(0)
        self.text = self._tmp.read().decode("utf-8", "replace")
        self._tmp.close()
        return False


class Geometry:
    """A mesh's data for the .rss: triangles with per-vertex attributes, or (`subdivision`, a dict
    of the cage's arrays as `raysplat_usd.py` writes them) a subdivision surface's cage, its
    positions the cage's points."""
    __slots__ = ("positions", "npos", "indices", "ntri", "normals", "uvs", "colors", "tri_face", "double_sided",
                 "subdivision")

    def __init__(self, positions=None, npos=0, indices=None, ntri=0, normals=None, uvs=None, colors=None,
                 tri_face=None, double_sided=False, subdivision=None):
        self.positions, self.npos, self.indices, self.ntri = positions, npos, indices, ntri
        self.normals, self.uvs, self.colors = normals, uvs, colors
        self.tri_face, self.double_sided = tri_face, double_sided
        self.subdivision = subdivision


class Progress:
    """`progress: <what> (<seconds> s)` lines on stderr for long conversions: none in the first
    PROGRESS_AFTER seconds, then at most one per PROGRESS_AFTER seconds (or when forced)."""

    def __init__(self):
        self.t0 = self.last = time.time()
        # the stderr of now: while USD's diagnostics are captured (CaptureStderr) fd 2 is a file
        self.fd = os.dup(2)

    def __call__(self, what, force=False):
        now = time.time()
        if now - self.t0 >= PROGRESS_AFTER and (force or now - self.last >= PROGRESS_AFTER):
            os.write(self.fd, ("progress: %s (%.1f s)\n" % (what, now - self.t0)).encode("utf-8"))
            self.last = now


GPRIM_TYPES = {"Cube", "Sphere", "Cylinder", "Cylinder_1", "Cone", "Capsule", "Capsule_1", "Plane"}
# UsdRender aspectRatioConformPolicy values (the renderer applies them: src/prepare/camera.rs).
ASPECT_CONFORM = {"expandAperture", "cropAperture", "adjustApertureWidth", "adjustApertureHeight",
                  "adjustPixelAspectRatio"}
# faceVaryingLinearInterpolation rules of subdivision surfaces (FaceVaryingRule in src/scene/subdiv.rs).
FVAR_RULES = {"none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all"}
# Tessellated into triangles by raysplat_curves.py.
TESSELLATED_TYPES = {"BasisCurves", "NurbsCurves", "HermiteCurves", "Points", "NurbsPatch", "TetMesh"}


def check_finite(obj, prim, what):
    def walk(o, key):
        if isinstance(o, float):
            if not math.isfinite(o):
                raise UserError(prim, "%s parameter %s is NaN or infinite" % (what, key))
        elif isinstance(o, dict):
            for k, v in o.items():
                walk(v, k)
        elif isinstance(o, (list, tuple)):
            for v in o:
                walk(v, key)

    walk(obj, what)


def blackbody_rgb(UsdLux, kelvin):
    """Linear Rec.709 colour of a blackbody, normalised to luminance 1 (6500 K is close to white)."""
    kelvin = min(max(kelvin, 1000.0), 10000.0)
    c = UsdLux.BlackbodyTemperatureAsRgb(kelvin)
    rgb = [float(c[0]), float(c[1]), float(c[2])]
    y = luminance(rgb)
    return [x / y for x in rgb] if y > 0 else [1.0, 1.0, 1.0]


def array_f32(values):
    a = array.array("f", values)
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def point_spheres(P, widths, cols, sv, sf):
    """A points prim's spheres with numpy, the same bytes as the pure-Python loop: (positions,
    vertex count, indices, triangle count, normals, colours or None) as .rss arrays. A few large
    arrays rather than millions of tuples, so memory running out fails in one allocation (a
    MemoryError) instead of wearing the heap down object by object."""
    centres = np.asarray(P, dtype=np.float64).reshape(-1, 3)
    n = len(centres)

    def per_point(data, width):
        v, interp = data
        v = np.asarray(v, dtype=np.float64).reshape(-1, width)
        return np.broadcast_to(v[:1], (n, width)) if interp in ("constant", "uniform") else v[:n]

    radii = 0.5 * per_point(widths, 1)
    unit = np.asarray(sv, dtype=np.float64)
    pos = (centres[:, None, :] + radii[:, :, None] * unit[None, :, :]).astype("<f4")
    nrm = np.broadcast_to(unit.astype("<f4"), (n,) + unit.shape)
    base = (np.arange(n, dtype=np.int64) * len(sv))[:, None, None]
    tris = (base + np.asarray(sf, dtype=np.int64)[None, :, :]).astype("<u4")
    colors = None
    if cols:
        c = per_point(cols, 3).astype("<f4")
        colors = np.repeat(c, len(sv), axis=0).tobytes()
    return pos.tobytes(), n * len(sv), tris.tobytes(), n * len(sf), nrm.tobytes(), colors


def permute_axis(vs, axis):
    """Geometry built around +Z turned to the gprim's axis by a cyclic permutation (a rotation)."""
    if axis == "X":
        return [(z, x, y) for x, y, z in vs]
    if axis == "Y":
        return [(y, z, x) for x, y, z in vs]
    return vs


def tess_cube(size):
    h = 0.5 * size
    faces = [  # normal, u axis, v axis
        ((1, 0, 0), (0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
        ((0, 1, 0), (0, 0, 1), (1, 0, 0)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
        ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
    ]
    pos, nrm, uv, tris = [], [], [], []
    for n, u, v in faces:
        base = len(pos)
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            pos.append(tuple(h * (n[i] + a * u[i] + b * v[i]) for i in range(3)))
            nrm.append(n)
            uv.append((0.5 * (a + 1), 0.5 * (b + 1)))
        tris += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return pos, nrm, uv, tris


def sphere_profile(r):
    """(radius, z, normal_r, normal_z, v) from the south to the north pole."""
    out = []
    for i in range(RINGS + 1):
        th = math.pi * i / RINGS  # 0 at the south pole
        s, c = math.sin(th), -math.cos(th)
        out.append((r * s, r * c, s, c, i / RINGS))
    return [out]


def cylinder_profile(rb, rt, h):
    """Side, bottom cap and top cap of a (possibly conical) cylinder along Z, as separate strips."""
    hz = 0.5 * h
    slope = math.atan2(rb - rt, h)  # normal tilt of the side
    ns, nz = math.cos(slope), math.sin(slope)
    strips = [[(rb, -hz, ns, nz, 0.0), (rt, hz, ns, nz, 1.0)]]
    if rb > 0:
        strips.append([(0.0, -hz, 0.0, -1.0, 0.0), (rb, -hz, 0.0, -1.0, 1.0)])
    if rt > 0:
        strips.append([(rt, hz, 0.0, 1.0, 0.0), (0.0, hz, 0.0, 1.0, 1.0)])
    return strips


def capsule_profile(r, h):
    out = []
    half = RINGS // 2
    for i in range(half + 1):  # bottom hemisphere
        th = 0.5 * math.pi * i / half
        s, c = math.sin(th), -math.cos(th)
        out.append((r * s, -0.5 * h + r * c, s, c, 0.5 * i / half))
    for i in range(half + 1):  # top hemisphere
        th = 0.5 * math.pi + 0.5 * math.pi * i / half
        s, c = math.sin(th), -math.cos(th)
        out.append((r * s, 0.5 * h + r * c, s, c, 0.5 + 0.5 * i / half))
    return [out]


def tess_revolve(strips):
    """Surfaces of revolution about +Z from profile strips; counter-clockwise seen from outside."""
    pos, nrm, uv, tris = [], [], [], []
    for strip in strips:
        base = len(pos)
        for j in range(SEGMENTS + 1):
            ph = 2.0 * math.pi * j / SEGMENTS
            cp, sp = math.cos(ph), math.sin(ph)
            for (rr, z, nr, nz, v) in strip:
                pos.append((rr * cp, rr * sp, z))
                nrm.append((nr * cp, nr * sp, nz))
                uv.append((j / SEGMENTS, v))
        n = len(strip)
        for j in range(SEGMENTS):
            for i in range(n - 1):
                a = base + j * n + i
                b = base + (j + 1) * n + i
                # quad a (j,i), b (j+1,i), b+1, a+1; skip triangles collapsed at the axis
                if strip[i][0] > 0:
                    tris.append((a, b, b + 1))
                if strip[i + 1][0] > 0:
                    tris.append((a, b + 1, a + 1))
    return pos, nrm, uv, tris


def tess_plane(w, l):
    hw, hl = 0.5 * w, 0.5 * l
    pos = [(-hw, -hl, 0.0), (hw, -hl, 0.0), (hw, hl, 0.0), (-hw, hl, 0.0)]
    nrm = [(0.0, 0.0, 1.0)] * 4
    uv = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    return pos, nrm, uv, [(0, 1, 2), (0, 2, 3)]


def write_atomic(path, data):
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        raise UserError("-", "cannot write %s: directory %s does not exist" % (path, d))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=d)
    try:
        # the usual 0666 & ~umask, not mkstemp's 0600: other users and processes read scene files
        mask = os.umask(0)
        os.umask(mask)
        os.fchmod(fd, 0o666 & ~mask)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def read_member(z, name):
    """A member of a zip archive, refused (ValueError) when it declares more than
    MAX_PACKAGED_TEXTURE_BYTES: the declared size is checked before anything is inflated."""
    size = z.getinfo(name).file_size
    if size > MAX_PACKAGED_TEXTURE_BYTES:
        raise ValueError("it declares %d bytes, more than the %d read from a package" % (size, MAX_PACKAGED_TEXTURE_BYTES))
    with z.open(name) as f:
        data = f.read(MAX_PACKAGED_TEXTURE_BYTES + 1)
    if len(data) > MAX_PACKAGED_TEXTURE_BYTES:
        raise ValueError("it holds more than the %d bytes read from a package" % MAX_PACKAGED_TEXTURE_BYTES)
    return data
