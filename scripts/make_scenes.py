#!/usr/bin/env python3
"""Write the repository's test scenes into scenes/ with usd-core (reproducible, commit-ready .usda).

    python3 scripts/make_scenes.py [OUTPUT_DIR]      (default: scenes/ next to this script's parent)

Scenes (metres, Y up; every surface is Lambertian: UsdPreviewSurface with useSpecularWorkflow = 1,
specularColor = 0, roughness = 1, so there is no specular lobe):

- cornell-box.usda    the classic Cornell box (McGuire's/Cornell's measured geometry, in metres): white,
                      red and green walls, a short and a tall block, a RectLight just under the ceiling
                      facing down; camera looking into the box; RenderSettings 256x256. The default demo.
- bumpy-box.usda      the Cornell box with a finely tessellated bumpy floor (a 128x128-quad heightfield, bumps up
                      to 4 mm of wavelengths 28-45 mm) and a small faceted sphere (radius 5 cm); 128x128.
- furnace.usda        white furnace: a closed box seen from inside, albedo 0.5 and emission Le = 1 on every
                      wall (no other light). Every pixel converges to Le / (1 - albedo) = 2.
- plane-distant.usda  a 200 m diffuse plane (albedo 0.6) under a delta DistantLight (angle 0) of irradiance
                      E = 3 W/m^2 (intensity 3: docs/units.md) at 30 degrees from the zenith, camera looking
                      straight down: every pixel is albedo * E * cos(theta) / pi.
- plane-rect.usda     a 0.1 m diffuse patch (albedo 0.5) centred under a parallel square RectLight of side
                      s = 1 m at height d = 0.7 m with radiance L = 4 (normalize off); a narrow camera looks
                      down at the patch centre: radiance albedo * E / pi, with E from the form factor below.

- secondary-light.usda a 4 x 3 x 4 m Lambertian room (albedo 0.7, one reddish wall) with two blocks, lit mostly
                      indirectly: a SphereLight (radius 3 cm) with a ShapingAPI cone of 7 degrees aimed at a small
                      patch of the ceiling (about 0.4 m^2), the strong secondary light of the strong-secondary-lighting
                      paper's Fig. 3; 160x120.

- concave-corners.usda a 1 x 1 x 1 m Lambertian room (albedo 0.75, the x = 0 wall reddish) full of concave corners:
                      two deep niches in the back wall (a tall narrow slot and a low wide one) and a two-step
                      staircase along the x = 1 wall; a RectLight under the ceiling. Where final gathering meets
                      photon density estimation in corners (the final-gathering tests); 64x64.

The expected values are also stored in each layer's customLayerData (`raysplat:expected`), so tests can
read them rather than re-derive them.
"""

import math
import os
import sys

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_OUT = os.path.join(os.path.dirname(HERE), "scenes")


# --------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------


def new_stage(doc, expected=None):
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(root.GetPrim())
    layer = stage.GetRootLayer()
    layer.documentation = doc
    data = {"generator": "scripts/make_scenes.py"}
    if expected:
        data["raysplat:expected"] = expected
    layer.customLayerData = data
    return stage


def look_at(eye, target, up=(0.0, 1.0, 0.0)):
    """Row-vector matrix of a frame at `eye` whose local -Z points at `target` (USD cameras and lights)."""
    eye, target, up = Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(*up)
    f = (target - eye).GetNormalized()
    if abs(Gf.Dot(f, up.GetNormalized())) > 0.999:
        up = Gf.Vec3d(0.0, 0.0, -1.0)
    x = Gf.Cross(f, up).GetNormalized()
    y = Gf.Cross(x, f)
    z = -f
    return Gf.Matrix4d(x[0], x[1], x[2], 0, y[0], y[1], y[2], 0, z[0], z[1], z[2], 0, eye[0], eye[1], eye[2], 1)


def set_transform(xformable, m):
    xformable.AddTransformOp().Set(m)


