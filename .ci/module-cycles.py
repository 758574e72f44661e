#!/usr/bin/env python3
"""Report module cycles in the workspace's library crates; exit 1 if there is one.

Usage: .ci/module-cycles.py [CRATE_SRC_DIR ...]   (default: every crates/*/src with a lib.rs)
       .ci/module-cycles.py --self-test     (the checker on small crates with and without cycles)

What it reads
-------------
The module tree is found the way rustc finds it: from `lib.rs` (or `main.rs` when a source
directory given on the command line has no `lib.rs`), following `mod name;` declarations to
`name.rs` or `name/mod.rs` (both conventions; `foo.rs` with a `foo/` folder beside it is the
module `foo` with its children in `foo/`). Inline modules (`mod tests { ... }`) are parsed
for `super::`/`self::` resolution and then folded into the module of the file they live in.
`#[path = "..."]` attributes are not supported (the workspace has none; the script says so
if it meets one).

What it counts as a reference
-----------------------------
In each module file, after removing comments (doc comments included: an intra-doc link is
no dependency) and string/char literals:
  * every `use` tree rooted at `crate::`, `super::` or `self::` (groups `{a, b::c}` and
    `self` inside a group are expanded), and
  * every other path written `crate::a::b`, `$crate::a::b`, `super::x`, `self::x` in the
    code (`pub(crate)`, `pub(super)` and `pub(in path)` visibilities are not references).
The target of a path is the deepest known module among its prefixes (`crate::a::b::Item`
names module `a::b` when `b` is a module of `a`, else module `a`). Bare paths such as
`child::f()` are not read: they name the module's own children, or names brought in by a
`use` that is already counted. References through re-exports are charged to the module
that is named (`crate::Foo` re-exported by `lib.rs` counts as a reference to the root).

What it counts as a cycle
-------------------------
For a reference from module X to module Y, let P be their deepest common ancestor. If P is
X or Y (a module using its own descendants, or a child using items of its parent or of an
ancestor) the reference is not an edge: parents and children are one unit. Otherwise the
edge joins the two children of P on the way to X and to Y: siblings, e.g. the crate's
top-level modules, or `solver::parity` and `solver::multigrid` under `solver`. A cycle is a
strongly connected component of more than one sibling in one such graph; each is reported
with the references (file:line and path) that form its edges.
"""

import re
import sys
from collections import defaultdict
from pathlib import Path

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"


