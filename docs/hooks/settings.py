"""The settings reference, generated at build time: this MkDocs hook replaces the marker line
of ``docs/reference/settings.md`` with the tables
``maopg.experiment.run.settings_reference.settings_markdown()`` writes from the config
dataclasses themselves (every setting's name, type, default, bounds and meaning), so the page
cannot fall behind the code. The function imports no torch, so the build stays fast."""

from __future__ import annotations

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.structure.files import Files
from mkdocs.structure.pages import Page

MARKER = "<!-- settings_markdown() -->"
"""The line the generated tables replace."""


def on_page_markdown(markdown: str, page: Page, config: MkDocsConfig, files: Files) -> str:
    if MARKER not in markdown:
        return markdown
    from maopg.experiment.run.settings_reference import settings_markdown

    return markdown.replace(MARKER, settings_markdown())