def lambert(stage, path, albedo, emission=None):
    parent = path.rsplit("/", 1)[0]
    if not stage.GetPrimAtPath(parent):
        UsdGeom.Scope.Define(stage, parent)
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/PreviewSurface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*albedo))
    sh.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
    sh.CreateInput("specularColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.0, 0.0, 0.0))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    if emission is not None:
        sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*emission))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def preview(stage, path, diffuse, specular, roughness, opacity=1.0, ior=1.5):
    """A UsdPreviewSurface in the specular workflow (glossy, or glass with opacity 0)."""
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/PreviewSurface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*diffuse))
    sh.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
    sh.CreateInput("specularColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*specular))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    sh.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(opacity)
    sh.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(ior)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def bind(prim, mat):
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(mat)


def sub(a, b):
    return tuple(a[i] - b[i] for i in range(3))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def quad_mesh(stage, path, quads, facing):
    """A mesh of quads; each quad's winding is chosen so that its normal points along
    `facing(centre, normal)` > 0 (e.g. into the box, or out of a block)."""
    points, counts, indices = [], [], []
    for q in quads:
        n = cross(sub(q[1], q[0]), sub(q[2], q[0]))
        c = tuple(sum(p[i] for p in q) / 4.0 for i in range(3))
        if facing(c, n) < 0:
            q = list(reversed(q))
        base = len(points)
        points.extend(q)
        counts.append(4)
        indices.extend(range(base, base + 4))
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    m.CreateFaceVertexCountsAttr(Vt.IntArray(counts))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray(indices))
    m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    lo = [min(p[i] for p in points) for i in range(3)]
    hi = [max(p[i] for p in points) for i in range(3)]
    m.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*lo), Gf.Vec3f(*hi)]))
    return m


def camera(stage, path, m, focal_length, h_aperture, v_aperture, clipping):
    cam = UsdGeom.Camera.Define(stage, path)
    set_transform(cam, m)
    cam.CreateProjectionAttr(UsdGeom.Tokens.perspective)
    cam.CreateFocalLengthAttr(focal_length)
    cam.CreateHorizontalApertureAttr(h_aperture)
    cam.CreateVerticalApertureAttr(v_aperture)
    cam.CreateClippingRangeAttr(Gf.Vec2f(*clipping))
    return cam


def render_settings(stage, cam_path, w, h):
    UsdGeom.Scope.Define(stage, "/Render")
    rs = UsdRender.Settings.Define(stage, "/Render/Settings")
    rs.CreateResolutionAttr(Gf.Vec2i(w, h))
    rs.CreateCameraRel().SetTargets([cam_path])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")


def aperture_for_fov(focal_length, fov_deg):
    return 2.0 * focal_length * math.tan(0.5 * math.radians(fov_deg))


# --------------------------------------------------------------------------------------------------
# scenes
# --------------------------------------------------------------------------------------------------


