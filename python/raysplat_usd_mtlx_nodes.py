"""raysplat_usd_mtlx_nodes.py: MaterialX node networks as values the renderer's material can hold — a
constant, or one image lookup whose texture scale, bias, output channel and `st` map absorb the nodes
between it and the surface (`docs/looks.md`, "Nodes between images and the surface") — read from a
`.mtlx` document or from UsdShade shaders whose `info:id` names MaterialX node definitions. A part of
the converter (`raysplat_usd.py`); `raysplat_usd_mtlx.py` maps the surfaces."""

import os
import sys

if "UserError" not in globals():  # run as a file: the modules beside it
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from raysplat_usd_common import *  # noqa: F401,F403

# MaterialX value types: number of components (scalars 1).
MX_SIZES = {"float": 1, "integer": 1, "boolean": 1, "vector2": 2, "color3": 3, "vector3": 3, "color4": 4, "vector4": 4}
# MaterialX colour spaces -> the texture's `color_space`.
MX_COLOR_SPACES = {"srgb_texture": "sRGB", "lin_rec709": "raw", "lin_srgb": "raw", "raw": "raw", "none": "raw",
                   "acescg": "ACEScg", "lin_ap1": "ACEScg", "lin_ap1_scene": "ACEScg"}
# MaterialX address modes -> wrap modes (`constant` returns the image's `default`: black when it is 0).
MX_ADDRESS = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "constant": "black"}


class MxConst:
    """A constant: a list of floats (one for scalars)."""

    def __init__(self, v):
        self.v = [float(x) for x in v]


class MxTex:
    """`(texel · scale + bias)[channels]` of one image: `desc` is its texture description without
    scale, bias and output; `uv` the primvar its coordinates read (None: the mesh's own)."""

    def __init__(self, desc, scale, bias, channels, uv):
        self.desc, self.scale, self.bias, self.channels, self.uv = desc, list(scale), list(bias), list(channels), uv

    def copy(self):
        return MxTex(dict(self.desc), self.scale, self.bias, self.channels, self.uv)


class MxUV:
    """Texture coordinates: the primvar `name` (None: the mesh's own), mapped by the 2D affine `m`."""

    def __init__(self, name, m):
        self.name, self.m = name, m


class MxVertex:
    """A colour primvar read per vertex."""

    def __init__(self, name):
        self.name = name


class MxNormal:
    """A tangent-space normal map (`normalmap` node): its texture gives the normal in [-1, 1]."""

    def __init__(self, tex):
        self.tex = tex


def mx_list(v):
    """A MaterialX or USD value as a list of floats, or a string / number as is."""
    if isinstance(v, (str, bool)):
        return v
    if isinstance(v, (int, float)):
        return [float(v)]
    try:
        return [float(x) for x in v]
    except TypeError:
        return v


def broadcast(v, n):
    return v * n if len(v) == 1 else v[:n]


class DocGraph:
    """A node network inside a MaterialX document (`mx.Node` elements)."""

    def __init__(self, conv, doc, path):
        self.conv, self.doc, self.path = conv, doc, path

    def nodedef(self, node):
        return node.getNodeDef()

    def where(self, node):
        return "%s:%s" % (self.path, node.getNamePath())

    def input(self, node, name):
        """('value', v) | ('node', upstream node, output name) | ('default', v) | ('none',)."""
        inp = node.getInput(name)
        depth = 0
        while inp is not None and depth < 16:
            depth += 1
            iface = inp.getInterfaceInput() if inp.hasInterfaceName() else None
            if iface is not None:
                inp = iface
                continue
            up = inp.getConnectedNode()
            if up is not None:
                out = inp.getConnectedOutput()
                return ("node", up, out.getName() if out is not None and out.getParent() == up else "out")
            if inp.hasValueString():
                return ("value", inp.getValue())
            break
        nd = self.nodedef(node)
        d = nd.getActiveInput(name) if nd is not None else None
        if d is not None and d.hasValueString():
            return ("default", d.getValue())
        return ("none",)

    def file(self, node):
        """(absolute path or None, colour space, the authored path) of an image node's `file`."""
        inp = node.getInput("file")
        if inp is None or not inp.getValueString():
            return None, "", ""
        authored = inp.getResolvedValueString()
        path = authored if os.path.isabs(authored) else os.path.normpath(
            os.path.join(os.path.dirname(self.path), authored))
        # a dependency of the conversion (recorded absent when missing: adding it re-converts)
        self.conv.texture_files[os.path.abspath(path)] = True
        if not os.path.isfile(path):
            self.conv.warn(self.where(node), "texture file %s not found; its fallback is used" % path)
        return path, inp.getActiveColorSpace(), authored


