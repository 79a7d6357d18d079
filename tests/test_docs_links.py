"""The documentation holds together: every relative link of README.md and docs/ reaches a file
(and, with a `#fragment`, a heading of that Markdown file), and each reference page stays short,
its studies in docs/reports/."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md")])
REFERENCE_PAGES = sorted((ROOT / "docs").glob("*.md"))
MAX_PAGE_LINES = 300
"""A reference page (docs/*.md) starts with how to use its package and stays this short."""

FENCE = re.compile(r"^(```|~~~).*?^\1", re.MULTILINE | re.DOTALL)
CODE_SPAN = re.compile(r"(`+).+?\1", re.DOTALL)
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*#*\s*$", re.MULTILINE)
SCHEME = re.compile(r"[a-z][a-z0-9+.-]*:", re.IGNORECASE)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: a link's text kept, lower case, punctuation but `-` and `_`
    dropped, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)
    return re.sub(r"[^\w\- ]", "", text.lower()).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every heading anchor of a Markdown file; a repeated one numbered as GitHub numbers it."""
    seen: dict[str, int] = {}
    for heading in HEADING.findall(FENCE.sub("", path.read_text(encoding="utf-8"))):
        base = slug(heading)
        seen[base] = seen.get(base, 0) + 1
        if seen[base] > 1:
            seen[f"{base}-{seen[base] - 1}"] = 1
    return set(seen)


def broken_links(page: Path) -> list[str]:
    """The relative links of ``page`` (outside code) that reach no file, or no heading of the
    Markdown file they name."""
    prose = CODE_SPAN.sub("", FENCE.sub("", page.read_text(encoding="utf-8")))
    broken = []
    for target in LINK.findall(prose):
        if SCHEME.match(target):  # https:, mailto:, ...
            continue
        file, _, fragment = target.partition("#")
        path = (page.parent / file).resolve() if file else page
        if not path.exists():
            broken.append(f"{target} (no such file)")
        elif fragment and path.suffix == ".md" and fragment not in anchors(path):
            broken.append(f"{target} (no such heading)")
    return broken


def test_slug_is_githubs():
    assert slug("Decoding (the paper's Sec. 3.3 and 4.3)") == "decoding-the-papers-sec-33-and-43"
    assert slug("The approach check (`approach_check=True`, `--approach-check`)") == (
        "the-approach-check-approach_checktrue---approach-check"
    )


def test_repeated_headings_are_numbered(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("# Notes\n## Notes\n```\n# not a heading\n```\n## Notes\n")
    assert anchors(page) == {"notes", "notes-1", "notes-2"}


def test_the_checker_finds_broken_links_and_leaves_code_alone(tmp_path):
    (tmp_path / "other.md").write_text("# Some heading\n")
    page = tmp_path / "page.md"
    page.write_text(
        "# Top\n[ok](other.md#some-heading) [self](#top) [web](https://example.com)\n"
        "[gone](missing.md) [no anchor](other.md#nowhere) `[code](ignored.md)`\n"
        "```\n[block](ignored.md)\n```\n"
    )
    assert broken_links(page) == ["missing.md (no such file)", "other.md#nowhere (no such heading)"]


@pytest.mark.parametrize("page", PAGES, ids=lambda path: str(path.relative_to(ROOT)))
def test_every_relative_link_resolves(page):
    assert broken_links(page) == []


@pytest.mark.parametrize("page", REFERENCE_PAGES, ids=lambda path: path.name)
def test_reference_pages_stay_short(page):
    lines = len(page.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_PAGE_LINES, (
        f"docs/{page.name} has {lines} lines, over {MAX_PAGE_LINES}: move its studies and "
        "measurement campaigns to docs/reports/ and link them"
    )
