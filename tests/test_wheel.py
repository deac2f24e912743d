"""The wheel is complete: built, installed into a fresh environment, it runs ``slt reprocess``.

The wheel is built offline (``pip wheel --no-deps --no-build-isolation --no-index``) from a copy
of the sources, so the checkout gets no ``build/`` or ``*.egg-info``. It is installed with
``--no-deps`` into a new virtual environment that sees this environment's site-packages as a
plain path entry (so the dependencies resolve, but no editable install or source tree does);
``slt`` then runs from that environment in a folder outside the checkout.
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "superlane_tools"
pytestmark = pytest.mark.slow


def _package_files() -> set[str]:
    """Every file of the package in the source tree, as wheel member names."""
    return {
        p.relative_to(REPO).as_posix()
        for p in PACKAGE.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"
    }


def _run(cmd: list[str | Path], cwd: Path, env: dict[str, str]) -> str:
    res = subprocess.run(
        [str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, check=False
    )
    assert res.returncode == 0, f"{cmd}: exit {res.returncode}\n{res.stdout}\n{res.stderr}"
    return res.stdout + res.stderr


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, src / name)
    shutil.copytree(
        PACKAGE, src / PACKAGE.name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc")
    )
    dist = tmp / "dist"
    cmd = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation"]
    _run([*cmd, "--no-index", "-q", "-w", dist, src], tmp, dict(os.environ))
    (built,) = dist.glob("superlane_tools-*.whl")
    return built


def test_wheel_ships_every_package_file(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = sorted(_package_files() - names)
    assert not missing, f"not in the wheel: {missing}"
    data = {n for n in names if n.endswith((".onnx", ".dbc", ".yaml", ".json"))}
    assert any(n.startswith("superlane_tools/models/") and n.endswith(".onnx") for n in data)
    assert any(n.endswith(".dbc") for n in data)
    assert any("camera" in n and n.endswith(".yaml") for n in data)
    assert "superlane_tools/py.typed" in names
    entry = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    assert "slt = superlane_tools.cli.app:main" in zipfile.ZipFile(wheel).read(entry).decode()


def test_installed_wheel_reprocesses_a_simulated_drive(wheel: Path, tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv], tmp_path, dict(os.environ))
    purelib = Path(sysconfig.get_path("purelib", vars={"base": str(venv), "platbase": str(venv)}))
    # This environment's dependencies, as plain path entries: their .pth files (an editable
    # install of the checkout among them) are not processed.
    deps = [*site.getsitepackages(), site.getusersitepackages()]
    (purelib / "_slt_test_deps.pth").write_text("\n".join(deps) + "\n")
    env = {k: v for k, v in os.environ.items() if k not in {"PYTHONPATH", "PYTHONHOME"}}
    env["SLT_CACHE_DIR"] = str(tmp_path / "cache")
    pip = [sys.executable, "-m", "pip", "--python", venv / "bin" / "python"]  # pip >= 22.3
    _run([*pip, "install", "-q", "--no-deps", "--no-index", wheel], tmp_path, env)
    python, slt = venv / "bin" / "python", venv / "bin" / "slt"
    where = _run(
        [python, "-c", "import superlane_tools as s; print(s.__file__)"], tmp_path, env
    ).strip()
    assert Path(where).is_relative_to(venv), where
    assert not Path(where).is_relative_to(REPO)
    work = tmp_path / "work"
    work.mkdir()
    _run(
        [
            slt,
            "simulate",
            "-s",
            "highway_curves",
            "--duration",
            "2",
            "--width",
            "320",
            "--height",
            "180",
            "-o",
            "drive.mcap",
        ],
        work,
        env,
    )
    _run([slt, "reprocess", "drive.mcap", "-o", "run"], work, env)
    assert (work / "run" / "report.html").stat().st_size > 1000
    assert (work / "run" / "lanes.parquet").is_file()
    for name in ("sim_default", "tusimple", "kitti"):
        assert name in _run([slt, "camera", "list"], work, env)