def cornell_box(doc=None, bumpy_floor=False, sphere=False, resolution=(256, 256), glossy=False):
    """The Cornell box. With `bumpy_floor` the floor is a finely tessellated heightfield (`bumpy_floor_mesh`)
    and the blocks reach below its lowest point; with `sphere` a small tessellated sphere stands on it.
    With `glossy` the tall block is a moderately glossy UsdPreviewSurface and the sphere is glass."""
    mm = 0.001  # the measured data is in millimetres
    P = lambda x, y, z: (x * mm, y * mm, z * mm)
    stage = new_stage(doc or ("The Cornell box (measured geometry of the Cornell University Program of Computer "
                              "Graphics, in metres), Lambertian walls, a RectLight under the ceiling. Written by "
                              "scripts/make_scenes.py."))
    white = lambert(stage, "/World/Looks/White", (0.73, 0.73, 0.73))
    red = lambert(stage, "/World/Looks/Red", (0.65, 0.05, 0.05))
    green = lambert(stage, "/World/Looks/Green", (0.12, 0.45, 0.15))
    centre = P(278.0, 274.4, 279.6)
    inward = lambda c, n: dot(n, sub(centre, c))
    UsdGeom.Scope.Define(stage, "/World/Geometry")
    floor = [P(552.8, 0, 0), P(0, 0, 0), P(0, 0, 559.2), P(549.6, 0, 559.2)]
    walls = quad_mesh(stage, "/World/Geometry/Walls", ([] if bumpy_floor else [floor]) + [
        [P(556.0, 548.8, 0), P(556.0, 548.8, 559.2), P(0, 548.8, 559.2), P(0, 548.8, 0)],  # ceiling
        [P(549.6, 0, 559.2), P(0, 0, 559.2), P(0, 548.8, 559.2), P(556.0, 548.8, 559.2)],  # back wall
    ], inward)
    bind(walls.GetPrim(), white)
    if bumpy_floor:
        bind(bumpy_floor_mesh(stage, "/World/Geometry/BumpyFloor", floor).GetPrim(), white)
    left = quad_mesh(stage, "/World/Geometry/RedWall", [
        [P(552.8, 0, 0), P(549.6, 0, 559.2), P(556.0, 548.8, 559.2), P(556.0, 548.8, 0)]], inward)
    bind(left.GetPrim(), red)
    right = quad_mesh(stage, "/World/Geometry/GreenWall", [
        [P(0, 0, 559.2), P(0, 0, 0), P(0, 548.8, 0), P(0, 548.8, 559.2)]], inward)
    bind(right.GetPrim(), green)
    bottom = -BUMP_AMPLITUDE if bumpy_floor else 0.0

    def block(path, top, height):
        c = tuple(sum(p[i] for p in top) / 4.0 for i in range(3))
        c = (c[0], 0.5 * height, c[2])
        out = lambda cc, n: dot(n, sub(cc, c))
        quads = [[t for t in top]]
        for i in range(4):
            a, b = top[i], top[(i + 1) % 4]
            quads.append([a, b, (b[0], bottom, b[2]), (a[0], bottom, a[2])])
        m = quad_mesh(stage, path, quads, out)
        bind(m.GetPrim(), glossy_mat if glossy and "Tall" in path else white)

    if glossy:
        glossy_mat = preview(stage, "/World/Looks/Glossy", (0.25, 0.25, 0.3), (0.6, 0.6, 0.6), 0.3)
        glass = preview(stage, "/World/Looks/Glass", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 0.0, opacity=0.0, ior=1.5)

    block("/World/Geometry/ShortBlock", [P(130.0, 165.0, 65.0), P(82.0, 165.0, 225.0), P(240.0, 165.0, 272.0),
                                         P(290.0, 165.0, 114.0)], 165.0 * mm)
    block("/World/Geometry/TallBlock", [P(423.0, 330.0, 247.0), P(265.0, 330.0, 296.0), P(314.0, 330.0, 456.0),
                                        P(472.0, 330.0, 406.0)], 330.0 * mm)
    if sphere:
        if glossy:
            bind(sphere_mesh(stage, "/World/Geometry/GlassSphere", P(400.0, 80.0, 120.0), 80.0 * mm, 64, 32).GetPrim(),
                 glass)
        else:
            bind(sphere_mesh(stage, "/World/Geometry/Sphere", P(420.0, 50.0, 130.0), 50.0 * mm, 32, 16).GetPrim(),
                 white)
    UsdGeom.Scope.Define(stage, "/World/Lights")
    light = UsdLux.RectLight.Define(stage, "/World/Lights/CeilingLight")
    # The measured opening is 130 x 105 mm at (213..343, 227..332); the light hangs 0.5 mm below the
    # ceiling and faces down (local -Z -> world -Y). Radiance (17, 12, 4) W/(sr m^2), the classic value.
    set_transform(light, look_at(P(278.0, 548.3, 279.5), P(278.0, 0.0, 279.5), up=(0.0, 0.0, 1.0)))
    light.CreateWidthAttr(130.0 * mm)
    light.CreateHeightAttr(105.0 * mm)
    light.CreateIntensityAttr(17.0)
    light.CreateColorAttr(Gf.Vec3f(1.0, 12.0 / 17.0, 4.0 / 17.0))
    light.CreateNormalizeAttr(False)
    # Camera of the measured setup: at (278, 273, -800) mm looking along +Z, 35 mm lens, 25 mm film.
    cam = camera(stage, "/World/Camera", look_at(P(278.0, 273.0, -800.0), P(278.0, 273.0, 0.0)),
                 35.0, 25.0, 25.0, (0.01, 100.0))
    render_settings(stage, cam.GetPath(), *resolution)
    return stage


