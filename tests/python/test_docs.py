"""The README and the guide: short enough for a newcomer, every relative link resolves, and
nothing points outside the repository."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", ROOT / "ARCHITECTURE.md", ROOT / "benches" / "README.md",
         ROOT / "results" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def anchors(page: Path) -> set[str]:
    """GitHub's heading anchors (lower case, punctuation dropped, spaces to hyphens) and the
    explicit ones (`<a id="..."></a>`)."""
    out = set()
    for line in page.read_text().splitlines():
        out.update(re.findall(r'<a id="([^"]+)"></a>', line))
        if line.startswith("#"):
            title = line.lstrip("#").strip().lower()
            out.add(re.sub(r"[^\w\- ]", "", title).replace(" ", "-"))
    return out


def test_readme_is_short() -> None:
    assert len((ROOT / "README.md").read_text().splitlines()) < 250


def test_every_link_resolves() -> None:
    broken = []
    for page in PAGES:
        for target in LINK.findall(page.read_text()):
            if re.match(r"^[a-z]+:", target):
                continue  # an address on the web
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            if not dest.exists():
                broken.append(f"{page.relative_to(ROOT)}: {target}")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                broken.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    assert broken == []


def test_nothing_points_outside_the_repository() -> None:
    offenders = []
    for page in PAGES:
        for n, line in enumerate(page.read_text().splitlines(), 1):
            if "../shared" in line or "MODEL.md" in line:
                offenders.append(f"{page.relative_to(ROOT)}:{n}")
            for target in LINK.findall(line):
                if not re.match(r"^[a-z]+:", target):
                    dest = (page.parent / target.partition("#")[0]).resolve()
                    if ROOT not in dest.parents and dest != ROOT:
                        offenders.append(f"{page.relative_to(ROOT)}:{n}: {target}")
    assert offenders == []