def strip_comments_and_strings(src):
    """Blank out comments and string/char literals, keeping newlines (for line numbers)."""
    out = []
    i, n = 0, len(src)

    def blank(s):
        return "".join(c if c == "\n" else " " for c in s)

    while i < n:
        c = src[i]
        if src.startswith("//", i):
            j = src.find("\n", i)
            j = n if j < 0 else j
            out.append(blank(src[i:j]))
            i = j
        elif src.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if src.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif src.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append(blank(src[i:j]))
            i = j
        elif c in "rb" and re.match(r'(?:br|r)#*"', src[i:i + 300]) and (
            i == 0 or not re.match(r"[A-Za-z0-9_]", src[i - 1])
        ):
            m = re.match(r'(?:br|r)(#*)"', src[i:])
            close = '"' + m.group(1)
            j = src.find(close, i + m.end())
            j = n if j < 0 else j + len(close)
            out.append(blank(src[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and src[j] != '"':
                j += 2 if src[j] == "\\" else 1
            j += 1
            out.append(blank(src[i:j]))
            i = j
        elif c == "'":
            # A char literal ('a', '\n', '\u{..}') or a lifetime ('a): only the former is blanked.
            m = re.match(r"'(?:\\(?:u\{[0-9a-fA-F]+\}|x[0-9a-fA-F]{2}|.)|[^\\'])'", src[i:])
            if m:
                out.append(blank(m.group(0)))
                i += m.end()
            else:
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def line_of(text, pos):
    return text.count("\n", 0, pos) + 1


def expand_use_tree(tree):
    """`a::{b, c::{d, self}}` -> [['a','b'], ['a','c','d'], ['a','c']]."""
    tree = re.sub(r"\s+", "", tree)
    tree = re.sub(r"\bas\w+", "", tree)  # `x as y` (whitespace already removed: `xasy`)
    return _expand(tree)


def _split_top(s):
    parts, depth, cur = [], 0, ""
    for c in s:
        if c == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += c == "{"
        depth -= c == "}"
        cur += c
    if cur:
        parts.append(cur)
    return parts


def _expand(s):
    brace = s.find("{")
    if brace < 0:
        segs = [p for p in s.split("::") if p]
        if segs and segs[-1] == "self":
            segs = segs[:-1]
        if segs and segs[-1] == "*":
            segs = segs[:-1]
        return [segs]
    prefix = [p for p in s[:brace].split("::") if p]
    inner = s[brace + 1:s.rfind("}")]
    result = []
    for part in _split_top(inner):
        for tail in _expand(part):
            result.append(prefix + tail)
    return result


class Crate:
    def __init__(self, src_dir):
        self.src_dir = Path(src_dir)
        self.name = self.src_dir.parent.name
        root = self.src_dir / "lib.rs"
        if not root.exists():
            root = self.src_dir / "main.rs"
        self.modules = {}  # module path tuple -> file Path
        self.inline = set()  # inline module paths (folded into their file's module)
        self.text = {}  # module path -> stripped text
        self.refs = []  # (from_module, to_path_segments, file, line, written)
        self.warnings = []
        self._load((), root, root.parent)

    def _load(self, path, file, child_dir):
        src = file.read_text(encoding="utf-8")
        text = strip_comments_and_strings(src)
        if "#[path" in re.sub(r"\s+", "", text):
            self.warnings.append(f"{file}: #[path] attribute not supported; result may be incomplete")
        self.modules[path] = file
        self.text[path] = text
        # Find `mod x;` and `mod x {`, tracking inline-module nesting by braces.
        scopes = []  # stack of (brace depth at which the inline module opened, module path)
        depth = 0
        pos_scope = []  # (pos, module path for text from pos on)
        token = re.compile(r"\{|\}|\bmod\s+(" + IDENT + r")\s*([;{])")
        current = path
        pos_scope.append((0, path))
        for m in token.finditer(text):
            tok = m.group(0)
            if tok == "{":
                depth += 1
            elif tok == "}":
                depth -= 1
                if scopes and scopes[-1][0] == depth:
                    scopes.pop()
                    current = scopes[-1][1] if scopes else path
                    pos_scope.append((m.end(), current))
            else:
                name, kind = m.group(1), m.group(2)
                sub = current + (name,)
                if kind == "{":
                    self.inline.add(sub)
                    self.modules[sub] = file
                    scopes.append((depth, sub))
                    depth += 1
                    current = sub
                    pos_scope.append((m.end(), current))
                else:
                    # Inline modules' `mod x;` children live in child_dir/<inline path>/.
                    rel = sub[len(path):]
                    base = child_dir.joinpath(*rel[:-1])
                    cand = [base / f"{name}.rs", base / name / "mod.rs"]
                    found = [c for c in cand if c.exists()]
                    if not found:
                        self.warnings.append(f"{file}: `mod {name};` has no file")
                        continue
                    f = found[0]
                    sub_dir = f.parent if f.name == "mod.rs" else f.parent / name
                    self._load(sub, f, sub_dir)
        self._collect_refs(file, text, pos_scope)

    def _collect_refs(self, file, text, pos_scope):
        def scope_at(pos):
            cur = pos_scope[0][1]
            for p, s in pos_scope:
                if p <= pos:
                    cur = s
                else:
                    break
            return cur

        # Visibility qualifiers are not references.
        text = re.sub(r"pub\s*\(\s*in\s+[^)]*\)", lambda m: " " * len(m.group(0)), text)
        used_spans = []
        for m in re.finditer(r"\buse\s+([^;]*);", text):
            used_spans.append((m.start(), m.end()))
            scope = scope_at(m.start())
            for segs in expand_use_tree(m.group(1)):
                if segs and segs[0] in ("crate", "super", "self", "$crate"):
                    self._add(scope, segs, file, line_of(text, m.start()), "use " + "::".join(segs))
        path_re = re.compile(
            r"(\$crate|\bcrate|\bsuper|\bself)((?:\s*::\s*(?:super|" + IDENT + r"))+)"
        )
        for m in path_re.finditer(text):
            if any(a <= m.start() < b for a, b in used_spans):
                continue
            segs = [m.group(1)] + [s for s in re.split(r"\s*::\s*", m.group(2)) if s]
            self._add(scope_at(m.start()), segs, file, line_of(text, m.start()), "::".join(segs))

    def _add(self, scope, segs, file, line, written):
        self.refs.append((scope, segs, file, line, written))

    def file_module(self, path):
        """The module of the file that holds `path` (inline modules folded in)."""
        while path in self.inline:
            path = path[:-1]
        return path

    def resolve(self, scope, segs):
        """Module path named by `segs` used in module `scope`, or None."""
        segs = list(segs)
        head = segs.pop(0)
        if head in ("crate", "$crate"):
            base = ()
        elif head == "self":
            base = scope
        else:  # super
            base = scope[:-1]
        while segs and segs[0] == "super":
            segs.pop(0)
            base = base[:-1]
        while segs and segs[0] == "self":
            segs.pop(0)
        target = base
        for s in segs:
            if target + (s,) in self.modules:
                target = target + (s,)
            else:
                break
        return target

    def edges(self):
        """{parent: {(a, b): [(file, line, written, from, to)]}} between siblings a, b of parent."""
        out = defaultdict(lambda: defaultdict(list))
        for scope, segs, file, line, written in self.refs:
            src = self.file_module(scope)
            dst = self.file_module(self.resolve(scope, segs))
            k = 0
            while k < min(len(src), len(dst)) and src[k] == dst[k]:
                k += 1
            if k == len(src) or k == len(dst):
                continue  # ancestor/descendant: not an edge
            parent = src[:k]
            out[parent][(src[k], dst[k])].append((file, line, written, src, dst))
        return out


def sccs(nodes, adj):
    """Tarjan's strongly connected components."""
    index, low, on, stack, result = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(adj.get(v, ())):
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
            result.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return result


def modname(path):
    return "::".join(path) if path else "crate"


def count_cycles(crate):
    """The number of cycles in `crate`, over every parent's sibling graph."""
    found = 0
    for edges in crate.edges().values():
        adj = defaultdict(set)
        nodes = set()
        for a, b in edges:
            adj[a].add(b)
            nodes.update((a, b))
        found += sum(1 for comp in sccs(nodes, adj) if len(comp) >= 2)
    return found


def self_test():
    """Checks the checker on small crates written to a temporary folder: a cycle between two
    siblings (through `use crate::` and `super::`) is found, a nested one too, and neither a
    parent using its children nor a child using its parent counts."""
    import tempfile

    cases = {
        "siblings": (1, {"lib.rs": "mod a;\nmod b;\n", "a.rs": "use crate::b::f;\n",
                         "b.rs": "pub fn f() { super::a::g() }\n"}),
        "nested": (1, {"lib.rs": "mod s;\n", "s.rs": "mod x;\nmod y;\n",
                       "s/x.rs": "use super::y::Y;\n", "s/y.rs": "use crate::s::x::X;\n"}),
        "parent_child": (0, {"lib.rs": "mod a;\nuse crate::a::f;\n",
                             "a.rs": "use crate::g;\npub fn f() {}\n"}),
        "one_way": (0, {"lib.rs": "mod a;\nmod b;\n", "a.rs": "use crate::b::f;\n",
                        "b.rs": "// crate::a::g is only a comment\npub fn f() {}\n"}),
    }
    failures = 0
    for name, (want, files) in cases.items():
        with tempfile.TemporaryDirectory() as tmp:
            src = Path(tmp) / "src"
            for rel, text in files.items():
                (src / rel).parent.mkdir(parents=True, exist_ok=True)
                (src / rel).write_text(text)
            got = count_cycles(Crate(src))
        status = "ok" if got == want else "FAILED"
        failures += got != want
        print(f"module-cycles self-test {name}: {got} cycle(s), expected {want}: {status}")
    return 1 if failures else 0


def main(argv):
    if argv[1:] == ["--self-test"]:
        return self_test()
    root = Path(__file__).resolve().parent.parent
    dirs = [Path(a) for a in argv[1:]] or sorted(
        p.parent for p in (root / "crates").glob("*/src/lib.rs")
    )
    found = 0
    for d in dirs:
        crate = Crate(d)
        for w in crate.warnings:
            print(f"module-cycles: warning: {w}", file=sys.stderr)
        for parent, edges in sorted(crate.edges().items()):
            adj = defaultdict(set)
            nodes = set()
            for a, b in edges:
                adj[a].add(b)
                nodes.update((a, b))
            for comp in sccs(nodes, adj):
                if len(comp) < 2:
                    continue
                found += 1
                names = [modname(parent + (c,)) for c in comp]
                print(f"{crate.name}: cycle between {' , '.join(names)}")
                members = set(comp)
                for (a, b), refs in sorted(edges.items()):
                    if a in members and b in members:
                        print(f"  {modname(parent + (a,))} -> {modname(parent + (b,))}:")
                        for file, line, written, _, _ in refs:
                            rel = file.relative_to(root) if file.is_relative_to(root) else file
                            print(f"    {rel}:{line}: {written}")
    if found:
        print(f"module-cycles: {found} cycle(s) found", file=sys.stderr)
        return 1
    print(f"module-cycles: no cycles in {len(dirs)} crate(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
