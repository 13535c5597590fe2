"""raysplat_crate.py: the sizes a crate (.usdc) file declares, checked against the file's size before
usd-core reads it. usd-core allocates what a crate file's counts claim before it finds that the
file cannot hold that much: a 849-byte file whose token count says 2^30 made it take 8.5 GB. The
check reads the table of contents, the section headers and every array value's count (the
layout of usd's `crateFile.cpp`, versions 0.4 to 0.x) and refuses a count that the bytes after it
cannot encode, naming the prim whose field holds it. Anything it does not understand it leaves to
usd-core; the converter's memory limit (`--memory-limit`) stays the last guard.

Standard library only (a part of the converter, embedded in the Rust binary)."""

import struct

# Elements a compressed stream may decode per byte of it: LZ4 expands at most 255 times, and
# usd's integer coding stores an integer in 2 bits at the least (4 per byte).
MAX_EXPANSION = 4 * 255
BOOTSTRAP = 88
# Bytes per element of the array value types (crateDataTypes.h); others count 1.
ELEMENT_BYTES = {1: 1, 2: 1, 3: 4, 4: 4, 5: 8, 6: 8, 7: 2, 8: 4, 9: 8, 10: 4, 11: 4, 12: 4, 13: 32, 14: 72,
                 15: 128, 16: 32, 17: 16, 18: 8, 19: 16, 20: 8, 21: 4, 22: 8, 23: 24, 24: 12, 25: 6, 26: 12,
                 27: 32, 28: 16, 29: 8, 30: 16}


class CrateError(Exception):
    """A declared size the file cannot hold: `prim` (or "-") and a message."""

    def __init__(self, prim, message):
        super().__init__(message)
        self.prim = prim
        self.message = message


class Unreadable(Exception):
    """A structure the check does not follow (left to usd-core)."""


def u64(data, at):
    if at < 0 or at + 8 > len(data):
        raise Unreadable("read past the end")
    return struct.unpack_from("<Q", data, at)[0]