class UsdGraph:
    """A node network of UsdShade shaders whose `info:id` names MaterialX node definitions."""

    def __init__(self, conv, lib):
        self.conv, self.lib = conv, lib

    def nodedef(self, node):
        return self.lib.getNodeDef(str(node.GetShaderId() or ""))

    def where(self, node):
        return str(node.GetPath())

    def input(self, node, name):
        inp = node.GetInput(name)
        if inp:
            r = self.conv.resolve(inp)
            if r[0] == "value":
                return ("value", r[1])
            if r[0] == "output":
                return ("node", r[1], r[2])
        nd = self.nodedef(node)
        d = nd.getActiveInput(name) if nd is not None else None
        if d is not None and d.hasValueString():
            return ("default", d.getValue())
        return ("none",)

    def file(self, node):
        inp = node.GetInput("file")
        if not inp:
            return None, "", ""
        r = self.conv.resolve(inp)
        if r[0] != "value" or not isinstance(r[1], self.conv.Sdf.AssetPath) or not r[1].path:
            return None, "", ""
        attr = inp.GetValueProducingAttributes(False)[0]
        path = self.conv.resolve_texture(r[1], attr, node.GetPath())
        cs = attr.GetColorSpace() if attr.HasColorSpace() else ""
        return path, cs, r[1].path

