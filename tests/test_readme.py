"""The README is a user's page: its code runs, it stays short, and its links resolve.

* Every fenced ```python block of README.md is executed, **each in a fresh namespace**
  (a block must define or import every name it uses), with the repository root as the
  working directory; a failure names the block's number (1-based, in file order) and its
  first line in README.md.
* README.md is at most 12 KiB.
* Every relative link and image in README.md and in the hand-written Markdown pages under
  docs/ points to a file or folder of the repository, and a ``#fragment`` to a heading of
  the page it names (GitHub's heading anchors).
"""

from __future__ import annotations

import re
import traceback
from pathlib import Path
from urllib.parse import unquote

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_README_BYTES = 12 * 1024

#: hand-written pages whose links are checked (reports under docs/results/*/ are generated)
DOC_PAGES = [README, *sorted((ROOT / "docs").glob("*.md")), ROOT / "docs" / "results" / "README.md"]

_FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```[ \t]*$", re.S | re.M)
_LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_HEADING = re.compile(r"^(#{1,6})[ \t]+(.+?)[ \t]*#*[ \t]*$", re.M)


def python_blocks(text: str) -> list[tuple[int, str]]:
    """``(line number of the opening fence, code)`` of every ```python block."""
    out = []
    for m in _FENCE.finditer(text):
        if m.group(1).strip().lower() in ("python", "py", "python3"):
            out.append((text.count("\n", 0, m.start()) + 1, m.group(2)))
    return out


def _without_code(text: str) -> str:
    """The text with fenced blocks and inline code blanked (links there are not links)."""
    text = _FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    return re.sub(r"`[^`\n]*`", "``", text)


def relative_links(text: str) -> list[str]:
    """Targets of the page's Markdown links and images that are not URLs."""
    targets = [m.group(1) for m in _LINK.finditer(_without_code(text))]
    return [t for t in targets if not re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", t)]


def heading_anchors(text: str) -> set[str]:
    """GitHub's anchors of a page's headings: lower case, punctuation other than ``-`` and
    ``_`` dropped, spaces to ``-``; repeated headings get ``-1``, ``-2``, ..."""
    seen: dict[str, int] = {}
    anchors = set()
    for m in _HEADING.finditer(_FENCE.sub("", text)):
        title = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", m.group(2))    # links: their text
        slug = re.sub(r"[^\w\- ]", "", title.replace("`", "").strip().lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        anchors.add(slug if n == 0 else f"{slug}-{n}")
        seen[slug] = n + 1
    return anchors


def test_readme_is_at_most_12_kib():
    size = README.stat().st_size
    assert size <= MAX_README_BYTES, (
        f"README.md is {size} bytes, more than {MAX_README_BYTES}: move detail to docs/")


def test_readme_has_python_examples():
    assert python_blocks(README.read_text(encoding="utf-8")), "README.md has no ```python block"


@pytest.mark.parametrize("number, line, code", [
    (k, line, code) for k, (line, code) in
    enumerate(python_blocks(README.read_text(encoding="utf-8")), start=1)])
def test_readme_python_block_runs(number, line, code, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    namespace = {"__name__": f"readme_block_{number}"}
    try:
        exec(compile(code, f"README.md, python block {number} (line {line})", "exec"),
             namespace)
    except Exception:
        pytest.fail(f"README.md python block {number} (line {line}) failed:\n"
                    f"{traceback.format_exc()}", pytrace=False)
    capsys.readouterr()


@pytest.mark.parametrize("page", DOC_PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(page):
    text = page.read_text(encoding="utf-8")
    broken = []
    for target in relative_links(text):
        path, _, fragment = unquote(target).partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif not dest.is_relative_to(ROOT):
            broken.append(f"{target}: outside the repository")
        elif fragment and dest.suffix == ".md" and dest.is_file() and \
                fragment not in heading_anchors(dest.read_text(encoding="utf-8")):
            broken.append(f"{target}: no heading with anchor #{fragment}")
    assert not broken, f"{page.relative_to(ROOT)}: broken links:\n  " + "\n  ".join(broken)


def test_link_helpers_on_known_cases():
    text = ("# A title, with `code` (and/parens)\n\n## A title, with `code` (and/parens)\n"
            "see [x](docs/a.md#b) ![img](p.png) [web](https://e.org) `[no](link.md)`\n"
            "```python\nprint('[no](link.md)')\n```\n")
    assert heading_anchors(text) == {"a-title-with-code-andparens",
                                     "a-title-with-code-andparens-1"}
    assert relative_links(text) == ["docs/a.md#b", "p.png"]
    assert python_blocks(text) == [(5, "print('[no](link.md)')\n")]