# Bumpy floor: GRID x GRID quads over the floor quadrilateral, heights up to BUMP_AMPLITUDE (metres).
BUMP_GRID = 128
BUMP_AMPLITUDE = 0.004
# Height = BUMP_AMPLITUDE * sum of weight * sin(2 pi (x kx + z kz) + phase) / sum of weights,
# wavelengths 28-45 mm (7-10 grid cells), tapered to 0 within BUMP_TAPER of the walls.
BUMP_WAVES = [(1.0, 1.0 / 0.036, 1.0 / 0.041, 0.3), (0.7, 1.0 / 0.029, -1.0 / 0.045, 1.7),
              (0.5, -1.0 / 0.052, 1.0 / 0.028, 4.1)]
BUMP_TAPER = 0.02


def bump_height(x, z, dist_to_edge):
    wsum = sum(w[0] for w in BUMP_WAVES)
    h = sum(w * math.sin(2.0 * math.pi * (x * kx + z * kz) + ph) for w, kx, kz, ph in BUMP_WAVES) / wsum
    return BUMP_AMPLITUDE * h * min(1.0, dist_to_edge / BUMP_TAPER)


def bumpy_floor_mesh(stage, path, corners):
    """A heightfield over the planar quadrilateral `corners` (y = 0, bilinear in (u, v)), faceted (no
    authored normals): BUMP_GRID^2 quads whose normals point up."""
    n = BUMP_GRID
    points = []
    for j in range(n + 1):
        v = j / n
        for i in range(n + 1):
            u = i / n
            a = [corners[0][k] + (corners[1][k] - corners[0][k]) * u for k in range(3)]
            b = [corners[3][k] + (corners[2][k] - corners[3][k]) * u for k in range(3)]
            p = [a[k] + (b[k] - a[k]) * v for k in range(3)]
            # distance to the nearest edge of the (nearly rectangular) floor, along the grid parameters
            du = min(u, 1.0 - u) * abs(corners[0][0] - corners[1][0])
            dv = min(v, 1.0 - v) * abs(corners[3][2] - corners[0][2])
            points.append((p[0], bump_height(p[0], p[2], min(du, dv)), p[2]))
    counts, indices = [], []
    for j in range(n):
        for i in range(n):
            a, b = j * (n + 1) + i, j * (n + 1) + i + 1
            c, d = b + n + 1, a + n + 1
            q = [a, b, c, d]
            nrm = cross(sub(points[b], points[a]), sub(points[c], points[a]))
            if nrm[1] < 0:
                q.reverse()
            counts.append(4)
            indices.extend(q)
    return poly_mesh(stage, path, points, counts, indices)


def sphere_mesh(stage, path, centre, radius, segments, rings):
    """A faceted UV sphere (triangles at the poles, quads between) with outward normals."""
    points = [(centre[0], centre[1] + radius, centre[2])]
    for r in range(1, rings):
        th = math.pi * r / rings
        for s in range(segments):
            ph = 2.0 * math.pi * s / segments
            points.append((centre[0] + radius * math.sin(th) * math.cos(ph), centre[1] + radius * math.cos(th),
                           centre[2] + radius * math.sin(th) * math.sin(ph)))
    points.append((centre[0], centre[1] - radius, centre[2]))
    south = len(points) - 1
    ring = lambda r, s: 1 + (r - 1) * segments + s % segments
    faces = [[0, ring(1, s + 1), ring(1, s)] for s in range(segments)]
    for r in range(1, rings - 1):
        faces += [[ring(r, s), ring(r, s + 1), ring(r + 1, s + 1), ring(r + 1, s)] for s in range(segments)]
    faces += [[ring(rings - 1, s), ring(rings - 1, s + 1), south] for s in range(segments)]
    counts, indices = [], []
    for f in faces:
        c = tuple(sum(points[i][k] for i in f) / len(f) for k in range(3))
        nrm = cross(sub(points[f[1]], points[f[0]]), sub(points[f[2]], points[f[0]]))
        if dot(nrm, sub(c, centre)) < 0:
            f = list(reversed(f))
        counts.append(len(f))
        indices.extend(f)
    return poly_mesh(stage, path, points, counts, indices)


def poly_mesh(stage, path, points, counts, indices):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    m.CreateFaceVertexCountsAttr(Vt.IntArray(counts))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray(indices))
    m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    lo = [min(p[i] for p in points) for i in range(3)]
    hi = [max(p[i] for p in points) for i in range(3)]
    m.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*lo), Gf.Vec3f(*hi)]))
    return m


