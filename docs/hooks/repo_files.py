"""Links from the site's pages to the repository's other files work on the site as on GitHub.

The pages link to files outside ``docs/`` by their relative paths in the repository
(``../../results/tables.md``, ``../examples/berries.py``): GitHub follows those links, and so
does the site, because this MkDocs hook puts every such file into it under ``repo/`` (the
repository's own layout below it) and rewrites the links to point there. A Markdown file
becomes a page (not in the navigation; its own links are followed the same way, so the
generated results pages and their figures come along), any other file is copied as it is (a
figure is shown, a Python file served as text), and a folder is its ``README.md`` or, without
one, a generated list of its files. A link to a file that does not exist is left alone, so
``mkdocs build --strict`` fails on it. The repository's ``README.md`` is the home page (where
``docs/`` has no ``index.md``), its links read from the repository's root as on GitHub.
"""

from __future__ import annotations

import posixpath
import re
import subprocess
from pathlib import Path
from urllib.parse import unquote, urlsplit

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.structure.files import File, Files
from mkdocs.structure.pages import Page

MOUNT = "repo"
"""The site folder the repository's files outside ``docs/`` are put under."""
HOME = ("index.md", "README.md")
"""The home page, and the repository file it is."""
FENCE = re.compile(r"^(```|~~~).*?^\1[^\n]*$", re.DOTALL | re.MULTILINE)
"""A fenced code block: its ``[text](target)`` is code, not a link."""
LINK = re.compile(r"(\]\()([^)\s]+)((?:\s+\"[^\"]*\")?\))")
"""A Markdown link or image, ``[text](target "title")``: groups before, target, after."""


def _root(config: MkDocsConfig) -> Path:
    return Path(config.config_file_path).resolve().parent


def _docs_prefix(config: MkDocsConfig) -> str:
    return Path(config.docs_dir).resolve().relative_to(_root(config)).as_posix()


def _repo_path_of(file: File, config: MkDocsConfig) -> str:
    """The repository path a site file stands for."""
    if file.src_uri == HOME[0] and file.generated_by is not None:
        return HOME[1]
    if file.src_uri.startswith(MOUNT + "/"):
        return file.src_uri.removeprefix(MOUNT + "/")
    return f"{_docs_prefix(config)}/{file.src_uri}"


def _target(source: str, link: str, root: Path) -> tuple[str, str] | None:
    """The repository path (a file, or a folder's ``README.md`` or listing) and the anchor a
    link of the file at repository path ``source`` points to; None for a URL, an anchor of the
    page itself, or a path that leaves the repository or does not exist."""
    path, hash_, anchor = link.partition("#")
    if not path or urlsplit(path).scheme or path.startswith("/"):
        return None
    joined = posixpath.normpath(posixpath.join(posixpath.dirname(source), unquote(path)))
    if joined.startswith("..") or not (root / joined).exists():
        return None
    if (root / joined).is_dir():
        readme = root / joined / "README.md"
        joined = f"{joined}/README.md" if readme.exists() else f"{joined}/index.md"
    return joined, hash_ + anchor


def _site_path(repo_path: str, config: MkDocsConfig) -> str:
    if repo_path == HOME[1]:
        return HOME[0]
    prefix = _docs_prefix(config) + "/"
    if repo_path.startswith(prefix):
        return repo_path.removeprefix(prefix)
    return f"{MOUNT}/{repo_path}"


def _links(markdown: str) -> list[str]:
    return [m.group(2) for m in LINK.finditer(FENCE.sub("", markdown))]


def _files_in(root: Path, folder: str) -> list[str]:
    """The names of the files directly in a repository folder: the ones git tracks, in a
    checkout (a clone's local runs and weights stay off the site), else every one."""
    try:
        listed = subprocess.run(
            ["git", "ls-files", "--", folder],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.splitlines()
    except (OSError, subprocess.CalledProcessError):
        return sorted(p.name for p in (root / folder).iterdir() if p.is_file())
    return sorted(posixpath.basename(p) for p in listed if posixpath.dirname(p) == folder)


def _listing(root: Path, folder: str) -> str:
    """A page listing the files of a repository folder that has no ``README.md``."""
    items = "\n".join(f"- [`{name}`]({name})" for name in _files_in(root, folder))
    return f"# `{folder}/`\n\nThe files of the repository's folder `{folder}/`:\n\n{items}\n"


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """Add every repository file outside ``docs/`` that a page links to, transitively."""
    root = _root(config)
    if files.get_file_from_path(HOME[0]) is None:
        files.append(File.generated(config, HOME[0], abs_src_path=str(root / HOME[1])))
    pending = list(files.documentation_pages())
    while pending:
        page = pending.pop()
        source = _repo_path_of(page, config)
        for link in _links(page.content_string):
            found = _target(source, link, root)
            if found is None:
                continue
            site_path = _site_path(found[0], config)
            if files.get_file_from_path(site_path) is not None:
                continue
            if (root / found[0]).exists():
                added = File.generated(config, site_path, abs_src_path=str(root / found[0]))
            else:  # a folder without a README.md
                folder = posixpath.dirname(found[0])
                added = File.generated(config, site_path, content=_listing(root, folder))
            files.append(added)
            if added.is_documentation_page():
                pending.append(added)
    return files


def on_page_markdown(markdown: str, page: Page, config: MkDocsConfig, files: Files) -> str:
    """Point the page's links to repository files at their copies on the site."""
    root = _root(config)
    source = _repo_path_of(page.file, config)
    here = posixpath.dirname(page.file.src_uri)

    def rewrite(match: re.Match) -> str:
        found = _target(source, match.group(2), root)
        if found is None:
            return match.group(0)
        relative = posixpath.relpath(_site_path(found[0], config), here or ".")
        return f"{match.group(1)}{relative}{found[1]}{match.group(3)}"

    parts, last = [], 0
    for fence in FENCE.finditer(markdown):
        parts.append(LINK.sub(rewrite, markdown[last : fence.start()]))
        parts.append(fence.group(0))
        last = fence.end()
    parts.append(LINK.sub(rewrite, markdown[last:]))
    return "".join(parts)
