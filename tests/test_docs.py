"""The documentation site builds with every warning an error (``mkdocs build --strict``): a
broken link, a page missing from the navigation's files, an anchor no page has or an API
cross-reference that does not resolve fails it. The how-to pages' code runs in
``tests/test_howto.py``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]

pytest.importorskip("mkdocs", reason="the docs extra: pip install -e '.[docs]'")
pytest.importorskip("mkdocstrings_handlers.python", reason="the docs extra")


def test_the_site_builds_with_warnings_as_errors(tmp_path):
    site = tmp_path / "site"
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    )
    env["NO_MKDOCS_2_WARNING"] = "1"  # Material's notice about a future MkDocs, on every build
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    settings = (site / "reference" / "settings" / "index.html").read_text()
    assert "<table>" in settings  # the generated tables replaced the marker
    api = (site / "reference" / "api" / "experiment" / "index.html").read_text()
    assert 'id="maopg.experiment.evaluation.inference.load_policy"' in api
    assert ":class:" not in api  # the docstrings' roles became links or code
    # The repository files the pages link to are on the site, the README as the home page.
    assert (site / "repo" / "results" / "tables" / "index.html").exists()
    assert (site / "repo" / "results" / "fig4_tool_delivery.png").exists()
    assert "scripts/test.sh" in (site / "index.html").read_text()


def test_the_citation_file_cites_the_paper_and_the_software():
    """``CITATION.cff`` has what the Citation File Format 1.2.0 requires, and the paper as its
    preferred citation (what GitHub's "Cite this repository" shows)."""
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0"
    assert {"message", "title", "authors", "type"} <= set(cff) and cff["type"] == "software"
    paper = cff["preferred-citation"]
    assert paper["title"].startswith("Asynchronous, Option-Based Multi-Agent Policy Gradient")
    assert paper["authors"][0]["family-names"] == "Lyu"