def bumpy_box():
    return cornell_box(
        doc="The Cornell box of cornell-box.usda with a bumpy floor: a faceted heightfield of %dx%d quads (cells "
            "of about 4.3 mm) whose height, a sum of three sinusoids of wavelengths 28-45 mm, reaches %g mm "
            "(tapered to 0 at the walls; the blocks reach below it), and a faceted sphere (radius 50 mm, "
            "32x16 segments) on the floor. Lambertian, RectLight, RenderSettings 128x128. For the accuracy "
            "of photon density estimation on finely tessellated surfaces (topological and boundary bias). "
            "Written by scripts/make_scenes.py." % (BUMP_GRID, BUMP_GRID, BUMP_AMPLITUDE * 1000.0),
        bumpy_floor=True, sphere=True, resolution=(128, 128))


def cornell_glossy():
    return cornell_box(
        doc="The paper's CORNELL BOX I in spirit (photon-ray-splatting.md, Fig. 9): the Cornell box of "
            "cornell-box.usda with the bumpy floor of bumpy-box.usda (%dx%d faceted quads), a moderately glossy "
            "tall block (UsdPreviewSurface, specular workflow, specularColor 0.6, roughness 0.3, diffuse 0.25) and "
            "a glass sphere (radius 80 mm, ior 1.5, 64x32 faceted segments) that focuses a caustic on the floor. "
            "RenderSettings 128x128. For glossy transport by radiance maps (--glossy sh / histogram). "
            "Written by scripts/make_scenes.py." % (BUMP_GRID, BUMP_GRID),
        bumpy_floor=True, sphere=True, resolution=(128, 128), glossy=True)


def furnace(albedo=0.5, le=1.0):
    expected = le / (1.0 - albedo)
    stage = new_stage("White furnace: a closed box (side 2 m) seen from inside; every wall has albedo %g and "
                      "emits Le = %g. With no other light, radiance is Le / (1 - albedo) = %g everywhere. "
                      "Written by scripts/make_scenes.py." % (albedo, le, expected),
                      expected={"pixel_radiance": expected, "albedo": albedo, "emission": le})
    mat = lambert(stage, "/World/Looks/Wall", (albedo,) * 3, emission=(le,) * 3)
    corners = [(x, y, z) for z in (-1.0, 1.0) for y in (-1.0, 1.0) for x in (-1.0, 1.0)]
    faces = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]]
    quads = [[corners[i] for i in f] for f in faces]
    box = quad_mesh(stage, "/World/Box", quads, lambda c, n: dot(n, sub((0.0, 0.0, 0.0), c)))
    bind(box.GetPrim(), mat)
    cam = camera(stage, "/World/Camera", look_at((0.1, 0.2, 0.3), (0.5, 0.1, -1.0)), 50.0,
                 aperture_for_fov(50.0, 60.0), aperture_for_fov(50.0, 60.0), (0.001, 100.0))
    render_settings(stage, cam.GetPath(), 32, 32)
    return stage


def plane_distant(albedo=0.6, irradiance=3.0, theta_deg=30.0):
    t = math.radians(theta_deg)
    expected = albedo * irradiance * math.cos(t) / math.pi
    stage = new_stage("A 200 m Lambertian plane (albedo %g) under a delta DistantLight of irradiance %g W/m^2 "
                      "(intensity = irradiance on a surface facing the light, docs/units.md) travelling at "
                      "%g degrees from the zenith. Camera straight down. Every pixel: albedo * E * cos(theta) "
                      "/ pi = %.6f. Written by scripts/make_scenes.py." % (albedo, irradiance, theta_deg, expected),
                      expected={"pixel_radiance": expected, "albedo": albedo, "irradiance": irradiance,
                                "theta_deg": theta_deg})
    mat = lambert(stage, "/World/Looks/Plane", (albedo,) * 3)
    h = 100.0
    plane = quad_mesh(stage, "/World/Plane", [[(-h, 0.0, -h), (h, 0.0, -h), (h, 0.0, h), (-h, 0.0, h)]],
                      lambda c, n: n[1])
    bind(plane.GetPrim(), mat)
    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    direction = (math.sin(t), -math.cos(t), 0.0)  # the way the light travels
    set_transform(sun, look_at((0.0, 0.0, 0.0), direction))
    sun.CreateIntensityAttr(irradiance)
    sun.CreateAngleAttr(0.0)
    cam = camera(stage, "/World/Camera", look_at((0.0, 2.0, 0.0), (0.0, 0.0, 0.0)), 50.0,
                 aperture_for_fov(50.0, 40.0), aperture_for_fov(50.0, 40.0), (0.001, 1000.0))
    render_settings(stage, cam.GetPath(), 16, 16)
    return stage


