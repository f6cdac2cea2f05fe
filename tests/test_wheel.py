"""A non-editable install works: the wheel carries the MJCF assets and only the maopg package.

The wheel is built from a temporary copy of the working tree (so no build/ or *.egg-info is left
in the checkout, and files not yet committed are included), inspected, then installed into a
``--target`` folder and imported from outside the repository, where it must build both scenes
and render. An editable install is checked too: it must keep reading the top-level ``assets/``.
Each says how to install an optional extra the way that works there (:mod:`maopg.extras`).
"""

from __future__ import annotations

import configparser
import json
import os
import shutil
import subprocess
import sys
import tarfile
import textwrap
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: Top-level folders a build never needs (environments, history, outputs).
SKIP_TOP = {".venv", ".git", "runs", "results", "out", "build", "dist"}
SKIP_ANY = {"__pycache__", ".pytest_cache", ".ruff_cache"}
ASSET_FILES = sorted(
    p.relative_to(REPO / "assets").as_posix() for p in (REPO / "assets").rglob("*") if p.is_file()
)


def _ignore(folder: str, names: list[str]) -> set[str]:
    top = Path(folder).resolve() == REPO
    return {n for n in names if n in SKIP_ANY or n.endswith(".egg-info") or (top and n in SKIP_TOP)}


