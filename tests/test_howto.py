"""Every code block of the how-to pages (``docs/howto/*.md``) runs as written.

A page's blocks run in page order in one fresh folder, as a user would type them at the root of
a clone: ``bash`` blocks in bash (``set -euo pipefail``), ``python`` blocks in one Python
process that keeps their names from block to block, with this checkout first on the path (so
``python -m train`` and ``--import examples.berries`` work from the folder). The pages' blocks
are written with small budgets (``--total-samples 600``, a few ticks or episodes) and say how to
make them long, so the commands users copy are the commands tested. A block that cannot run
here (a cluster of machines, a W&B account) is preceded by ``<!-- not run: REASON -->``;
every other fence must be ``bash`` or ``python``, so no block escapes unnoticed.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs" / "howto").glob("*.md"))
BLOCK = re.compile(
    r"^(?:<!-- not run: (?P<why>[^\n]+?) -->\n)?```(?P<lang>[^\n]*)\n(?P<code>.*?)^```[ \t]*$",
    re.MULTILINE | re.DOTALL,
)
FENCE = re.compile(r"^[ \t]*```", re.MULTILINE)

RUNNER = """
import json, subprocess, sys
namespace = {"__name__": "__main__"}
for block in json.load(open(sys.argv[1])):
    print(f"--- {block['where']}", flush=True)
    if block["lang"] == "bash":
        subprocess.run(["bash", "-euo", "pipefail", "-c", block["code"]], check=True)
    else:
        code = "\\n" * (block["line"] - 1) + block["code"]
        exec(compile(code, block["page"], "exec"), namespace)
"""
"""Runs a page's blocks (a JSON list) in order; a Python block's traceback names the page and
line."""
TIMEOUT_S = 600


def blocks(page: Path) -> list[dict]:
    """The page's blocks to run: language, code, page and first line of code."""
    text = page.read_text()
    found = list(BLOCK.finditer(text))
    assert len(FENCE.findall(text)) == 2 * len(found), (
        f"{page.name}: a fence is indented or unclosed (blocks must start at the line's start)"
    )
    result = []
    for match in found:
        line = text.count("\n", 0, match.start("code")) + 1
        if match["why"]:
            continue
        assert match["lang"] in ("bash", "python"), (
            f"{page.name}:{line}: a ```{match['lang']} block; write bash or python, or mark it "
            "<!-- not run: REASON -->"
        )
        result.append(
            {
                "lang": match["lang"],
                "code": match["code"],
                "page": str(page),
                "line": line,
                "where": f"{page.relative_to(ROOT)}:{line}",
            }
        )
    return result


def test_every_how_to_page_has_code_to_run():
    assert len(PAGES) >= 8
    for page in PAGES:
        assert blocks(page), f"{page.name} has no block that runs"


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=[p.stem for p in PAGES])
def test_the_pages_blocks_run(page, tmp_path):
    (tmp_path / "blocks.json").write_text(json.dumps(blocks(page)))
    env = {k: v for k, v in os.environ.items() if not k.startswith("WANDB_")}
    env.update(
        PATH=os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")]),
        PYTHONPATH=os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]),
        # W&B without an account, and its settings and cache in the test's folder.
        WANDB_MODE="offline",
        WANDB_CONFIG_DIR=str(tmp_path / "wandb-home"),
        WANDB_CACHE_DIR=str(tmp_path / "wandb-home"),
        WANDB_DATA_DIR=str(tmp_path / "wandb-home"),
    )
    work = tmp_path / "work"
    work.mkdir()
    result = subprocess.run(
        [sys.executable, "-c", RUNNER, str(tmp_path / "blocks.json")],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )
    assert result.returncode == 0, (result.stdout + result.stderr)[-6000:]
