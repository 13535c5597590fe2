#!/usr/bin/env python3
"""The library's top-level module graph, from the `crate::…` paths in its code, and its cycles.

    scripts/module_graph.py [SRC_DIR] [--tests] [--edges]

A module `a` depends on `b` when code under `src/a` (or `src/a.rs`) names `crate::b` (in a `use`,
grouped `use crate::{b, c::d}` included, or inline). Comments and doc links are not code; test
code (`tests.rs`, files under a `tests/` folder, and a trailing `#[cfg(test)] mod tests { … }`) is
left out unless `--tests` is given. Prints the edges (with `--edges`), then each cycle as a path
with the first file and line of each of its edges. Exit status 1 when there is a cycle.
"""

import argparse
import re
import sys
from pathlib import Path

USE_GROUP = re.compile(r"\buse\s+crate\s*::\s*\{")
CRATE_PATH = re.compile(r"\bcrate\s*::\s*([a-z_][a-z0-9_]*)")


def strip_comments(text):
    """Remove `//` comments and `/* */` blocks, keeping string literals and line numbers."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(text[i : j + 1])
            i = j + 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def strip_trailing_tests(text):
    """Drop a `#[cfg(test)] mod tests { … }` that runs to the end of the file."""
    m = re.search(r"#\[cfg\(test\)\]\s*(pub(\([a-z]+\))?\s+)?mod\s+tests\s*\{", text)
    return text[: m.start()] if m else text


def group_heads(text, start):
    """Top-level names of the `use crate::{…}` group whose `{` ends at `start`."""
    depth, i, names, token = 1, start, [], ""
    while i < len(text) and depth > 0:
        c = text[i]
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
        if depth == 1 and c in ",}" or depth == 0:
            pass
        if depth == 1 and (c.isalnum() or c == "_"):
            token += c
        elif token:
            if depth == 1 or (depth == 2 and c == "{"):
                names.append(token)
            token = ""
        i += 1
    # keep only the first identifier of each comma-separated item at depth 1
    heads, item_start = [], True
    depth = 1
    for c_tok in re.finditer(r"[{},]|::|[A-Za-z_][A-Za-z0-9_]*", text[start:i]):
        t = c_tok.group(0)
        if t == "{":
            depth += 1
        elif t == "}":
            depth -= 1
        elif t == ",":
            if depth == 1:
                item_start = True
        elif t == "::":
            pass
        else:
            if depth == 1 and item_start:
                heads.append(t)
                item_start = False
    return heads


def module_of(path, src):
    rel = path.relative_to(src)
    if len(rel.parts) == 1:
        return rel.stem if rel.stem not in ("lib", "main") else None
    return rel.parts[0]


def is_test_file(path, src):
    rel = path.relative_to(src)
    return path.name == "tests.rs" or "tests" in rel.parts[:-1]


def reexports(src):
    """`pub use m::{A, B}` in lib.rs: `crate::A` means module `m`."""
    lib = (src / "lib.rs").read_text()
    out = {}
    for m in re.finditer(r"pub\s+use\s+([a-z_][a-z0-9_]*)\s*::\s*(\{[^}]*\}|[A-Za-z_][A-Za-z0-9_]*)", lib):
        for name in re.findall(r"[A-Za-z_][A-Za-z0-9_]*", m.group(2)):
            out[name] = m.group(1)
    return out


def graph(src, tests):
    modules = {module_of(p, src) for p in src.rglob("*.rs")} - {None}
    aliases = reexports(src)
    edges = {}  # (a, b) -> "file:line"
    for path in sorted(src.rglob("*.rs")):
        a = module_of(path, src)
        if a is None or (not tests and is_test_file(path, src)):
            continue
        text = strip_comments(path.read_text())
        if not tests:
            text = strip_trailing_tests(text)
        found = []
        for m in CRATE_PATH.finditer(text):
            found.append((m.group(1), m.start()))
        for m in USE_GROUP.finditer(text):
            for h in group_heads(text, m.end()):
                found.append((h, m.start()))
        for name, pos in found:
            b = aliases.get(name, name)
            if b in modules and b != a:
                line = text.count("\n", 0, pos) + 1
                edges.setdefault((a, b), f"{path.relative_to(src.parent)}:{line}")
    return modules, edges


def cycles(modules, edges):
    """Strongly connected components with more than one module (Tarjan), and for each of their
    edges a shortest cycle through it (each cycle once)."""
    succ = {m: sorted(b for (a, b) in edges if a == m) for m in modules}
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in succ[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for m in sorted(modules):
        if m not in index:
            visit(m)
    found = []
    for comp in comps:
        inside = set(comp)
        for (a, b) in sorted(edges):
            if a not in inside or b not in inside:
                continue
            # shortest path b -> a inside the component closes the cycle a -> b -> … -> a
            prev, queue = {b: None}, [b]
            while queue and a not in prev:
                nxt = []
                for v in queue:
                    for w in succ[v]:
                        if w in inside and w not in prev:
                            prev[w] = v
                            nxt.append(w)
                queue = nxt
            path, v = [], a
            while v is not None:
                path.append(v)
                v = prev[v]
            cyc = [a] + path[::-1][:-1] if len(path) > 1 else [a, b]
            cyc = cyc if cyc[-1] != a else cyc[:-1]
            k = cyc.index(min(cyc))
            canon = tuple(cyc[k:] + cyc[:k])
            if canon not in [c for c, _ in found]:
                found.append((canon, comp))
    return comps, [c for c, _ in found]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("src", nargs="?", default=str(Path(__file__).resolve().parent.parent / "src"))
    ap.add_argument("--tests", action="store_true", help="count test code too")
    ap.add_argument("--edges", action="store_true", help="print every edge")
    a = ap.parse_args()
    src = Path(a.src)
    modules, edges = graph(src, a.tests)
    print(f"{len(modules)} modules, {len(edges)} dependencies ({'with' if a.tests else 'without'} test code)")
    if a.edges:
        for m in sorted(modules):
            deps = sorted(b for (x, b) in edges if x == m)
            print(f"  {m} -> {', '.join(deps) if deps else '(none)'}")
    comps, cyc = cycles(modules, edges)
    if not comps:
        print("no cycles")
        return 0
    for comp in comps:
        print(f"strongly connected: {', '.join(comp)}")
    for c in cyc:
        ring = list(c) + [c[0]]
        print("cycle: " + " -> ".join(ring))
        for x, y in zip(ring, ring[1:]):
            print(f"    {x} -> {y}: {edges[(x, y)]}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
