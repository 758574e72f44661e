#!/usr/bin/env python3
"""Checks the relative links of the user documentation.

Every relative link in README.md and docs/**/*.md must resolve to an existing file or
folder of the repository; a link with an #anchor into a Markdown file must name one of its
headings, by GitHub's rule for heading ids: the heading text (inline code, emphasis and link
syntax reduced to their text) in lower case, every character that is not a letter, a digit,
a space, '-' or '_' removed, each space replaced by '-'; the second heading with the same id
gets '-1', the third '-2', and so on. Explicit anchors (<a name="x"> or id="x") count as
headings too.

Links with a scheme (http:, https:, mailto:, ...) are not checked. Fenced code blocks and
inline code are skipped.

    python3 .ci/check-links.py              # check README.md and docs/ of this repository
    python3 .ci/check-links.py ROOT         # ... of another tree
    python3 .ci/check-links.py --self-test  # check the checker on a small tree of its own

Exit status 0 when every link resolves, 1 otherwise (every broken link listed as
file:line: link: reason), 2 on bad usage.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
import unicodedata
from pathlib import Path
from urllib.parse import unquote

SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")
FENCE = re.compile(r"^ {0,3}(`{3,}|~{3,})")
CODE_SPAN = re.compile(r"(`+)(.+?)\1")
HEADING = re.compile(r"^ {0,3}(#{1,6})[ \t]+(.*?)[ \t#]*$")
SETEXT = re.compile(r"^ {0,3}(=+|-+)[ \t]*$")
REF_DEF = re.compile(r"^ {0,3}\[[^\]]+\]:[ \t]*<?([^ \t>]+)>?")
HTML_ANCHOR = re.compile(r"<a\s[^>]*?(?:name|id)\s*=\s*[\"']([^\"']+)[\"']", re.I)
HTML_LINK = re.compile(r"<(?:a|img)\s[^>]*?(?:href|src)\s*=\s*[\"']([^\"']+)[\"']", re.I)


def blank_code(lines: list[str]) -> list[str]:
    """The lines with fenced code blocks emptied and inline code spans blanked out."""
    out, fence = [], None
    for line in lines:
        m = FENCE.match(line)
        if fence is None and m:
            fence = m.group(1)
            out.append("")
            continue
        if fence is not None:
            if m and m.group(1)[0] == fence[0] and len(m.group(1)) >= len(fence):
                fence = None
            out.append("")
            continue
        out.append(CODE_SPAN.sub(lambda s: " " * len(s.group(0)), line))
    return out


def heading_text(raw: str) -> str:
    """The text of a heading line's content: link and image syntax, code ticks, emphasis
    markers and HTML tags reduced to the words GitHub uses for the id."""
    s = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", raw)
    s = re.sub(r"<[^>]+>", "", s)
    s = s.replace("`", "")
    s = re.sub(r"(\*\*|__|\*|(?<!\w)_|_(?!\w))", "", s)
    return s.strip()


def slug(text: str) -> str:
    """GitHub's heading id of `text` (before the duplicate suffix)."""
    keep = []
    for c in text.lower():
        if c in " -_":
            keep.append(c)
        elif unicodedata.category(c)[0] in "LNM":
            keep.append(c)
    return "".join(keep).replace(" ", "-")


def anchors(path: Path, cache: dict[Path, set[str]]) -> set[str]:
    """Every heading id (and explicit anchor) of the Markdown file `path`."""
    if path in cache:
        return cache[path]
    lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    plain = blank_code(lines)
    seen: dict[str, int] = {}
    ids: set[str] = set()

    def add(base: str) -> None:
        n = seen.get(base, 0)
        ids.add(base if n == 0 else f"{base}-{n}")
        seen[base] = n + 1

    fenced = [p == "" and l != "" for p, l in zip(plain, lines)]
    for i, line in enumerate(plain):
        if fenced[i]:
            continue
        m = HEADING.match(lines[i])
        if m and not fenced[i]:
            add(slug(heading_text(m.group(2))))
        elif (
            SETEXT.match(line)
            and i > 0
            and plain[i - 1].strip()
            and not fenced[i - 1]
            and not HEADING.match(lines[i - 1])
            and not lines[i - 1].lstrip().startswith("|")
            and line.strip()[0] == "="
        ):
            add(slug(heading_text(lines[i - 1])))
        for a in HTML_ANCHOR.findall(line):
            ids.add(a)
    cache[path] = ids
    return ids


def link_targets(line: str) -> list[str]:
    """The targets of the inline links and images `[text](target "title")` on `line`, of
    reference definitions `[id]: target` and of HTML href/src attributes."""
    found = []
    i = 0
    while True:
        j = line.find("](", i)
        if j < 0:
            break
        k, depth = j + 2, 0
        while k < len(line) and line[k] in " \t":
            k += 1
        if k < len(line) and line[k] == "<":
            end = line.find(">", k)
            if end < 0:
                i = j + 2
                continue
            found.append(line[k + 1 : end])
            i = end + 1
            continue
        start = k
        while k < len(line):
            c = line[k]
            if c == "\\":
                k += 2
                continue
            if c == "(":
                depth += 1
            elif c == ")":
                if depth == 0:
                    break
                depth -= 1
            elif c in " \t":
                break
            k += 1
        target = line[start:k]
        if target:
            found.append(target)
        i = k
    m = REF_DEF.match(line)
    if m:
        found.append(m.group(1))
    found.extend(HTML_LINK.findall(line))
    return found


