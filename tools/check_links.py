"""Check the documentation's links: every relative link and image in README.md, CHANGELOG.md and docs/*.md names a
tracked file (and a `#anchor` a heading of its target, as GitHub makes heading ids), and no tracked text file
points outside the repository at the shared folder beside it.

    python tools/check_links.py [--root DIR]

Prints one line per problem (`FILE:LINE: ...`) and exits 1 if there is any, else exits 0 silently.
Links inside code (fenced blocks, `inline code`) are text, not links, and are not checked; URLs with a scheme
(https:, mailto:) are outside the repository and are not checked either.
"""
from __future__ import annotations

import argparse
import re
import subprocess
import sys
import unicodedata
from pathlib import Path
from urllib.parse import unquote

ROOT = Path(__file__).resolve().parents[1]
# spelled in two pieces so that this file does not contain what it looks for
OUTSIDE = ".." + "/shared"

_FENCE = re.compile(r"^\s*(```|~~~)")
_HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
_INLINE_CODE = re.compile(r"(`+)(.+?)\1")
# [text](target) and ![alt](target); the text may hold one level of brackets (an image inside a link)
_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*(<[^>]*>|[^()\s]*(?:\([^()\s]*\)[^()\s]*)*)(?:\s+\"[^\"]*\")?\s*\)")
_HTML_SRC = re.compile(r"<(?:img|a)\b[^>]*?\b(?:src|href)=\"([^\"]+)\"", re.IGNORECASE)
_SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def tracked_files(root: Path) -> set[str]:
    """Paths (POSIX, relative to root) that git tracks; every file under root when root is not a git checkout."""
    try:
        out = subprocess.run(["git", "-C", str(root), "ls-files", "-z"], capture_output=True, check=True).stdout
        return {p for p in out.decode("utf-8", "replace").split("\0") if p}
    except (OSError, subprocess.CalledProcessError):
        return {p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file() and ".git" not in p.parts}


def doc_files(tracked: set[str]) -> list[str]:
    """The documents whose links are checked: README.md, CHANGELOG.md and docs/*.md."""
    return sorted(p for p in tracked if p in ("README.md", "CHANGELOG.md") or re.fullmatch(r"docs/[^/]+\.md", p))


def slug(heading: str) -> str:
    """GitHub's id for a heading: its text lowercased, punctuation dropped, spaces made hyphens."""
    text = _INLINE_CODE.sub(lambda m: m.group(2), heading)
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link in a heading counts by its text
    text = re.sub(r"<[^>]+>", "", text).strip().lower()
    kept = "".join(c for c in text if c in " -_" or unicodedata.category(c)[0] in "LNM")
    return kept.replace(" ", "-")


def _prose_lines(text: str):
    """(line number, line) outside fenced code blocks."""
    fenced = False
    for i, line in enumerate(text.splitlines(), 1):
        if _FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            yield i, line


def anchors(text: str) -> set[str]:
    """Every heading id of a Markdown text, repeats numbered as GitHub numbers them (name, name-1, ...)."""
    seen: dict[str, int] = {}
    out = set()
    for _, line in _prose_lines(text):
        m = _HEADING.match(line)
        if not m:
            continue
        base = slug(m.group(2))
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def links(text: str):
    """(line number, target) of every link and image outside code."""
    for i, line in _prose_lines(text):
        prose = _INLINE_CODE.sub(lambda m: " " * len(m.group(0)), line)
        for m in _LINK.finditer(prose):
            yield i, m.group(1).strip("<>")
        for m in _HTML_SRC.finditer(prose):
            yield i, m.group(1)


def check_doc(root: Path, doc: str, tracked: set[str]) -> list[str]:
    """One line per broken link of one document."""
    problems = []
    text = (root / doc).read_text(encoding="utf-8")
    here = Path(doc).parent
    for line, target in links(text):
        if not target or _SCHEME.match(target) or target.startswith("//"):
            continue
        path, _, anchor = target.partition("#")
        path = unquote(path)
        if path:
            if path.startswith("/"):
                problems.append(f"{doc}:{line}: {target}: an absolute path; fix: link relative to {doc}")
                continue
            resolved = _normalize(here / path)
            if resolved is None:
                problems.append(f"{doc}:{line}: {target}: leads outside the repository; fix: link a tracked file")
                continue
            if resolved not in tracked and not any(t.startswith(resolved.rstrip("/") + "/") for t in tracked):
                problems.append(f"{doc}:{line}: {target}: no tracked file {resolved}; fix: correct the path or "
                                "git add the file")
                continue
        else:
            resolved = doc
        if anchor and resolved.endswith(".md") and resolved in tracked:
            if anchor.lower() not in anchors((root / resolved).read_text(encoding="utf-8")):
                problems.append(f"{doc}:{line}: {target}: no heading #{anchor} in {resolved}; fix: link an existing "
                                "heading")
    return problems


def _normalize(path: Path) -> str | None:
    """A relative path with `.` and `..` resolved, POSIX; None when it climbs out of the repository."""
    parts: list[str] = []
    for part in path.as_posix().split("/"):
        if part in ("", "."):
            continue
        if part == "..":
            if not parts:
                return None
            parts.pop()
        else:
            parts.append(part)
    return "/".join(parts)


def check_outside(root: Path, tracked: set[str]) -> list[str]:
    """One line per tracked text file that names the shared folder outside the repository."""
    problems = []
    needle = OUTSIDE.encode()
    for rel in sorted(tracked):
        try:
            data = (root / rel).read_bytes()
        except OSError:  # tracked but deleted in this working tree
            continue
        if b"\0" in data[:8192] or needle not in data:
            continue
        for i, line in enumerate(data.decode("utf-8", "replace").splitlines(), 1):
            if OUTSIDE in line:
                problems.append(f"{rel}:{i}: points outside the repository ({OUTSIDE}); fix: describe the data "
                                "and take its folder as an argument")
    return problems


def check(root: Path = ROOT) -> list[str]:
    """Every problem found, one line each."""
    tracked = tracked_files(root)
    problems = []
    for doc in doc_files(tracked):
        if (root / doc).is_file():
            problems += check_doc(root, doc, tracked)
    return problems + check_outside(root, tracked)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", type=Path, default=ROOT, help="the repository's root (default: this checkout)")
    problems = check(ap.parse_args(argv).root)
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
