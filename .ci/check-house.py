#!/usr/bin/env python3
"""House rules of the workspace's Rust sources (issue 48); exit 1 on any violation.

Usage: .ci/check-house.py              the checks below
       .ci/check-house.py --report     the checks, and the 20 longest functions and files
                                       (printed even when everything passes)
       .ci/check-house.py --self-test  the checker on a small temporary crate tree with known
                                       violations and non-violations

What is read
------------
Every `*.rs` file under `crates/*/src/` and `src/` (the binary). Integration tests
(`tests/`), benches, examples and build scripts live outside those folders and are not read.
Each file is first lexed: comments (line, block, nested block, doc) and string, byte-string,
raw-string (`r#"…"#`) and char literals are blanked out, newlines kept, so that nothing in
a comment or a literal counts; a `'` starts a char literal only when it is `'\\…'` or `'x'`
(otherwise it is a lifetime or a label).

Test code is exempt from every check: an item carrying `#[cfg(test)]` (or
`#[cfg(all(test, …))]`) from the attribute to the end of the item (the `}` matching its
first `{`, or its `;`), a function carrying `#[test]`, and a whole file declared by
`#[cfg(test)] mod name;`.

(a) Library crates do not print or read the environment
    Crates named in LIBRARY_CRATES (those whose crates/<name>/src exists; the others are
    skipped with a note). The command crates (pn-drivers, pn-lab) and the binary may print.
    Flagged outside test code: the macros `println!`, `print!`, `eprintln!`, `eprint!`,
    `dbg!`; `io::stdout`/`io::stderr` (with or without `std::`) and bare `stdout()` /
    `stderr()` calls (method calls such as `Command::stdout(…)` are not); `env::var`,
    `env::var_os`, `env::vars`, `env::vars_os`, `env::args`, `env::args_os`,
    `env::set_var`, `env::remove_var`, `env::temp_dir` (it reads TMPDIR) and the same
    names imported by `use std::env::{…}`. Allowed: `env!(…)` and `option_env!(…)` (read
    at compile time) and `env::current_dir()`.

(a') Library crates do not write files or start processes
    Writing: crates in LIBRARY_CRATES except those in WRITING_CRATES (pn-formats, the one
    crate that writes files, for the commands that call it). Flagged outside test code:
    `fs::write`, `fs::rename`, `fs::copy`, `fs::hard_link`, `fs::remove_file`,
    `fs::remove_dir`, `fs::remove_dir_all`, `fs::create_dir`, `fs::create_dir_all` (with
    or without `std::`, and the same names imported by `use std::fs::{…}`), `File::create`,
    `File::create_new`, `OpenOptions`, `DirBuilder` and `BitMapBackend::new` (plotters
    drawing into a file). Reading is allowed (`fs::read*`, `File::open`: a library reads
    the input files the user names).
    Processes: every crate in LIBRARY_CRATES, pn-formats included. Flagged outside test
    code: `process::Command` (a path or a `use`, with or without `std::`; also inside
    `use std::process::{…}`) and `Command::new`.
    Build scripts (`build.rs`, outside `src/`) may write into OUT_DIR and are not read.

(b) No file over MAX_FILE_LINES (900) lines
    Counted: the file's lines (as `wc -l` counts them, plus a last line without a newline)
    minus the lines of `#[cfg(test)]` modules written inline (`#[cfg(test)] mod tests
    { … }`, from the attribute line to the closing brace line). Files whose first
    five lines say `@generated` or `do not edit` are skipped (generated code under OUT_DIR
    is not in the tree anyway).

(c) No function over MAX_FN_LINES (150) lines
    Every `fn NAME` item with a body: free functions, methods, associated and nested
    functions, whatever the qualifiers (`pub(crate)`, `const`, `async`, `unsafe`, `extern`)
    and however long the signature (generics, where clauses). Counted: from the line of the
    `fn` keyword to the line of the body's closing brace, both included (attributes and doc
    comments above it are not counted). A nested function's lines also count toward the
    function around it. Declarations without a body (`fn f();` in a trait) are not
    functions here. Functions in test code (above) are skipped.
"""