def check_file(md: Path, root: Path, cache: dict[Path, set[str]]) -> list[str]:
    """The broken links of `md`, as 'file:line: link: reason'."""
    errors = []
    lines = md.read_text(encoding="utf-8", errors="replace").splitlines()
    rel_md = md.relative_to(root).as_posix()
    for n, line in enumerate(blank_code(lines), start=1):
        for target in link_targets(line):
            if SCHEME.match(target):
                continue
            path_part, _, anchor = target.partition("#")
            path_part = unquote(path_part)
            if path_part == "":
                dest = md
            elif path_part.startswith("/"):
                dest = root / path_part.lstrip("/")
            else:
                dest = md.parent / path_part
            dest = Path(os.path.normpath(dest))
            try:
                dest.relative_to(root)
            except ValueError:
                errors.append(f"{rel_md}:{n}: {target}: points outside the repository")
                continue
            if not dest.exists():
                errors.append(f"{rel_md}:{n}: {target}: no such file")
                continue
            if anchor and dest.is_file() and dest.suffix.lower() == ".md":
                if unquote(anchor).lower() not in {a.lower() for a in anchors(dest, cache)}:
                    where = "this file" if dest == md else dest.relative_to(root).as_posix()
                    errors.append(f"{rel_md}:{n}: {target}: no heading #{anchor} in {where}")
    return errors


def markdown_files(root: Path) -> list[Path]:
    files = [root / "README.md"] if (root / "README.md").is_file() else []
    docs = root / "docs"
    if docs.is_dir():
        files += sorted(p for p in docs.rglob("*.md") if p.is_file())
    return files


def check(root: Path) -> list[str]:
    root = Path(os.path.normpath(root.resolve()))
    cache: dict[Path, set[str]] = {}
    errors = []
    for md in markdown_files(root):
        errors += check_file(md, root, cache)
    return errors


def self_test() -> int:
    """Builds a small tree with good and broken links; the checker must report exactly the
    broken ones."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "docs" / "sub").mkdir(parents=True)
        (root / "data").mkdir()
        (root / "data" / "x.csv").write_text("a\n")
        (root / "README.md").write_text(
            "# Title\n"
            "See [guide](docs/guide.md), [section](docs/guide.md#the-setup-step),\n"
            "[dup](docs/guide.md#notes-1), [data](data/x.csv), [folder](data/),\n"
            "[web](https://example.com/nope), [mail](mailto:a@b.c), ![img](data/x.csv)\n"
            "[top](#title) and [code](src/lib.rs) <- broken: no src/lib.rs\n"
            "[bad anchor](docs/guide.md#no-such-heading)\n"
            "`[in code](missing.md)` is code, not a link\n"
            "```sh\n[fenced](missing-too.md)\n```\n"
            "[ref]: docs/missing-ref.md\n"
        )
        (root / "docs" / "guide.md").write_text(
            "# Guide\n\n## The *setup* step\n\n## Notes\n\ntext\n\n## Notes\n\n"
            "## `pn solve --bc x=marshak`, per face (§3)\n\n"
            "Other\n=====\n\n"
            "Back to [the readme](../README.md#title), [self](#notes),\n"
            "[per face](#pn-solve---bc-xmarshak-per-face-3), [setext](#other),\n"
            "[escape](../../outside.md), [sub](sub/page.md#deep), [nested](sub/page.md#nope)\n"
            "[parens](sub/page.md#a-b) [angle](<sub/page.md>)\n"
        )
        (root / "docs" / "sub" / "page.md").write_text(
            "## Deep\n\n### A (b)\n\n<a name=\"custom\"></a>\n[c](#custom) [d](../guide.md#guide)\n"
        )
        got = sorted(check(root))
        want = sorted(
            [
                "README.md:5: src/lib.rs: no such file",
                "README.md:6: docs/guide.md#no-such-heading: no heading #no-such-heading in docs/guide.md",
                "README.md:11: docs/missing-ref.md: no such file",
                "docs/guide.md:18: ../../outside.md: points outside the repository",
                "docs/guide.md:18: sub/page.md#nope: no heading #nope in docs/sub/page.md",
            ]
        )
        if got != want:
            print("check-links self-test FAILED", file=sys.stderr)
            print("  expected:", *want, sep="\n    ", file=sys.stderr)
            print("  got:", *got, sep="\n    ", file=sys.stderr)
            return 1
        # Slugs of GitHub's rule.
        cases = {
            "3. Staggered grids": "3-staggered-grids",
            "Field sampling at material interfaces (`--sampling exact|average[:N]`)":
                "field-sampling-at-material-interfaces---sampling-exactaveragen",
            "A cheaper assembly and setup, and an f32 Krylov basis at any size":
                "a-cheaper-assembly-and-setup-and-an-f32-krylov-basis-at-any-size",
            "In renders (2026-12-05)": "in-renders-2026-12-05",
            "Solver tuning (experts)": "solver-tuning-experts",
            "snake_case and σ_t": "snake_case-and-σ_t",
        }
        for text, want_slug in cases.items():
            got_slug = slug(heading_text(text))
            if got_slug != want_slug:
                print(f"check-links self-test FAILED: slug({text!r}) = {got_slug!r}, "
                      f"expected {want_slug!r}", file=sys.stderr)
                return 1
    print("check-links self-test: ok")
    return 0


def main(argv: list[str]) -> int:
    if argv and argv[0] in ("-h", "--help"):
        print(__doc__)
        return 0
    if argv and argv[0] == "--self-test":
        return self_test()
    if len(argv) > 1:
        print("usage: check-links.py [ROOT] | --self-test", file=sys.stderr)
        return 2
    root = Path(argv[0]) if argv else Path(__file__).resolve().parent.parent
    errors = check(root)
    for e in errors:
        print(e)
    if errors:
        print(f"check-links: {len(errors)} broken link(s)", file=sys.stderr)
        return 1
    print(f"check-links: ok ({len(markdown_files(Path(os.path.normpath(root.resolve()))))} files)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
