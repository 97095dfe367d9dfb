#!/usr/bin/env python3
"""Prints the graph of `crate::` paths between the library's top-level modules
and fails (exit 1) if it has a cycle.

Code only: comments, doc comments and `#[cfg(test)]` modules are skipped (a
test may cross-check against any layer). The layers are checked in the order
`src/lib.rs` declares them: a module may import only modules declared before
it. Run from the repository root: `python3 scripts/layers.py`.
"""
import os
import re
import sys

SRC = "src"


def lib_order():
    order = []
    for line in open(os.path.join(SRC, "lib.rs")):
        m = re.match(r"\s*pub mod (\w+);", line)
        if m:
            order.append(m.group(1))
    return order


def module_files(name):
    files = []
    single = os.path.join(SRC, name + ".rs")
    if os.path.exists(single):
        files.append(single)
    folder = os.path.join(SRC, name)
    if os.path.isdir(folder):
        for root, _, names in os.walk(folder):
            files += [os.path.join(root, n) for n in names if n.endswith(".rs")]
    return sorted(files)


def test_files(files):
    """Files declared behind `#[cfg(test)]` by their parent."""
    skipped = set()
    for path in files:
        lines = open(path).read().splitlines()
        for i, line in enumerate(lines):
            m = re.match(r"\s*(pub(\(crate\))?\s+)?mod (\w+);", line)
            if m and i > 0 and "cfg(test)" in lines[i - 1]:
                base = os.path.dirname(path)
                stem = os.path.splitext(os.path.basename(path))[0]
                if stem not in ("mod", "lib"):
                    base = os.path.join(base, stem)
                for cand in (os.path.join(base, m.group(3) + ".rs"),
                             os.path.join(base, m.group(3), "mod.rs")):
                    skipped.add(os.path.normpath(cand))
                # `#[path = "…"]` above `#[cfg(test)]`
                p = re.search(r'path\s*=\s*"([^"]+)"', "\n".join(lines[max(0, i - 3):i]))
                if p:
                    skipped.add(os.path.normpath(os.path.join(os.path.dirname(path), p.group(1))))
    return skipped


def code_of(path):
    text = open(path).read()
    # Inline test modules: from `#[cfg(test)]` + `mod name {` to the end.
    m = re.search(r"#\[cfg\(test\)\]\s*(pub(\(crate\))?\s+)?mod \w+\s*\{", text)
    if m:
        text = text[: m.start()]
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"'(\\.|[^'\\])'", "' '", text)
    text = re.sub(r'"(\\[\s\S]|[^"\\])*"', '""', text)
    return text


def imported(text):
    names = set()
    for m in re.finditer(r"\bcrate::", text):
        rest = text[m.end():]
        if rest.startswith("{"):
            depth, token, i = 0, "", 0
            while i < len(rest):
                c = rest[i]
                if c == "{":
                    depth += 1
                    token = ""
                elif c == "}":
                    depth -= 1
                    if depth == 0:
                        break
                elif depth == 1 and c == ",":
                    token = ""
                elif depth == 1 and (c.isalnum() or c == "_") and token is not None:
                    token += c
                    j = i + 1
                    if j < len(rest) and not (rest[j].isalnum() or rest[j] == "_"):
                        names.add(token)
                        token = None
                i += 1
        else:
            w = re.match(r"\w+", rest)
            if w:
                names.add(w.group(0))
    return names


def main():
    order = lib_order()
    graph = {}
    for name in order:
        files = module_files(name)
        skip = test_files(files)
        deps = set()
        for path in files:
            if os.path.normpath(path) in skip or path.endswith("_tests.rs") or path.endswith("/tests.rs"):
                continue
            deps |= imported(code_of(path))
        graph[name] = sorted(d for d in deps if d in order and d != name)

    position = {n: i for i, n in enumerate(order)}
    upward = []
    for name in order:
        ups = [d for d in graph[name] if position[d] > position[name]]
        upward += [(name, d) for d in ups]
        print(f"{name:>10} -> {', '.join(graph[name]) or '-'}")

    # Strongly connected components (Tarjan).
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
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
            comps.append(comp)

    sys.setrecursionlimit(10000)
    for v in order:
        if v not in index:
            visit(v)
    cycles = [sorted(c) for c in comps if len(c) > 1]
    print()
    for c in cycles:
        print(f"cycle among {len(c)} modules: {', '.join(c)}")
    for a, b in upward:
        print(f"upward import: {a} -> {b} (declared after it in src/lib.rs)")
    if cycles or upward:
        sys.exit(1)
    print("acyclic, in src/lib.rs order")


if __name__ == "__main__":
    main()