def _run(cmd: list[str], cwd: Path, env: dict[str, str] | None = None) -> str:
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def _clean_env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return {**env, **extra}


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A scratch folder holding ``src/``, a copy of the working tree to build from."""
    root = tmp_path_factory.mktemp("wheel")
    shutil.copytree(REPO, root / "src", ignore=_ignore, symlinks=True)
    return root


@pytest.fixture(scope="module")
def wheel(work: Path) -> Path:
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    _run(
        [*pip, "wheel", ".", "--no-deps", "--no-build-isolation", "-w", str(work / "dist")],
        work / "src",
    )
    (found,) = (work / "dist").glob("maopg-*.whl")
    return found


@pytest.fixture(scope="module")
def names(wheel: Path) -> list[str]:
    with zipfile.ZipFile(wheel) as zf:
        return zf.namelist()


def _read(wheel: Path, suffix: str) -> str:
    with zipfile.ZipFile(wheel) as zf:
        (name,) = (n for n in zf.namelist() if n.endswith(suffix))
        return zf.read(name).decode()


def test_wheel_carries_every_asset_and_only_maopg(wheel: Path, names: list[str]) -> None:
    assert len(ASSET_FILES) > 0
    for sub in ("robots", "arenas", "props"):
        assert any(n.startswith(f"maopg/assets/{sub}/") and n.endswith(".xml") for n in names), sub
    packaged = sorted(
        n.removeprefix("maopg/assets/") for n in names if n.startswith("maopg/assets/")
    )
    assert packaged == ASSET_FILES, "the wheel's maopg/assets/ differs from the top-level assets/"
    with zipfile.ZipFile(wheel) as zf:
        for rel in ASSET_FILES:
            assert zf.read(f"maopg/assets/{rel}") == (REPO / "assets" / rel).read_bytes(), rel
    assert "maopg/py.typed" in names
    tops = {n.split("/")[0] for n in names}
    assert not tops & {"train", "eval", "assets"}, tops
    assert tops == {"maopg", "maopg-0.1.0.dist-info"}, tops


def test_console_scripts_point_into_maopg(wheel: Path) -> None:
    entry = configparser.ConfigParser()
    entry.read_string(_read(wheel, ".dist-info/entry_points.txt"))
    scripts = dict(entry["console_scripts"])
    assert set(scripts) >= {"maopg-train", "maopg-eval"}, scripts
    for name in ("maopg-train", "maopg-eval"):
        assert scripts[name].startswith("maopg."), scripts[name]


def test_console_script_modules_are_in_the_wheel(names: list[str]) -> None:
    modules = ("maopg/experiment/cli/train_cli.py", "maopg/experiment/cli/eval_cli.py")
    if not (REPO / modules[0]).exists():
        pytest.skip(f"{modules[0]} is not written yet: the console scripts have no target")
    for module in modules:
        assert module in names, module


def test_sdist_carries_the_build_inputs(work: Path) -> None:
    out = work / "sdist"
    code = f"from setuptools import build_meta; print(build_meta.build_sdist({str(out)!r}))"
    name = _run([sys.executable, "-c", code], work / "src").strip().splitlines()[-1]
    with tarfile.open(out / name) as tf:
        members = {m.name.split("/", 1)[1] for m in tf.getmembers() if "/" in m.name}
    assert {"setup.py", "pyproject.toml", "MANIFEST.in", "maopg/py.typed"} <= members
    assert {f"assets/{rel}" for rel in ASSET_FILES} <= members


INSTALLED_CHECK = textwrap.dedent(
    """
    import json, sys
    from pathlib import Path

    import numpy as np

    import maopg
    from maopg.env import make_env
    from maopg.extras import install_hint
    from maopg.sim.robots import ASSETS_DIR

    site = Path(sys.argv[1]).resolve()
    report = {"maopg": maopg.__file__, "assets": str(ASSETS_DIR), "images": {}}
    report["hint"] = install_hint("wandb")
    assert Path(maopg.__file__).resolve().is_relative_to(site), report
    assert ASSETS_DIR.resolve() == site / "maopg" / "assets", report
    for task in ("tool_delivery", "water_filling"):
        env = make_env(task, "continue", images=True, image_size=32)
        try:
            images = np.asarray(env.reset(seed=0).images)
        finally:
            env.close()
        assert images.size > 0 and np.ptp(images) > 0, (task, images.shape)
        report["images"][task] = list(images.shape)
    print(json.dumps(report))
    """
)


def test_installed_wheel_builds_both_scenes_and_renders(work: Path, wheel: Path) -> None:
    site = work / "site"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    _run([*pip, "install", "--no-deps", "--target", str(site), str(wheel)], work)
    assert (site / "maopg" / "assets" / "robots" / "fetch.xml").is_file()
    assert not (site / "train").exists() and not (site / "eval").exists()
    elsewhere = work / "elsewhere"
    elsewhere.mkdir()
    env = _clean_env(PYTHONPATH=str(site))
    out = _run([sys.executable, "-c", INSTALLED_CHECK, str(site)], elsewhere, env)
    report = json.loads(out.strip().splitlines()[-1])
    assert set(report["images"]) == {"tool_delivery", "water_filling"}
    assert report["hint"] == "pip install 'maopg[wandb]'"  # an extra of the installed package


EDITABLE_CHECK = textwrap.dedent(
    """
    import json, site, sys

    site.addsitedir(sys.argv[1])  # runs the editable wheel's .pth, which installs its finder
    import maopg
    from maopg.extras import install_hint
    from maopg.sim.assets import ASSETS_DIR

    hint = install_hint("wandb")
    print(json.dumps({"maopg": maopg.__file__, "assets": str(ASSETS_DIR), "hint": hint}))
    """
)


def test_editable_install_reads_top_level_assets(work: Path) -> None:
    out_dir = work / "editable"
    code = f"from setuptools import build_meta; print(build_meta.build_editable({str(out_dir)!r}))"
    name = _run([sys.executable, "-c", code], work / "src").strip().splitlines()[-1]
    with zipfile.ZipFile(out_dir / name) as zf:
        assert not [n for n in zf.namelist() if "assets/" in n], "editable wheels copy no assets"
    site = work / "editable-site"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    _run([*pip, "install", "--no-deps", "--target", str(site), str(out_dir / name)], work)
    # -S: leave out .venv's site-packages, whose own editable finder points at the checkout.
    cmd = [sys.executable, "-S", "-c", EDITABLE_CHECK, str(site)]
    report = json.loads(_run(cmd, work, _clean_env()).strip().splitlines()[-1])
    src = (work / "src").resolve()
    assert Path(report["maopg"]).resolve() == src / "maopg" / "__init__.py", report
    assert Path(report["assets"]).resolve() == src / "assets", report
    # the clone's own extra, installed from its root (pip's index has no maopg of this clone)
    assert report["hint"] == f"pip install -e '.[wandb]' (in {src}, the clone maopg runs from)"