def square_light_irradiance(radiance, side, distance):
    """Irradiance below the centre of a parallel square Lambertian emitter.

    Form factor from a point (differential area) to a parallel rectangle of size a x b at distance d, with
    the point below one corner (X = a/d, Y = b/d):
        F = 1/(2 pi) * [ X/sqrt(1+X^2) * atan(Y/sqrt(1+X^2)) + Y/sqrt(1+Y^2) * atan(X/sqrt(1+Y^2)) ]
    Below the centre the square splits into four such corner rectangles of size s/2 x s/2, so
        E = pi * L * 4 * F(X = Y = s / (2 d)).
    """
    x = y = 0.5 * side / distance
    f = (x / math.sqrt(1 + x * x) * math.atan(y / math.sqrt(1 + x * x))
         + y / math.sqrt(1 + y * y) * math.atan(x / math.sqrt(1 + y * y))) / (2.0 * math.pi)
    return math.pi * radiance * 4.0 * f


def plane_rect(albedo=0.5, radiance=4.0, side=1.0, distance=0.7):
    e = square_light_irradiance(radiance, side, distance)
    expected = albedo * e / math.pi
    stage = new_stage(
        "A 0.1 m Lambertian patch (albedo %g) centred under a parallel square RectLight (side %g m, height %g m, "
        "radiance %g, normalize off) facing down. Irradiance at the patch centre from the form factor of "
        "parallel rectangles: four corner rectangles with X = Y = s/(2d), "
        "F = [X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + Y/sqrt(1+Y^2) atan(X/sqrt(1+Y^2))] / (2 pi), "
        "E = pi L 4 F = %.6f W/m^2; the camera (1 degree field of view, above the light, looking down through "
        "its back) sees radiance albedo E / pi = %.6f. Written by scripts/make_scenes.py."
        % (albedo, side, distance, radiance, e, expected),
        expected={"pixel_radiance": expected, "irradiance": e, "albedo": albedo, "light_radiance": radiance,
                  "side": side, "distance": distance})
    mat = lambert(stage, "/World/Looks/Patch", (albedo,) * 3)
    h = 0.05 * side
    patch = quad_mesh(stage, "/World/Patch", [[(-h, 0.0, -h), (h, 0.0, -h), (h, 0.0, h), (-h, 0.0, h)]],
                      lambda c, n: n[1])
    bind(patch.GetPrim(), mat)
    light = UsdLux.RectLight.Define(stage, "/World/Light")
    set_transform(light, look_at((0.0, distance, 0.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)))
    light.CreateWidthAttr(side)
    light.CreateHeightAttr(side)
    light.CreateIntensityAttr(radiance)
    light.CreateNormalizeAttr(False)
    cam = camera(stage, "/World/Camera", look_at((0.0, 2.0 * distance, 0.0), (0.0, 0.0, 0.0)), 50.0,
                 aperture_for_fov(50.0, 1.0), aperture_for_fov(50.0, 1.0), (0.001, 100.0))
    render_settings(stage, cam.GetPath(), 8, 8)
    return stage


