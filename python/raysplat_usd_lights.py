"""raysplat_usd_lights.py: the converter's UsdLux lights (rect, disk, sphere, distant, dome; point
lights as small spheres) and the warnings for what of them cannot be represented (shaping, IES
profiles, geometry lights). A part of the converter (`raysplat_usd.py`), which the Rust binary runs as one
text after `raysplat_usd_common.py`."""

import os
import sys

if "UserError" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_usd_common import *  # noqa: F401,F403


class LightReader:
    """Lights of `Converter` (a mixin: the state lives in `Converter.__init__`)."""

    # ---- lights ---------------------------------------------------------------------------------
    def lattr(self, prim, name, default):
        """A UsdLux input, read with the `inputs:` prefix (USD >= 21.05) or without (older files)."""
        a = prim.GetAttribute("inputs:" + name)
        b = prim.GetAttribute(name)
        if a and a.HasAuthoredValue():
            return a.Get(self.time)
        if b and b.HasAuthoredValue():
            return b.Get(self.time)
        if a and a.HasValue():
            v = a.Get(self.time)
            if v is not None:
                return v
        return default

    def lnum(self, prim, name, default):
        v = self.lattr(prim, name, default)
        try:
            x = float(v)
        except (TypeError, ValueError):
            self.warn(prim.GetPath(), "inputs:%s has an unexpected value %r; using %g" % (name, v, default))
            return float(default)
        return x

    def lvec3(self, prim, name, default):
        v = self.lattr(prim, name, default)
        try:
            return vec(v, 3)
        except (TypeError, ValueError, IndexError):
            self.warn(prim.GetPath(), "inputs:%s has an unexpected value %r; using %s" % (name, v, default))
            return list(default)

    def emission(self, prim):
        """color * intensity * 2^exposure * blackbody(colorTemperature)."""
        path = prim.GetPath()
        color = self.lvec3(prim, "color", (1.0, 1.0, 1.0))
        intensity = self.lnum(prim, "intensity", 1.0)
        exposure = self.lnum(prim, "exposure", 0.0)
        try:
            k = intensity * math.pow(2.0, exposure)
        except OverflowError:  # an exposure beyond ~1024 stops: infinite (refused below)
            k = intensity * math.inf
        rgb = [c * k for c in color]
        if self.lattr(prim, "enableColorTemperature", False):
            temp = self.lnum(prim, "colorTemperature", 6500.0)
            if not math.isfinite(temp):
                # (usd-core's blackbody table crashes the process on NaN)
                raise UserError(str(path), "colorTemperature %r is not a finite temperature" % temp)
            bb = blackbody_rgb(self.UsdLux, temp)
            rgb = [rgb[i] * bb[i] for i in range(3)]
        for name in ("diffuse", "specular"):
            v = self.lnum(prim, name, 1.0)
            if abs(v - 1.0) > 1e-6:
                self.warn(path, "inputs:%s %g (a non-physical multiplier) is not supported; ignored" % (name, v))
        if not finite(*rgb):
            raise UserError(str(path), "light emission is NaN or infinite (color %s, intensity %r, exposure %r)"
                            % (color, intensity, exposure))
        if any(c < 0 for c in rgb):
            raise UserError(str(path), "light emission is negative (color %s, intensity %r)" % (color, intensity))
        return rgb

    def light(self, prim):
        UsdLux, Gf = self.UsdLux, self.Gf
        path = str(prim.GetPath())
        tname = prim.GetTypeName()
        if prim.GetRelationship("light:filters") and prim.GetRelationship("light:filters").GetTargets():
            self.warn(path, "light filters are not supported; ignored")
        if prim.HasAPI(UsdLux.ShadowAPI):
            se = self.lattr(prim, "shadow:enable", True)
            if not se:
                self.warn(path, "shadow:enable = false is not supported; the light casts shadows")
        for coll in ("lightLink", "shadowLink"):
            inc = prim.GetAttribute("collection:%s:includeRoot" % coll)
            exc = prim.GetRelationship("collection:%s:excludes" % coll)
            if (inc and inc.HasAuthoredValue() and not inc.Get()) or (exc and exc.GetTargets()):
                self.warn(path, "light linking (%s) is not supported; the light affects everything" % coll)
        if zero_scale(self.world(prim)):
            # zero scale, USD's usual way to hide a prim: no emitter left (as for meshes)
            self.warn(path, "transform has zero scale: the light is left out")
            return
        if prim.IsA(UsdLux.RectLight):
            self.rect_light(prim, path)
        elif prim.IsA(UsdLux.DiskLight):
            self.disk_light(prim, path)
        elif prim.IsA(UsdLux.SphereLight):
            self.sphere_light(prim, path)
        elif prim.IsA(UsdLux.DistantLight):
            self.distant_light(prim, path)
        elif prim.IsA(UsdLux.DomeLight) or tname == "DomeLight_1":
            self.dome_light(prim, path, tname)
        elif prim.IsA(UsdLux.CylinderLight):
            self.warn(path, "CylinderLight is not supported; skipped")
        elif prim.IsA(UsdLux.PortalLight):
            self.warn(path, "PortalLight is not supported; ignored")
        elif prim.IsA(UsdLux.GeometryLight):
            self.warn(path, "GeometryLight is not supported; skipped")
        else:
            self.warn(path, "light type %s is not supported; skipped" % (tname or "(LightAPI on %s)" % prim.GetTypeName()))

    def shaping_ignored(self, prim, path):
        if prim.HasAPI(self.UsdLux.ShapingAPI):
            ang = self.lnum(prim, "shaping:cone:angle", 90.0)
            foc = self.lnum(prim, "shaping:focus", 0.0)
            if ang < 90.0 or foc > 0:
                self.warn(path, "ShapingAPI (cone/focus) is only supported on SphereLight; ignored")
        self.ies_ignored(prim, path)

    def ies_ignored(self, prim, path):
        ies = self.lattr(prim, "shaping:ies:file", None)
        if ies is not None and getattr(ies, "path", ""):
            self.warn(path, "IES profiles are not supported; ignored")

    def light_texture(self, prim, path, wrap_s, wrap_t):
        asset = self.lattr(prim, "texture:file", None)
        if asset is None or not getattr(asset, "path", ""):
            return None
        attr = prim.GetAttribute("inputs:texture:file")
        if not (attr and attr.HasAuthoredValue()):
            attr = prim.GetAttribute("texture:file")
        p = self.resolve_texture(asset, attr, path)
        if not os.path.isfile(p):
            return None  # warned: rendered untextured
        desc = {"path": p, "wrap_s": wrap_s, "wrap_t": wrap_t, "scale": [1.0, 1.0, 1.0, 1.0],
                "bias": [0.0, 0.0, 0.0, 0.0], "color_space": "auto", "output": "rgb", "fallback": [1.0, 1.0, 1.0, 1.0]}
        key = json.dumps(desc, sort_keys=True)
        if key not in self._texture_index:
            desc["prim"] = str(path)
            self.textures.append(desc)
            self._texture_index[key] = len(self.textures) - 1
        return self._texture_index[key]

    def rect_light(self, prim, path):
        m = self.world(prim)
        frame, (sx, sy, sz) = self.rigid(m, path, "light")
        w = self.lnum(prim, "width", 1.0) * sx
        h = self.lnum(prim, "height", 1.0) * sy
        rgb = self.emission(prim)
        if not (w > 0 and h > 0):
            raise UserError(path, "RectLight size %g x %g m is not positive" % (w, h))
        if self.lattr(prim, "normalize", False):
            rgb = [c / (w * h) for c in rgb]
        self.shaping_ignored(prim, path)
        tex = self.light_texture(prim, path, "clamp", "clamp")
        self.lights.append({"type": "rect", "name": path, "transform": self.cols(frame), "width": w, "height": h,
                            "radiance": rgb, "texture": tex})

    def disk_light(self, prim, path):
        m = self.world(prim)
        frame, (sx, sy, sz) = self.rigid(m, path, "light")
        if abs(sx - sy) > 1e-3 * max(sx, sy):
            self.warn(path, "non-uniform scale makes an elliptic disk; rendered as a disk of equal area")
        r = self.lnum(prim, "radius", 0.5) * math.sqrt(sx * sy)
        rgb = self.emission(prim)
        if not r > 0:
            raise UserError(path, "DiskLight radius %g m is not positive" % r)
        if self.lattr(prim, "normalize", False):
            rgb = [c / (math.pi * r * r) for c in rgb]
        self.shaping_ignored(prim, path)
        self.lights.append({"type": "disk", "name": path, "transform": self.cols(frame), "radius": r, "radiance": rgb})

    def sphere_light(self, prim, path):
        m = self.world(prim)
        frame, (sx, sy, sz) = self.rigid(m, path, "light")
        if max(sx, sy, sz) - min(sx, sy, sz) > 1e-3 * max(sx, sy, sz):
            self.warn(path, "non-uniform scale makes an ellipsoid; rendered as a sphere of equal volume")
        r = self.lnum(prim, "radius", 0.5) * (sx * sy * sz) ** (1.0 / 3.0)
        if r < 0 or not math.isfinite(r):
            raise UserError(path, "SphereLight radius %g m is negative or not finite" % r)
        rgb = self.emission(prim)
        normalize = bool(self.lattr(prim, "normalize", False))
        point = bool(self.lattr(prim, "treatAsPoint", False)) or r == 0.0
        if point:
            # A point light keeps the radiant intensity (W/sr) of the authored sphere:
            #   J = L * pi r^2 (unnormalised; for r = 0, J = color*intensity*2^exposure),
            #   J = color*intensity*2^exposure / 4 (normalised: L = I / (4 pi r^2)).
            if normalize:
                j = [c / 4.0 for c in rgb]
            elif r > 0:
                j = [c * math.pi * r * r for c in rgb]
            else:
                j = rgb
            rp = min(r, POINT_LIGHT_RADIUS) if r > 0 else POINT_LIGHT_RADIUS
            rgb = [c / (math.pi * rp * rp) for c in j]
            r = rp
        elif normalize:
            rgb = [c / (4.0 * math.pi * r * r) for c in rgb]
        cone = None
        if prim.HasAPI(self.UsdLux.ShapingAPI) or prim.GetAttribute("inputs:shaping:cone:angle").HasAuthoredValue() \
                or prim.GetAttribute("shaping:cone:angle").HasAuthoredValue():
            ang = self.lnum(prim, "shaping:cone:angle", 90.0)
            soft = self.lnum(prim, "shaping:cone:softness", 0.0)
            foc = self.lnum(prim, "shaping:focus", 0.0)
            tint = self.lattr(prim, "shaping:focusTint", None)
            if foc > 0 and tint is not None and any(abs(float(x)) > 1e-6 for x in vec(tint, 3)):
                self.warn(path, "shaping:focusTint is not supported; treated as black")
            if not finite(ang, soft, foc):
                raise UserError(path, "shaping parameters are NaN or infinite")
            if ang < 180.0 or foc > 0:
                cone = {"angle_deg": min(max(ang, 0.0), 180.0), "softness": min(max(soft, 0.0), 1.0),
                        "focus": max(foc, 0.0)}
        self.ies_ignored(prim, path)
        self.lights.append({"type": "sphere", "name": path, "transform": self.cols(frame), "radius": r,
                            "radiance": rgb, "cone": cone})

    def distant_light(self, prim, path):
        Gf = self.Gf
        m = self.world(prim)
        d = Gf.Vec3d(-m[2][0], -m[2][1], -m[2][2])
        if not d.GetLength() > 0:
            raise UserError(path, "DistantLight transform is singular")
        d = d.GetNormalized()
        angle = self.lnum(prim, "angle", 0.53)
        if not (0.0 <= angle < 360.0):
            self.warn(path, "angle %g clamped to [0, 180]" % angle)
        angle = min(max(angle, 0.0), 180.0)
        # Irradiance on a surface facing the light = color * intensity * 2^exposure (docs/units.md).
        e = self.emission(prim)
        self.shaping_ignored(prim, path)
        self.lights.append({"type": "distant", "name": path, "direction": [d[0], d[1], d[2]], "angle_deg": angle,
                            "irradiance": e})

    def dome_light(self, prim, path, tname):
        Gf = self.Gf
        m = self.xf.GetLocalToWorldTransform(prim)
        pre = Gf.Matrix4d(1.0)
        if tname == "DomeLight_1":
            pole = str(prim.GetAttribute("poleAxis").Get() or "scene")
            if pole == "Z" or (pole == "scene" and self.up == "Z"):
                pre = Gf.Matrix4d(1.0).SetRotate(Gf.Rotation(Gf.Vec3d(1, 0, 0), 90.0))  # +Y pole -> +Z
        # The renderer's lat-long map follows OpenEXR/USD: local +Z at the image centre, +Y up.
        full = pre * m * self.root
        frame, _ = self.rigid(full, path, "light")
        fmt = str(self.lattr(prim, "texture:format", "automatic"))
        tex = None
        if fmt not in ("automatic", "latlong"):
            self.warn(path, "dome texture format %r is not supported (lat-long only); texture ignored" % fmt)
        else:
            tex = self.light_texture(prim, path, "repeat", "clamp")
        rgb = self.emission(prim)
        if prim.GetRelationship("portals") and prim.GetRelationship("portals").GetTargets():
            self.warn(path, "dome light portals are ignored")
        self.lights.append({"type": "dome", "name": path, "transform": self.cols(frame), "radiance": rgb,
                            "texture": tex})
