"""Every relative link in the project's Markdown files points at a file that exists."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
# The user's guide and its pages, the package READMEs, the policy cards and the notebook.
DOCS = sorted({*REPO.glob("*.md"), *REPO.glob("docs/*.md"), *REPO.glob("*/README.md"),
               *REPO.glob("policies/trained/*/CARD.md"), *REPO.glob("experiments/**/*.md")})
LINK = re.compile(r"\]\(([^)\s]+)\)")


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.relative_to(REPO).as_posix())
def test_relative_links_resolve(doc: Path) -> None:
    broken = []
    for target in LINK.findall(doc.read_text(encoding="utf-8")):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue  # a web address or an anchor in the same page
        path = (doc.parent / target.split("#", 1)[0]).resolve()
        if not path.exists():
            broken.append(target)
    assert not broken, f"{doc.relative_to(REPO)}: links to missing files {broken}"