import re
import sys
import tempfile
from pathlib import Path

LIBRARY_CRATES = [
    "cas",
    "pn-stencil",
    "pn-codegen",
    "pn-kernels",
    "pn-krylov",
    "pn-runtime",
    "pn-distributed",
    "pn-formats",
    "pn-render",
    "pnsolver-py",
]
# The library crates that may write files (check (a') still forbids them processes).
WRITING_CRATES = ["pn-formats"]
MAX_FILE_LINES = 900
MAX_FN_LINES = 150

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"


# ----------------------------------------------------------------------------------------
# Lexing


def strip(src):
    """Blank out comments and string/char literals, keeping every newline (and the length).

    A string literal keeps its opening and closing quote so that `println!("…")` still reads
    as a macro call; everything inside becomes spaces.
    """
    out = []
    i, n = 0, len(src)

    def blank(s, quote=False):
        b = "".join(c if c == "\n" else " " for c in s)
        if quote and len(b) >= 2:
            b = '"' + b[1:-1] + '"'
        return b

    ident_char = re.compile(r"[A-Za-z0-9_]")
    raw = re.compile(r'(?:br|cr|r)(#*)"')
    while i < n:
        c = src[i]
        if c == "/" and src.startswith("//", i):
            j = src.find("\n", i)
            j = n if j < 0 else j
            out.append(blank(src[i:j]))
            i = j
        elif c == "/" and src.startswith("/*", i):
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
        elif c in "bcr" and (i == 0 or not ident_char.match(src[i - 1])) and raw.match(src, i):
            m = raw.match(src, i)
            close = '"' + m.group(1)
            j = src.find(close, m.end())
            j = n if j < 0 else j + len(close)
            out.append(blank(src[i:j], quote=True))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and src[j] != '"':
                j += 2 if src[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(blank(src[i:j], quote=True))
            i = j
        elif c == "'":
            if i + 1 < n and src[i + 1] == "\\":
                # '\n', '\'', '\\', '\x41', '\u{1F600}'
                j = i + 3
                while j < n and src[j] != "'" and src[j] != "\n":
                    j += 1
                j = min(j + 1, n)
                out.append(blank(src[i:j]))
                i = j
            elif i + 2 < n and src[i + 2] == "'" and src[i + 1] != "\n":
                out.append(blank(src[i:i + 3]))
                i += 3
            else:
                out.append(c)  # a lifetime or a loop label
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def line_of(text, pos):
    return text.count("\n", 0, pos) + 1


def count_lines(src):
    return src.count("\n") + (1 if src and not src.endswith("\n") else 0)


def matching_brace(text, open_pos):
    """Position of the `}` matching the `{` at open_pos (len(text) if unbalanced)."""
    depth = 0
    for m in re.finditer(r"[{}]", text[open_pos:]):
        depth += 1 if m.group(0) == "{" else -1
        if depth == 0:
            return open_pos + m.start()
    return len(text)


def item_end(text, pos):
    """From pos (just after an attribute), the end of the item: the position of the `}`
    matching its first `{`, or of its `;`, whichever comes first outside () and []."""
    depth = 0
    for m in re.finditer(r"[()\[\]{};]", text[pos:]):
        t = m.group(0)
        if t in "([":
            depth += 1
        elif t in ")]":
            depth -= 1
        elif depth <= 0:
            if t == ";":
                return pos + m.start(), None
            if t == "{":
                return matching_brace(text, pos + m.start()), pos + m.start()
            return pos + m.start(), None  # a stray `}`: the attribute closed its block
    return len(text), None


# ----------------------------------------------------------------------------------------
# One source file

CFG_TEST = re.compile(r"#\s*\[\s*cfg\s*\(\s*(?:test|all\s*\((?:[^()]*,)?\s*test\s*(?:,[^()]*)?\))\s*\)\s*\]")
TEST_ATTR = re.compile(r"#\s*\[\s*test\s*\]")
FN = re.compile(r"\bfn\s+(" + IDENT + r")")
# `impl`/`trait` blocks as items (at the start of a line), not `-> impl Trait` in signatures.
IMPL = re.compile(
    r"^[ \t]*(?:pub(?:\s*\([^)]*\))?\s+)?(?:unsafe\s+)?(?:default\s+)?(impl|trait)\b", re.M
)


class Source:
    """A lexed file with its test regions."""

    def __init__(self, path, rel):
        self.path = path
        self.rel = rel
        self.src = path.read_text(encoding="utf-8")
        self.text = strip(self.src)
        # (start, end) character ranges of test code; `test_mods`: inline #[cfg(test)]
        # modules (start line, end line); `test_files`: names of `#[cfg(test)] mod x;`.
        self.tests = []
        self.test_mods = []
        self.test_files = []
        for m in CFG_TEST.finditer(self.text):
            end, brace = item_end(self.text, m.end())
            self.tests.append((m.start(), end))
            head = self.text[m.end():brace if brace is not None else end]
            mod = re.search(r"\bmod\s+(" + IDENT + r")\s*$", head)
            if mod and brace is not None:
                self.test_mods.append((line_of(self.text, m.start()), line_of(self.text, end)))
            elif mod:
                self.test_files.append(mod.group(1))
        for m in TEST_ATTR.finditer(self.text):
            end, _ = item_end(self.text, m.end())
            self.tests.append((m.start(), end))

    def in_test(self, pos):
        return any(a <= pos <= b for a, b in self.tests)

    def generated(self):
        head = "\n".join(self.src.splitlines()[:5]).lower()
        return "@generated" in head or "do not edit" in head

    def counted_lines(self):
        """Lines outside inline #[cfg(test)] modules (nested ones counted once)."""
        excluded = set()
        for a, b in self.test_mods:
            excluded.update(range(a, b + 1))
        return count_lines(self.src) - len(excluded)

    def impl_ranges(self):
        """(start, end, name) of `impl … {` and `trait Name … {` blocks."""
        out = []
        for m in IMPL.finditer(self.text):
            end, brace = item_end(self.text, m.end())
            if brace is None:
                continue
            head = self.text[m.end():brace]
            if m.group(1) == "trait":
                name = re.match(r"\s*(" + IDENT + ")", head)
                name = name.group(1) if name else "?"
            else:
                head = re.sub(r"\bwhere\b.*", "", head, flags=re.S)
                head = strip_generics(head.strip())
                if re.search(r"\bfor\b", head):
                    head = re.split(r"\bfor\b", head)[-1]
                words = re.findall(IDENT, strip_generics_all(head))
                words = [w for w in words if w not in ("dyn", "mut", "const", "unsafe")]
                name = words[-1] if words else "?"
            out.append((brace, end, name))
        return out

    def functions(self):
        """(name, first line, line count) of every function with a body outside tests."""
        impls = self.impl_ranges()
        out = []
        for m in FN.finditer(self.text):
            if self.in_test(m.start()):
                continue
            end, brace = item_end(self.text, m.end())
            if brace is None:
                continue  # a declaration without a body
            owner = [name for a, b, name in impls if a < m.start() < b]
            name = f"{owner[-1]}::{m.group(1)}" if owner else m.group(1)
            first = line_of(self.text, m.start())
            out.append((name, first, line_of(self.text, end) - first + 1))
        return out


def strip_generics(s):
    """`<T: A<B>> Foo<T>` -> ` Foo<T>`: drops a leading generic parameter list."""
    if not s.startswith("<"):
        return s
    depth = 0
    for i, c in enumerate(s):
        depth += (c == "<") - (c == ">" and s[i - 1] != "-")
        if depth == 0:
            return s[i + 1:]
    return s


def strip_generics_all(s):
    out, depth = [], 0
    for i, c in enumerate(s):
        if c == "<":
            depth += 1
        elif c == ">" and (i == 0 or s[i - 1] != "-"):
            depth -= 1
        elif depth == 0:
            out.append(c)
    return "".join(out)


# ----------------------------------------------------------------------------------------
# The tree

PRINT = re.compile(r"(?<![A-Za-z0-9_])(println|print|eprintln|eprint|dbg)\s*!")
STDIO = re.compile(r"\bio\s*::\s*(stdout|stderr)\b|(?<![A-Za-z0-9_.:])(stdout|stderr)\s*\(")
ENV_NAMES = r"(var|var_os|vars|vars_os|args|args_os|set_var|remove_var|temp_dir)"
ENV = re.compile(r"\benv\s*::\s*" + ENV_NAMES + r"\b")
ENV_USE = re.compile(r"\benv\s*::\s*\{([^}]*)\}")
FS_NAMES = (r"(write|rename|copy|hard_link|remove_file|remove_dir|remove_dir_all|create_dir"
            r"|create_dir_all)")
WRITE = re.compile(r"\bfs\s*::\s*" + FS_NAMES + r"\b"
                   r"|\b(File\s*::\s*create(?:_new)?|OpenOptions|DirBuilder"
                   r"|BitMapBackend\s*::\s*new)\b")
FS_USE = re.compile(r"\bfs\s*::\s*\{([^}]*)\}")
PROCESS = re.compile(r"\b(process\s*::\s*Command)\b(?:\s*::\s*new\b)?|\b(Command\s*::\s*new)\b")
PROCESS_USE = re.compile(r"\bprocess\s*::\s*\{([^}]*)\}")


def spelled(s):
    """`fs :: write` -> `fs::write` (a match as a message)."""
    return re.sub(r"\s+", "", s)


def rust_files(src_dir):
    """The .rs files of a source folder, without those declared `#[cfg(test)] mod x;`."""
    files = {p: Source(p, p) for p in sorted(src_dir.rglob("*.rs"))}
    test_only = set()
    for p, s in files.items():
        base = p.parent if p.name in ("lib.rs", "main.rs", "mod.rs") else p.with_suffix("")
        for name in s.test_files:
            for cand in (base / f"{name}.rs", base / name / "mod.rs"):
                test_only.add(cand)
            test_only.update(q for q in files if (base / name) in q.parents)
    return [s for p, s in files.items() if p not in test_only]


def scanned_dirs(root):
    dirs = sorted(p for p in (root / "crates").glob("*/src") if p.is_dir())
    if (root / "src").is_dir():
        dirs.append(root / "src")
    return dirs


def check(root, libraries=LIBRARY_CRATES, note=print, writers=WRITING_CRATES):
    """Returns (violations, functions, files): violations are (check, rel, line, message)."""
    root = Path(root)
    violations, functions, files = [], [], []

    def rel(p):
        return p.relative_to(root).as_posix()

    # (a) printing and the environment in library crates
    for name in libraries:
        src_dir = root / "crates" / name / "src"
        if not src_dir.is_dir():
            note(f"check-house: library crate {name}: no crates/{name}/src here, skipped")
            continue
        for s in rust_files(src_dir):
            for m in PRINT.finditer(s.text):
                if not s.in_test(m.start()):
                    violations.append(("print", rel(s.path), line_of(s.text, m.start()),
                                       f"`{m.group(1)}!` in library crate {name}"))
            for m in STDIO.finditer(s.text):
                if not s.in_test(m.start()):
                    what = next(g for g in m.groups() if g)
                    violations.append(("print", rel(s.path), line_of(s.text, m.start()),
                                       f"`{what}` in library crate {name}"))
            for m in ENV.finditer(s.text):
                if not s.in_test(m.start()):
                    violations.append(("env", rel(s.path), line_of(s.text, m.start()),
                                       f"`env::{m.group(1)}` in library crate {name}"))
            for m in ENV_USE.finditer(s.text):
                if s.in_test(m.start()):
                    continue
                for used in re.findall(r"\b" + ENV_NAMES + r"\b", m.group(1)):
                    violations.append(("env", rel(s.path), line_of(s.text, m.start()),
                                       f"`use std::env::{{{used}}}` in library crate {name}"))
            # (a') writing files (except in `writers`) and starting processes
            hits = []
            if name not in writers:
                for m in WRITE.finditer(s.text):
                    hits.append(("write", m.start(), spelled(m.group(0))))
                for m in FS_USE.finditer(s.text):
                    for used in re.findall(r"\b" + FS_NAMES + r"\b", m.group(1)):
                        hits.append(("write", m.start(), f"use std::fs::{{{used}}}"))
            for m in PROCESS.finditer(s.text):
                hits.append(("process", m.start(), spelled(m.group(1) or m.group(2))))
            for m in PROCESS_USE.finditer(s.text):
                if re.search(r"\bCommand\b", m.group(1)):
                    hits.append(("process", m.start(), "use std::process::{Command}"))
            for kind, pos, what in hits:
                if not s.in_test(pos):
                    violations.append((kind, rel(s.path), line_of(s.text, pos),
                                       f"`{what}` in library crate {name}"))

    # (b) file length and (c) function length, every crate and the binary
    for src_dir in scanned_dirs(root):
        for s in rust_files(src_dir):
            if s.generated():
                continue
            n = s.counted_lines()
            files.append((rel(s.path), n))
            if n > MAX_FILE_LINES:
                violations.append(("file", rel(s.path), 1,
                                   f"{n} lines (limit {MAX_FILE_LINES}, tests excluded)"))
            for fname, line, length in s.functions():
                functions.append((rel(s.path), line, fname, length))
                if length > MAX_FN_LINES:
                    violations.append(("fn", rel(s.path), line,
                                       f"fn {fname} is {length} lines (limit {MAX_FN_LINES})"))
    violations.sort(key=lambda v: (v[1], v[2], v[0]))
    return violations, functions, files


def report(functions, files, top=20):
    print(f"check-house: the {top} longest functions (lines, fn line to closing brace):")
    for path, line, name, length in sorted(functions, key=lambda f: (-f[3], f[0], f[1]))[:top]:
        print(f"  {length:5}  {path}:{line}  {name}")
    print(f"check-house: the {top} longest files (lines without inline test modules):")
    for path, n in sorted(files, key=lambda f: (-f[1], f[0]))[:top]:
        print(f"  {n:5}  {path}")


# ----------------------------------------------------------------------------------------
# Self-test


def body_fn(name, lines, indent=""):
    """A function of exactly `lines` lines (fn line to closing brace)."""
    inner = [f"{indent}    let _x{k} = {k};" for k in range(lines - 2)]
    return "\n".join([f"{indent}fn {name}() {{", *inner, f"{indent}}}"]) + "\n"


def self_test():
    lib = (
        "//! println!(\"in a doc comment\") and std::env::var(\"X\")\n"       # 1
        "pub fn hello() -> &'static str {\n"                               # 2
        "    let _s = \"println!(\\\"in a string\\\") env::var(\";\n"        # 3
        "    let _r = r#\"fn fake() { { \" println!() }\"#;\n"               # 4
        "    let _c = ('{', '\\'', '}', b'\"');\n"                           # 5
        "    println!(\"flagged\");\n"                                      # 6
        "    let _v = std::env::var(\"HOME\");\n"                            # 7
        "    let _d = env!(\"CARGO_PKG_NAME\");\n"                           # 8
        "    let _o = option_env!(\"PN_X\");\n"                              # 9
        "    let _t = std::env::temp_dir();\n"                              # 10
        "    let _w = std::io::stderr();\n"                                 # 11
        "    \"x\"\n"                                                       # 12
        "}\n"                                                               # 13
        "/* block /* nested println!() */ still comment eprintln!() */\n"   # 14
        "pub trait T { fn decl(&self); fn with_default(&self) -> u8 { 1 } }\n"  # 15
        "pub fn spawn(c: &mut std::process::Command) { c.stdout(std::process::Stdio::null()); }\n"  # 16
        "pub fn generic<'a, T: Into<[u8; 3]>>(x: &'a T) -> &'a T\n"          # 17
        "where\n"                                                           # 18
        "    T: Clone,\n"                                                   # 19
        "{\n"                                                               # 20
        "    dbg!(x)\n"                                                     # 21
        "}\n"                                                               # 22
        "use std::env::{self, args}; pub fn it() -> impl Iterator<Item = u8> { fn inner() {} inner(); 0..1 }\n"  # 23
        "#[cfg(test)]\n"                                                    # 24
        "mod tests {\n"                                                     # 25
        "    #[test]\n"                                                     # 26
        "    fn t() { println!(\"test output\"); let _ = std::env::var(\"X\"); }\n"  # 27
        "}\n"                                                               # 28
    )
    lines = lib.count("\n")
    # Long functions: a method of 151 lines (flagged), a free one of 150 (not), a pub(crate)
    # const fn of 152 (flagged), a #[test] fn of 200 (not).
    long = "pub struct S;\nimpl<T> From<T> for S {\n    fn from(_: T) -> S {\n"
    long += "".join(f"        let _a{k} = {k};\n" for k in range(148)) + "        S\n    }\n}\n"
    lib += long  # `from` starts at line lines+3
    from_line = lines + 3
    lines = lib.count("\n")
    lib += body_fn("exactly_150", 150)
    lines += 150
    lib += "pub(crate) const fn const_152() {\n" + "".join(
        f"    let _b{k} = {k};\n" for k in range(150)) + "}\n"
    const_line = lines + 1
    lines += 152
    lib += "#[test]\n" + body_fn("long_test", 200)
    lines += 201
    # A file of 901 lines of which 20 are a #[cfg(test)] module: 881 counted, not flagged.
    big_ok = "".join(f"pub const C{k}: u32 = {k};\n" for k in range(881))
    big_ok += "#[cfg(test)]\nmod tests {\n" + "".join(f"    // {k}\n" for k in range(17)) + "}\n"
    big_bad = "".join(f"pub const C{k}: u32 = {k};\n" for k in range(901))
    test_only = "pub fn noisy() { println!(\"only in tests\"); }\n"
    cmd = "fn main() {\n    println!(\"a command may print\");\n}\n"
    # Writing files and starting processes: flagged in libx; in fmtz (a writing crate, as
    # pn-formats) the writes are allowed and the process is not.
    io = (
        "use std::fs::{self, read_to_string, remove_file};\n"                # 1
        "use std::process::{Command, Stdio};\n"                             # 2
        "pub fn save(p: &std::path::Path) -> std::io::Result<()> {\n"       # 3
        "    let _t = read_to_string(p)?; let _f = std::fs::File::open(p)?;\n"  # 4
        "    std::fs::write(p, \"std::fs::write in a string\")?;\n"         # 5
        "    fs::create_dir_all(p)?; let _o = std::fs::File::create(p)?;\n"  # 6
        "    let _c = Command::new(\"ls\").stdout(Stdio::null()).status();\n"  # 7
        "    Ok(())\n"                                                      # 8
        "}\n"                                                               # 9
        "#[cfg(test)]\n"                                                    # 10
        "fn t() { std::fs::write(\"x\", \"\").ok(); std::process::Command::new(\"ls\"); }\n"  # 11
    )
    gen = "// @generated by a tool; do not edit.\n" + "".join(
        f"pub const G{k}: u32 = {k};\n" for k in range(1000))
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        tree = {
            "crates/libx/src/lib.rs": lib + "#[cfg(test)]\nmod helpers;\nmod big_ok;\nmod big_bad;\n",
            "crates/libx/src/helpers.rs": test_only,
            "crates/libx/src/big_ok.rs": big_ok,
            "crates/libx/src/big_bad.rs": big_bad,
            "crates/libx/src/gen.rs": gen,
            "crates/libx/src/io.rs": io,
            "crates/fmtz/src/lib.rs": io,
            "crates/libx/build.rs": "fn main() { println!(\"cargo:rerun-if-changed=x\"); }\n",
            "crates/libx/tests/t.rs": "fn t() { println!(\"x\"); }\n",
            "crates/cmdy/src/main.rs": cmd,
            "src/main.rs": cmd,
        }
        for rel_path, text in tree.items():
            p = root / rel_path
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(text, encoding="utf-8")
        notes = []
        got, functions, files = check(root, ["libx", "fmtz", "missing"], note=notes.append,
                                      writers=["fmtz"])
    lib_rs = "crates/libx/src/lib.rs"
    io_rs = "crates/libx/src/io.rs"
    fmt_rs = "crates/fmtz/src/lib.rs"
    want = [
        ("print", lib_rs, 6, "`println!` in library crate libx"),
        ("env", lib_rs, 7, "`env::var` in library crate libx"),
        ("env", lib_rs, 10, "`env::temp_dir` in library crate libx"),
        ("print", lib_rs, 11, "`stderr` in library crate libx"),
        ("print", lib_rs, 21, "`dbg!` in library crate libx"),
        ("process", lib_rs, 16, "`process::Command` in library crate libx"),
        ("env", lib_rs, 23, "`use std::env::{args}` in library crate libx"),
        ("write", io_rs, 1, "`use std::fs::{remove_file}` in library crate libx"),
        ("process", io_rs, 2, "`use std::process::{Command}` in library crate libx"),
        ("write", io_rs, 5, "`fs::write` in library crate libx"),
        ("write", io_rs, 6, "`fs::create_dir_all` in library crate libx"),
        ("write", io_rs, 6, "`File::create` in library crate libx"),
        ("process", io_rs, 7, "`Command::new` in library crate libx"),
        ("process", fmt_rs, 2, "`use std::process::{Command}` in library crate fmtz"),
        ("process", fmt_rs, 7, "`Command::new` in library crate fmtz"),
        ("fn", lib_rs, from_line, "fn S::from is 151 lines (limit 150)"),
        ("fn", lib_rs, const_line, "fn const_152 is 152 lines (limit 150)"),
        ("file", "crates/libx/src/big_bad.rs", 1, "901 lines (limit 900, tests excluded)"),
    ]
    want.sort(key=lambda v: (v[1], v[2], v[0]))
    ok = True
    if got != want:
        ok = False
        print("check-house self-test: violations differ")
        for v in want:
            if v not in got:
                print(f"  missing:    {v}")
        for v in got:
            if v not in want:
                print(f"  unexpected: {v}")
    fn_names = sorted(f[2] for f in functions if f[0] == lib_rs)
    want_fns = sorted(["hello", "T::with_default", "spawn", "generic", "it", "inner",
                       "S::from", "exactly_150", "const_152"])
    if fn_names != want_fns:
        ok = False
        print(f"check-house self-test: functions {fn_names}, expected {want_fns}")
    lengths = {f[2]: f[3] for f in functions}
    if lengths.get("exactly_150") != 150 or lengths.get("generic") != 6:
        ok = False
        print(f"check-house self-test: lengths {lengths}")
    counted = dict(files)
    if counted.get("crates/libx/src/big_ok.rs") != 881 or "crates/libx/src/gen.rs" in counted \
            or "crates/libx/src/helpers.rs" in counted:
        ok = False
        print(f"check-house self-test: file counts {counted}")
    if notes != ["check-house: library crate missing: no crates/missing/src here, skipped"]:
        ok = False
        print(f"check-house self-test: notes {notes}")
    print(f"check-house self-test: {'ok' if ok else 'FAILED'} ({len(want)} known violations)")
    return 0 if ok else 1


# ----------------------------------------------------------------------------------------


def main(argv):
    if argv[1:] == ["--self-test"]:
        return self_test()
    if argv[1:] not in ([], ["--report"]):
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    root = Path(__file__).resolve().parent.parent
    violations, functions, files = check(root)
    if argv[1:] == ["--report"]:
        report(functions, files)
    what = {
        "print": "library code prints",
        "env": "library code reads the environment",
        "write": "library code writes files",
        "process": "library code starts a process",
        "file": f"file over {MAX_FILE_LINES} lines",
        "fn": f"function over {MAX_FN_LINES} lines",
    }
    for kind, path, line, message in violations:
        print(f"{path}:{line}: {what[kind]}: {message}")
    if violations:
        counts = {k: sum(v[0] == k for v in violations) for k in what}
        summary = ", ".join(f"{n} {k}" for k, n in counts.items() if n)
        print(f"check-house: {len(violations)} violation(s) ({summary})")
        return 1
    print(f"check-house: ok ({len(files)} files, {len(functions)} functions)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