def secondary_light():
    stage = new_stage("A 4 x 3 x 4 m Lambertian room (albedo 0.7, the left wall reddish) with two blocks, lit mostly "
                      "indirectly: a small SphereLight (radius 3 cm) with a ShapingAPI cone of 7 degrees aims at a "
                      "patch of about 0.4 m^2 on the ceiling, which becomes a strong secondary light source "
                      "(Tawara, Myszkowski and Seidel, Fig. 3). Written by scripts/make_scenes.py.")
    white = lambert(stage, "/World/Looks/White", (0.7, 0.7, 0.7))
    red = lambert(stage, "/World/Looks/Red", (0.7, 0.35, 0.3))
    lo, hi = (-2.0, 0.0, -2.0), (2.0, 3.0, 2.0)
    centre = tuple(0.5 * (lo[i] + hi[i]) for i in range(3))
    inward = lambda c, n: dot(n, sub(centre, c))
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    UsdGeom.Scope.Define(stage, "/World/Geometry")
    walls = quad_mesh(stage, "/World/Geometry/Walls", [
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],  # floor
        [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],  # ceiling
        [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],  # back
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],  # front
        [(x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)],  # right
    ], inward)
    bind(walls.GetPrim(), white)
    left = quad_mesh(stage, "/World/Geometry/LeftWall", [[(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)]],
                     inward)
    bind(left.GetPrim(), red)

    def block(path, c, h, s):
        cc = (c[0], 0.5 * h, c[1])
        out = lambda q, n: dot(n, sub(q, cc))
        a0, a1, b0, b1 = c[0] - s, c[0] + s, c[1] - s, c[1] + s
        quads = [[(a0, h, b0), (a1, h, b0), (a1, h, b1), (a0, h, b1)],
                 [(a0, 0, b0), (a1, 0, b0), (a1, h, b0), (a0, h, b0)],
                 [(a0, 0, b1), (a1, 0, b1), (a1, h, b1), (a0, h, b1)],
                 [(a0, 0, b0), (a0, 0, b1), (a0, h, b1), (a0, h, b0)],
                 [(a1, 0, b0), (a1, 0, b1), (a1, h, b1), (a1, h, b0)]]
        bind(quad_mesh(stage, path, quads, out).GetPrim(), white)

    block("/World/Geometry/TallBlock", (0.9, -0.9), 1.4, 0.3)
    block("/World/Geometry/ShortBlock", (-0.9, 0.4), 0.6, 0.35)
    UsdGeom.Scope.Define(stage, "/World/Lights")
    spot = UsdLux.SphereLight.Define(stage, "/World/Lights/Spot")
    set_transform(spot, look_at((0.6, 1.0, 0.2), (-0.8, 3.0, -0.8)))
    spot.CreateRadiusAttr(0.03)
    spot.CreateIntensityAttr(200000.0)
    spot.CreateNormalizeAttr(False)
    shaping = UsdLux.ShapingAPI.Apply(spot.GetPrim())
    shaping.CreateShapingConeAngleAttr(7.0)
    shaping.CreateShapingConeSoftnessAttr(0.0)
    cam = camera(stage, "/World/Camera", look_at((0.0, 1.5, 1.9), (-0.3, 1.7, -2.0)), 24.0,
                 aperture_for_fov(24.0, 80.0), aperture_for_fov(24.0, 80.0) * 0.75, (0.01, 100.0))
    render_settings(stage, cam.GetPath(), 160, 120)
    return stage