class MtlxNodes:
    """Values of MaterialX nodes for `Converter` (a mixin of `MtlxReader`)."""

    def mx_mix(self, a, b, w, where):
        """`a · (1 − w) + b · w` for a constant `w`, where one side at most is a texture."""
        if w >= 1.0 or a is None:
            return b
        if w <= 0.0 or b is None:
            return a
        if isinstance(a, MxConst) and isinstance(b, MxConst):
            return MxConst([x * (1.0 - w) + y * w for x, y in zip(broadcast(a.v, 3), broadcast(b.v, 3))])
        if isinstance(a, MxTex) and isinstance(b, MxConst):
            return self.mx_affine(a, [1.0 - w] * 3, [y * w for y in broadcast(b.v, 3)], where)
        if isinstance(b, MxTex) and isinstance(a, MxConst):
            return self.mx_affine(b, [w] * 3, [x * (1.0 - w) for x in broadcast(a.v, 3)], where)
        self.warn(where, "a blend of two textures cannot be represented; the first is used")
        return a

    def mx_eval(self, graph, node, output, depth):
        """The value of `node`'s `output` (MxConst / MxTex / MxUV / MxVertex / MxNormal), or None
        (a node the mapping cannot carry; warned)."""
        if depth > 32:
            return None
        nd = graph.nodedef(node)
        where = graph.where(node)
        if nd is None:
            self.warn(where, "no MaterialX node definition; the input it drives uses its default")
            return None
        cat = nd.getNodeString()
        outs = nd.getActiveOutputs()
        otype = outs[0].getType() if outs else ""
        for o in outs:
            if o.getName() == output:
                otype = o.getType()
        size = MX_SIZES.get(otype, 1)

        def inp(name, n=None):
            r = graph.input(node, name)
            if r[0] in ("value", "default"):
                v = mx_list(r[1])
                if isinstance(v, list) and n:
                    v = broadcast(v, n)
                return MxConst(v) if isinstance(v, list) else v
            if r[0] == "node":
                return self.mx_eval(graph, r[1], r[2], depth + 1)
            return None

        if cat == "constant":
            return inp("value", size)
        if cat in ("dot", "convert"):
            v = inp("in")
            if isinstance(v, MxConst):
                return MxConst(broadcast(v.v, size) if len(v.v) == 1 else (v.v + [1.0])[:size])
            if isinstance(v, MxTex):
                return self.mx_broadcast(v, size)
            return v
        if cat in ("image", "tiledimage"):
            return self.mx_image(graph, node, cat, size, inp, where)
        if cat == "texcoord":
            index = inp("index")
            if isinstance(index, MxConst) and index.v[0] != 0:
                self.warn(where, "texcoord index %d: the mesh's texture coordinates are used" % index.v[0])
            return MxUV("st", IDENTITY_2D)
        if cat == "geompropvalue":
            name = inp("geomprop")
            if otype == "vector2":
                return MxUV(str(name) if isinstance(name, str) and name else "st", IDENTITY_2D)
            if otype == "color3" and isinstance(name, str) and name:
                return MxVertex(name)
            self.warn(where, "geompropvalue of type %s is not supported" % otype)
            return None
        if cat == "place2d":
            return self.mx_place2d(inp, where)
        if cat == "extract":
            v, index = inp("in"), inp("index")
            i = int(index.v[0]) if isinstance(index, MxConst) else 0
            if isinstance(v, MxConst):
                return MxConst([v.v[min(i, len(v.v) - 1)]])
            if isinstance(v, MxTex) and i < len(v.channels):
                t = v.copy()
                t.channels = [v.channels[i]]
                return t
            return None
        if cat == "swizzle":
            v, chans = inp("in"), inp("channels")
            if isinstance(chans, str) and isinstance(v, (MxConst, MxTex)):
                idx = ["rgbaxyzw".index(c) % 4 for c in chans if c in "rgbaxyzw"]
                if isinstance(v, MxConst):
                    return MxConst([v.v[min(i, len(v.v) - 1)] for i in idx])
                if all(i < len(v.channels) for i in idx):
                    t = v.copy()
                    t.channels = [v.channels[i] for i in idx]
                    return t
            return None
        if cat in ("multiply", "add", "subtract", "divide"):
            return self.mx_arith(cat, inp("in1"), inp("in2"), size, where)
        if cat == "mix":
            fg, bg, mix = inp("fg", size), inp("bg", size), inp("mix")
            if isinstance(mix, MxConst):
                return self.mx_mix(bg, fg, mix.v[0], where) if size == 3 else self.mx_mix1(bg, fg, mix.v[0], where)
            self.warn(where, "mix by a texture cannot be represented; the input it drives uses its default")
            return None
        if cat == "normalmap":
            v, sc = inp("in"), inp("scale")
            s = sc.v[0] if isinstance(sc, MxConst) else 1.0
            if isinstance(v, MxTex):
                t = self.mx_broadcast(v, 3)
                if t is None:
                    return None
                t = self.mx_affine(t, [2.0 * s, 2.0 * s, 2.0], [-s, -s, -1.0], where)
                return MxNormal(t) if t is not None else None
            return None
        self.warn(where, "MaterialX node %s is not supported; the input it drives uses its default" % cat)
        return None

    def mx_mix1(self, a, b, w, where):
        if isinstance(a, MxConst) and isinstance(b, MxConst):
            return MxConst([x * (1.0 - w) + y * w for x, y in zip(a.v, b.v)])
        return self.mx_mix(a, b, w, where) if w not in (0.0, 1.0) else (b if w >= 1.0 else a)

    def mx_place2d(self, inp, where):
        tc = inp("texcoord")
        if tc is None:
            tc = MxUV("st", IDENTITY_2D)
        if not isinstance(tc, MxUV):
            return None
        c = lambda n, d: inp(n).v if isinstance(inp(n), MxConst) else d  # noqa: E731
        pivot, scale, offset = c("pivot", [0.0, 0.0]), c("scale", [1.0, 1.0]), c("offset", [0.0, 0.0])
        rot = c("rotate", [0.0])[0]
        order = c("operationorder", [0.0])[0]
        if scale[0] == 0.0 or scale[1] == 0.0:
            self.warn(where, "place2d scale 0; ignored")
            return tc
        ca, sa = math.cos(math.radians(rot)), math.sin(math.radians(rot))
        rotate = [[ca, sa, 0.0], [-sa, ca, 0.0]]  # MaterialX's rotate2d turns clockwise
        move = lambda dx, dy: [[1.0, 0.0, dx], [0.0, 1.0, dy]]  # noqa: E731
        div = [[1.0 / scale[0], 0.0, 0.0], [0.0, 1.0 / scale[1], 0.0]]
        steps = ([move(-pivot[0], -pivot[1]), div, rotate, move(-offset[0], -offset[1]), move(pivot[0], pivot[1])]
                 if order == 0 else
                 [move(-pivot[0], -pivot[1]), move(-offset[0], -offset[1]), rotate, div, move(pivot[0], pivot[1])])
        m = tc.m
        for s in steps:
            m = compose_2d(s, m)
        return MxUV(tc.name, m)

    def mx_image(self, graph, node, cat, size, inp, where):
        path, cs, authored = graph.file(node)
        default = inp("default", 4)
        fb = (default.v + [1.0] * 4)[:4] if isinstance(default, MxConst) else [0.0, 0.0, 0.0, 1.0]
        if size < 4 and isinstance(default, MxConst) and len(default.v) == 1:
            fb = [default.v[0]] * 3 + [1.0]
        if not path:
            return MxConst(fb[:size])
        tc = inp("texcoord")
        if tc is None:
            tc = MxUV("st", IDENTITY_2D)
        if not isinstance(tc, MxUV):
            self.warn(where, "texcoord is not a texture coordinate node; the mesh's texture coordinates are used")
            tc = MxUV("st", IDENTITY_2D)
        m = tc.m
        wraps = []
        if cat == "tiledimage":
            c = lambda n, d: inp(n).v if isinstance(inp(n), MxConst) else d  # noqa: E731
            tiling, offset = c("uvtiling", [1.0, 1.0]), c("uvoffset", [0.0, 0.0])
            img, tile = c("realworldimagesize", [1.0, 1.0]), c("realworldtilesize", [1.0, 1.0])
            kx, ky = tiling[0] * tile[0] / img[0], tiling[1] * tile[1] / img[1]
            m = compose_2d([[kx, 0.0, -offset[0] * tile[0] / img[0]], [0.0, ky, -offset[1] * tile[1] / img[1]]], m)
            wraps = ["repeat", "repeat"]
        else:
            for name in ("uaddressmode", "vaddressmode"):
                a = inp(name)
                a = a if isinstance(a, str) and a else "periodic"
                w = MX_ADDRESS.get(a)
                if w is None:
                    self.warn(where, "unknown %s %r; periodic is used" % (name, a))
                    w = "repeat"
                if a == "constant" and any(x != 0.0 for x in fb):
                    self.warn(where, "%s constant with a non-black default: black is used outside the image" % name)
                wraps.append(w)
        color_space = "auto"
        if cs:
            color_space = MX_COLOR_SPACES.get(cs.lower())
            if color_space is None:
                self.warn(where, "colour space %r of %s is not converted; read as linear" % (cs, authored))
                color_space = "raw"
        desc = {"path": path, "wrap_s": wraps[0], "wrap_t": wraps[1], "color_space": color_space,
                "fallback": fb, "prim": where}
        if m != IDENTITY_2D:
            desc["st_transform"] = m
        return MxTex(desc, [1.0] * 4, [0.0] * 4, list(range(min(size, 4))) if size > 1 else [0], tc.name)

    def mx_broadcast(self, t, size):
        """A texture value as `size` components (a scalar repeated; a colour cut to 3)."""
        if len(t.channels) == size:
            return t
        if len(t.channels) == 1:
            r = t.copy()
            r.channels = t.channels * size
            return r
        if len(t.channels) > size:
            r = t.copy()
            r.channels = t.channels[:size]
            return r
        return None

    def mx_affine(self, t, k, c, where):
        """`t · k + c` per component, folded into the texture's scale and bias (None when the
        components of one channel would need different factors)."""
        t = t.copy()
        done = {}
        for i, ch in enumerate(t.channels):
            ki, ci = k[min(i, len(k) - 1)], c[min(i, len(c) - 1)]
            if ch in done:
                if done[ch] != (ki, ci):
                    self.warn(where, "different factors on one texture channel cannot be represented")
                    return None
                continue
            done[ch] = (ki, ci)
            t.scale[ch] *= ki
            t.bias[ch] = t.bias[ch] * ki + ci
        return t

    def mx_arith(self, cat, a, b, size, where):
        if isinstance(a, MxConst) and isinstance(b, MxConst):
            x, y = broadcast(a.v, size), broadcast(b.v, size)
            f = {"multiply": lambda p, q: p * q, "add": lambda p, q: p + q, "subtract": lambda p, q: p - q,
                 "divide": lambda p, q: p / q if q != 0.0 else 0.0}[cat]
            return MxConst([f(p, q) for p, q in zip(x, y)])
        if isinstance(a, MxUV) and isinstance(b, MxConst) and cat in ("multiply", "add", "subtract", "divide"):
            k = broadcast(b.v, 2)
            if cat == "multiply":
                step = [[k[0], 0.0, 0.0], [0.0, k[1], 0.0]]
            elif cat == "divide" and k[0] != 0.0 and k[1] != 0.0:
                step = [[1.0 / k[0], 0.0, 0.0], [0.0, 1.0 / k[1], 0.0]]
            elif cat == "add":
                step = [[1.0, 0.0, k[0]], [0.0, 1.0, k[1]]]
            elif cat == "subtract":
                step = [[1.0, 0.0, -k[0]], [0.0, 1.0, -k[1]]]
            else:
                return None
            return MxUV(a.name, compose_2d(step, a.m))
        if isinstance(a, MxTex) and isinstance(b, MxConst):
            t = self.mx_broadcast(a, size)
            k = broadcast(b.v, size)
            if t is None:
                return None
            if cat == "multiply":
                return self.mx_affine(t, k, [0.0] * size, where)
            if cat == "divide" and all(x != 0.0 for x in k):
                return self.mx_affine(t, [1.0 / x for x in k], [0.0] * size, where)
            if cat in ("add", "subtract"):
                return self.mx_affine(t, [1.0] * size, k if cat == "add" else [-x for x in k], where)
        if isinstance(b, MxTex) and isinstance(a, MxConst):
            t = self.mx_broadcast(b, size)
            k = broadcast(a.v, size)
            if t is None:
                return None
            if cat == "multiply":
                return self.mx_affine(t, k, [0.0] * size, where)
            if cat in ("add", "subtract"):
                return self.mx_affine(t, [1.0 if cat == "add" else -1.0] * size, k, where)
        self.warn(where, "%s of these inputs cannot be represented; the input it drives uses its default" % cat)
        return None

    def mx_channel(self, t, where, name):
        """A texture value as one channel (a scalar field)."""
        if len(t.channels) == 1:
            return t
        self.warn(where, "%s reads a colour texture; its first channel is used" % name)
        r = t.copy()
        r.channels = t.channels[:1]
        return r

    def mx_texture(self, t, where, name):
        """Register a texture value (its channels selecting the output) and note its st primvar."""
        ch = t.channels
        if ch == [0, 1, 2]:
            output = "rgb"
        elif len(set(ch)) == 1 and len(ch) in (1, 3):
            output = "rgba"[ch[0]]
        else:
            self.warn(where, "%s: channels %s of a texture cannot be selected; rgb is used" % (name, ch))
            output = "rgb"
        desc = dict(t.desc)
        prim = desc.pop("prim", where)
        desc.update({"scale": t.scale, "bias": t.bias, "output": output})
        if t.uv:
            self._mx_uv.add(t.uv)
        return self.register_texture(desc, prim)

