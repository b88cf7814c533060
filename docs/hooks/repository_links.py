"""MkDocs hook: links to repository files outside docs/, and pages that include a repository file.

* A Markdown link from a page to a file of the repository outside ``docs/`` (``../CONTRIBUTING.md``,
  ``../benchmarks/README.md``) has no page in the site. The link is checked here (a missing file
  is an error, like MkDocs' own check of links inside the site) and rendered as the path in code.
* A page line ``<!-- include: PATH -->`` is replaced by the repository file PATH (relative to the
  repository root, e.g. ``CHANGELOG.md``); its links into ``docs/`` are made relative to the page.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from mkdocs.exceptions import PluginError

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
LINK = re.compile(r"\[([^\]]+)\]\(([^)\s#]+)(#[^)\s]*)?\)")
INCLUDE = re.compile(r"^<!-- include: (\S+) -->$", re.M)


def _include(match: re.Match, page_dir: Path) -> str:
    source = ROOT / match.group(1)
    if not source.is_file():
        raise PluginError(f"include of a missing file: {match.group(1)}")
    text = source.read_text()

    def relink(link: re.Match) -> str:
        target = (source.parent / link.group(2)).resolve()
        if link.group(2).startswith(("http:", "https:", "mailto:", "#")):
            return link.group(0)
        if not target.is_relative_to(DOCS):  # a repository file: no page of the site
            if not target.exists():
                raise PluginError(f"{match.group(1)}: link to a missing repository file {link.group(2)}")
            return link.group(1)
        return f"[{link.group(1)}]({os.path.relpath(target, page_dir)}{link.group(3) or ''})"

    return LINK.sub(relink, text)


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Includes first, then links that leave docs/."""
    page_dir = (DOCS / page.file.src_uri).parent
    markdown = INCLUDE.sub(lambda m: _include(m, page_dir), markdown)

    def outside(link: re.Match) -> str:
        if link.group(2).startswith(("http:", "https:", "mailto:")):
            return link.group(0)
        target = (page_dir / link.group(2)).resolve()
        if target.is_relative_to(DOCS):
            return link.group(0)  # MkDocs checks it
        if not target.exists():
            raise PluginError(f"{page.file.src_uri}: link to a missing repository file {link.group(2)}")
        text = link.group(1)
        return text if text.startswith("`") else f"{text} (`{target.relative_to(ROOT)}`)"

    return LINK.sub(outside, markdown)