def lz4_block(src, max_out):
    """Decompress one LZ4 block of at most `max_out` bytes."""
    out = bytearray()
    i, n = 0, len(src)
    while i < n:
        token = src[i]
        i += 1
        lit = token >> 4
        if lit == 15:
            while True:
                if i >= n:
                    raise Unreadable("truncated LZ4 block")
                b = src[i]
                i += 1
                lit += b
                if b != 255:
                    break
        if i + lit > n or len(out) + lit > max_out:
            raise Unreadable("LZ4 literals out of range")
        out += src[i:i + lit]
        i += lit
        if i >= n:
            break
        if i + 2 > n:
            raise Unreadable("truncated LZ4 block")
        off = src[i] | (src[i + 1] << 8)
        i += 2
        if off == 0 or off > len(out):
            raise Unreadable("LZ4 offset out of range")
        ml = token & 15
        if ml == 15:
            while True:
                if i >= n:
                    raise Unreadable("truncated LZ4 block")
                b = src[i]
                i += 1
                ml += b
                if b != 255:
                    break
        ml += 4
        if len(out) + ml > max_out:
            raise Unreadable("LZ4 output too long")
        start = len(out) - off
        if off >= ml:
            out += out[start:start + ml]
        else:
            piece = bytes(out[start:])
            out += (piece * (ml // off + 1))[:ml]
    return bytes(out)


def fast_decompress(src, max_out):
    """usd's TfFastCompression: a chunk count, then LZ4 blocks (one when the count is 0)."""
    if not src:
        raise Unreadable("empty compressed buffer")
    chunks = src[0]
    if chunks == 0:
        return lz4_block(src[1:], max_out)
    out, i = bytearray(), 1
    for _ in range(chunks):
        if i + 4 > len(src):
            raise Unreadable("truncated chunk")
        size = struct.unpack_from("<i", src, i)[0]
        i += 4
        if size < 0 or i + size > len(src):
            raise Unreadable("chunk out of range")
        out += lz4_block(src[i:i + size], max_out - len(out))
        i += size
    return bytes(out)


def decode_ints(data, count):
    """usd's integer coding of `count` 32-bit integers: a common value, 2-bit codes, then the
    differences that are not the common one as 8, 16 or 32-bit integers; running sums."""
    if count == 0:
        return []
    common = struct.unpack_from("<i", data, 0)[0]
    codes_at, vals_at = 4, 4 + (count * 2 + 7) // 8
    out, prev = [], 0
    sizes = {1: ("<b", 1), 2: ("<h", 2), 3: ("<i", 4)}
    for k in range(count):
        code = (data[codes_at + k // 4] >> (2 * (k % 4))) & 3
        if code == 0:
            v = common
        else:
            fmt, size = sizes[code]
            if vals_at + size > len(data):
                raise Unreadable("integer codes run past their buffer")
            v = struct.unpack_from(fmt, data, vals_at)[0]
            vals_at += size
        prev = (prev + v + 2 ** 31) % 2 ** 32 - 2 ** 31
        out.append(prev)
    return out


class Reader:
    """A bounded cursor over one section."""

    def __init__(self, data, start, size, name):
        self.data, self.at, self.end, self.name = data, start, start + size, name

    def count(self, what, per_byte=MAX_EXPANSION):
        """A declared count, refused when the rest of the section cannot encode it."""
        n = u64(self.data, self.at)
        self.at += 8
        if n > per_byte * max(self.end - self.at, 0) + 16:
            raise CrateError("-", "the crate file declares %d %s in its %s section of %d bytes (a damaged or "
                             "crafted file)" % (n, what, self.name, self.end - self.at + 8))
        return n

    def compressed(self, what):
        """A length-prefixed compressed buffer."""
        size = u64(self.data, self.at)
        self.at += 8
        if self.at + size > self.end:
            raise CrateError("-", "the crate file's compressed %s (%d bytes) run past its %s section" % (
                what, size, self.name))
        buf = self.data[self.at:self.at + size]
        self.at += size
        return buf

    def ints(self, count, what):
        """`count` integers in usd's compressed integer coding."""
        buf = self.compressed(what)
        work = fast_decompress(buf, 4 + (count * 2 + 7) // 8 + 4 * count)
        return decode_ints(work, count)


def check_crate(data):
    """Raise CrateError when `data` (a crate file's bytes) declares more than it can hold."""
    size = len(data)
    if size < BOOTSTRAP or data[:8] != b"PXR-USDC":
        return
    version = tuple(data[8:11])
    toc = struct.unpack_from("<q", data, 16)[0]
    if not BOOTSTRAP <= toc <= size - 8:
        return  # usd-core reports it without allocating
    n_sections = u64(data, toc)
    if n_sections > (size - toc - 8) // 32:
        raise CrateError("-", "the crate file declares %d sections, more than its table of contents holds" % n_sections)
    sections = {}
    for k in range(n_sections):
        at = toc + 8 + 32 * k
        name = bytes(data[at:at + 16]).split(b"\0", 1)[0].decode("ascii", "replace")
        start, length = struct.unpack_from("<qq", data, at + 16)
        if start < 0 or length < 0 or start + length > size:
            raise CrateError("-", "the crate file's %s section (%d bytes at %d) runs past its end (%d bytes)" % (
                name, length, start, size))
        sections[name] = (start, length)
    if version < (0, 4, 0):
        return
    try:
        _check_sections(data, sections, version)
    except Unreadable:
        return


def _section(data, sections, name):
    if name not in sections:
        raise Unreadable("no %s section" % name)
    start, length = sections[name]
    return Reader(data, start, length, name)


def _check_sections(data, sections, version):
    r = _section(data, sections, "TOKENS")
    n_tokens = u64(data, r.at)
    r.at += 8
    uncompressed = r.count("bytes of tokens", per_byte=255)
    compressed = u64(data, r.at)
    if n_tokens > uncompressed:
        raise CrateError("-", "the crate file declares %d tokens in %d bytes of text" % (n_tokens, uncompressed))
    if r.at + 8 + compressed > r.end:
        raise CrateError("-", "the crate file's tokens (%d bytes) run past their section" % compressed)
    text = fast_decompress(data[r.at + 8:r.at + 8 + compressed], uncompressed)
    tokens = text.split(b"\0")[:n_tokens]

    r = _section(data, sections, "STRINGS")
    r.count("strings", per_byte=1)

    r = _section(data, sections, "FIELDS")
    n_fields = r.count("fields")
    field_tokens = r.ints(n_fields, "field names")
    reps_buf = r.compressed("field values")
    reps = fast_decompress(reps_buf, 8 * n_fields)
    if len(reps) != 8 * n_fields:
        raise Unreadable("field values of another size")

    r = _section(data, sections, "FIELDSETS")
    n_sets = r.count("field set entries")
    field_sets = r.ints(n_sets, "field sets")

    r = _section(data, sections, "PATHS")
    n_paths = r.count("paths")
    n_encoded = r.count("encoded paths")
    path_indexes = r.ints(n_encoded, "path indexes")
    element_tokens = r.ints(n_encoded, "path elements")
    jumps = r.ints(n_encoded, "path jumps")

    r = _section(data, sections, "SPECS")
    n_specs = r.count("specs")
    spec_paths = r.ints(n_specs, "spec paths")
    spec_sets = r.ints(n_specs, "spec field sets")
    r.ints(n_specs, "spec types")

    paths = _paths(n_paths, path_indexes, element_tokens, jumps, tokens)
    # the fields of each field set (sets end with ~0)
    sets, current, start = {}, [], 0
    for k, f in enumerate(field_sets):
        if f == -1:
            sets[start] = current
            current, start = [], k + 1
        else:
            current.append(f)
    array_header = 4 if version < (0, 7, 0) else 8
    for p, s in zip(spec_paths, spec_sets):
        for f in sets.get(s, []):
            if not 0 <= f < n_fields:
                continue
            rep = struct.unpack_from("<Q", reps, 8 * f)[0]
            _check_value(data, rep, array_header, lambda: _where(paths, p, tokens, field_tokens, f))


def _where(paths, p, tokens, field_tokens, f):
    """(prim, what) naming a spec's field."""
    path = paths.get(p, "-")
    t = field_tokens[f] if 0 <= f < len(field_tokens) else -1
    field = tokens[t].decode("utf-8", "replace") if 0 <= t < len(tokens) else "a field"
    prim = path.split(".", 1)[0] if path.startswith("/") else "-"
    return prim, "%s of %s" % (field, path)


# Values stored as a 64-bit count and that many elements (std::vector in crateFile.cpp), by type:
# PathVector, TokenVector, DoubleVector, LayerOffsetVector, StringVector.
VECTOR_BYTES = {40: 4, 41: 4, 48: 8, 49: 16, 50: 4}
# List operations of simple items: up to six such vectors after a header byte, by type: TokenListOp,
# StringListOp, PathListOp, IntListOp, Int64ListOp, UIntListOp, UInt64ListOp.
LISTOP_BYTES = {32: 4, 33: 4, 34: 4, 36: 4, 37: 8, 38: 4, 39: 8}
DICTIONARY, TIME_SAMPLES = 31, 46


def _refuse(data, where, count, what_kind, left):
    prim, what = where()
    raise CrateError(prim, "the crate file declares %d %s for %s, more than its remaining %d bytes can hold "
                     "(a damaged or crafted file)" % (count, what_kind, what, left))


def _vector(data, at, element, where, what_kind="elements"):
    """Check a 64-bit count followed by elements of `element` bytes at `at`; the end."""
    count = u64(data, at)
    left = len(data) - at - 8
    if count * element > left:
        _refuse(data, where, count, what_kind, left)
    return at + 8 + count * element


def _check_value(data, rep, array_header, where, depth=0):
    is_array, inlined, compressed = rep >> 63 & 1, rep >> 62 & 1, rep >> 61 & 1
    if inlined or depth > 4:
        return
    offset = rep & ((1 << 48) - 1)
    kind = rep >> 48 & 0xFF
    size = len(data)
    if offset == 0 and is_array:
        return  # an empty array
    if offset + 8 > size:
        prim, what = where()
        raise CrateError(prim, "the crate file's %s lies past its end (byte %d of %d)" % (what, offset, size))
    if is_array:
        count = struct.unpack_from("<I" if array_header == 4 else "<Q", data, offset)[0]
        left = size - offset - array_header
        bound = MAX_EXPANSION * left + 16 if compressed else left // ELEMENT_BYTES.get(kind, 1)
        if count > bound:
            _refuse(data, where, count, "elements", left)
    elif kind in VECTOR_BYTES:
        _vector(data, offset, VECTOR_BYTES[kind], where)
    elif kind in LISTOP_BYTES:
        header, at = data[offset], offset + 1
        for bit in (2, 4, 8, 16, 32, 64):  # explicit, added, deleted, ordered, prepended, appended
            if header & bit:
                at = _vector(data, at, LISTOP_BYTES[kind], where, "list items")
    elif kind == DICTIONARY:
        _vector(data, offset, 12, where, "dictionary entries")
    elif kind == TIME_SAMPLES:
        # an offset (relative) to the times' value, then one to the count of values and their values
        times_at = offset + struct.unpack_from("<q", data, offset)[0]
        if 0 <= times_at <= size - 8:
            _check_value(data, u64(data, times_at), array_header, where, depth + 1)
        jump = struct.unpack_from("<q", data, offset + 8)[0] if offset + 16 <= size else -1
        values_at = offset + 8 + jump
        if 0 <= values_at <= size - 8:
            _vector(data, values_at, 8, where, "time samples")
            for k in range(u64(data, values_at)):
                _check_value(data, u64(data, values_at + 8 + 8 * k), array_header, where, depth + 1)


def _paths(n_paths, path_indexes, element_tokens, jumps, tokens):
    """Path index -> path text, rebuilt from the compressed path tree (crateFile.cpp's
    _BuildDecompressedPathsImpl, without recursion)."""
    paths = {}
    todo = [(0, None)]
    steps = 0
    while todo:
        cur, parent = todo.pop()
        while True:
            steps += 1
            if steps > 4 * len(path_indexes) + 4 or not 0 <= cur < len(path_indexes):
                raise Unreadable("path tree out of range")
            this = cur
            cur += 1
            if parent is None:
                parent = "/"
                here = "/"
            else:
                t = element_tokens[this]
                name = tokens[abs(t)].decode("utf-8", "replace") if abs(t) < len(tokens) else "?"
                if t < 0:
                    here = parent + "." + name
                elif name.startswith("{") or parent.endswith("}"):
                    here = parent + name  # a variant selection, or a prim under one
                else:
                    here = parent.rstrip("/") + "/" + name
            paths[path_indexes[this]] = here
            j = jumps[this]
            has_child, has_sibling = j > 0 or j == -1, j >= 0
            if has_child:
                if has_sibling:
                    todo.append((this + j, parent))
                parent = here
            if not (has_child or has_sibling):
                break
    return paths