def concave_corners():
    stage = new_stage("A 1 x 1 x 1 m Lambertian room (albedo 0.75, the x = 0 wall reddish) with two deep niches in "
                      "the back wall and a two-step staircase along the x = 1 wall: many concave corners, lit by a "
                      "RectLight under the ceiling. Written by scripts/make_scenes.py.")
    white = lambert(stage, "/World/Looks/White", (0.75, 0.75, 0.75))
    red = lambert(stage, "/World/Looks/Red", (0.7, 0.2, 0.15))
    UsdGeom.Scope.Define(stage, "/World/Geometry")
    inward = lambda c, n: dot(n, sub((0.5, 0.5, 0.5), c))
    walls = quad_mesh(stage, "/World/Geometry/Walls", [
        [(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)],  # floor
        [(0, 1, 0), (1, 1, 0), (1, 1, 1), (0, 1, 1)],  # ceiling
        [(1, 0, 0), (1, 0, 1), (1, 1, 1), (1, 1, 0)],  # right
    ], inward)
    bind(walls.GetPrim(), white)
    left = quad_mesh(stage, "/World/Geometry/LeftWall", [[(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)]], inward)
    bind(left.GetPrim(), red)
    # Back wall (z = 1) around the niche openings; each niche is a box cavity reaching back to z = depth.
    niches = [(0.2, 0.32, 0.3, 0.75, 1.25), (0.5, 0.75, 0.12, 0.27, 1.15)]  # x0, x1, y0, y1, depth
    xs = sorted({0.0, 1.0} | {n[0] for n in niches} | {n[1] for n in niches})
    ys = sorted({0.0, 1.0} | {n[2] for n in niches} | {n[3] for n in niches})
    back = []
    for i in range(len(xs) - 1):
        for j in range(len(ys) - 1):
            cx, cy = 0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1])
            if any(n[0] < cx < n[1] and n[2] < cy < n[3] for n in niches):
                continue
            back.append([(xs[i], ys[j], 1.0), (xs[i + 1], ys[j], 1.0), (xs[i + 1], ys[j + 1], 1.0),
                         (xs[i], ys[j + 1], 1.0)])
    cavity = []
    for (x0, x1, y0, y1, d) in niches:
        cavity += [[(x0, y0, d), (x1, y0, d), (x1, y1, d), (x0, y1, d)],  # back of the niche
                   [(x0, y0, 1), (x1, y0, 1), (x1, y0, d), (x0, y0, d)],  # bottom
                   [(x0, y1, 1), (x1, y1, 1), (x1, y1, d), (x0, y1, d)],  # top
                   [(x0, y0, 1), (x0, y1, 1), (x0, y1, d), (x0, y0, d)],  # left
                   [(x1, y0, 1), (x1, y1, 1), (x1, y1, d), (x1, y0, d)]]  # right
    # Walls face into the room; a niche's faces face into the niche (toward its centre line).
    mid = lambda n: (0.5 * (n[0] + n[1]), 0.5 * (n[2] + n[3]), 0.5 * (1.0 + n[4]))
    def facing(c, nrm):
        for n in niches:
            if n[0] - 1e-6 <= c[0] <= n[1] + 1e-6 and n[2] - 1e-6 <= c[1] <= n[3] + 1e-6 and c[2] > 1.0 + 1e-6:
                return dot(nrm, sub(mid(n), c))
        return inward(c, nrm)
    bind(quad_mesh(stage, "/World/Geometry/BackWall", back + cavity, facing).GetPrim(), white)

    def block(path, x0, x1, y1, z0, z1):
        cc = (0.5 * (x0 + x1), 0.5 * y1, 0.5 * (z0 + z1))
        out = lambda q, n: dot(n, sub(q, cc))
        quads = [[(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],
                 [(x0, 0, z0), (x1, 0, z0), (x1, y1, z0), (x0, y1, z0)],
                 [(x0, 0, z0), (x0, 0, z1), (x0, y1, z1), (x0, y1, z0)]]
        bind(quad_mesh(stage, path, quads, out).GetPrim(), white)

    block("/World/Geometry/LowStep", 0.7, 1.0, 0.15, 0.35, 1.0)
    block("/World/Geometry/HighStep", 0.85, 1.0, 0.3, 0.5, 1.0)
    UsdGeom.Scope.Define(stage, "/World/Lights")
    light = UsdLux.RectLight.Define(stage, "/World/Lights/CeilingLight")
    set_transform(light, look_at((0.5, 0.999, 0.5), (0.5, 0.0, 0.5), up=(0.0, 0.0, 1.0)))
    light.CreateWidthAttr(0.25)
    light.CreateHeightAttr(0.25)
    light.CreateIntensityAttr(10.0)
    light.CreateNormalizeAttr(False)
    cam = camera(stage, "/World/Camera", look_at((0.5, 0.5, -1.1), (0.5, 0.5, 0.0)), 35.0,
                 aperture_for_fov(35.0, 42.0), aperture_for_fov(35.0, 42.0), (0.01, 100.0))
    render_settings(stage, cam.GetPath(), 64, 64)
    return stage


SCENES = {
    "cornell-box.usda": cornell_box,
    "furnace.usda": furnace,
    "plane-distant.usda": plane_distant,
    "plane-rect.usda": plane_rect,
    "bumpy-box.usda": bumpy_box,
    "cornell-glossy.usda": cornell_glossy,
    "secondary-light.usda": secondary_light,
    "concave-corners.usda": concave_corners,
}


def main(argv):
    out_dir = argv[0] if argv else DEFAULT_OUT
    os.makedirs(out_dir, exist_ok=True)
    for name, make in SCENES.items():
        stage = make()
        path = os.path.join(out_dir, name)
        text = stage.GetRootLayer().ExportToString()
        tmp = path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
        print("wrote %s" % path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
