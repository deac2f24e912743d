"""The lane-fit kernel cache: user cache folder, one note when compiling, read-only installs."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from superlane_tools.lanes import _kernels
from superlane_tools.lanes._kernels import COMPILE_NOTE, kernel_cache_dir

PACKAGE = Path(_kernels.__file__).resolve().parents[1]
WARM = "from superlane_tools.lanes.kernel_cache import warm_up; warm_up()"


def test_cache_dir_follows_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("SLT_CACHE_DIR", str(tmp_path / "slt"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert kernel_cache_dir() == tmp_path / "slt" / "numba"
    monkeypatch.delenv("SLT_CACHE_DIR")
    assert kernel_cache_dir() == tmp_path / "xdg" / "superlane-tools" / "numba"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    if sys.platform.startswith("linux"):
        assert kernel_cache_dir() == tmp_path / "home" / ".cache" / "superlane-tools" / "numba"


def _files(root: Path) -> set[Path]:
    return {p.relative_to(root) for p in root.rglob("*")}


def _warm(site: Path, cache: Path) -> subprocess.CompletedProcess[str]:
    env = {
        **os.environ,
        "PYTHONPATH": str(site),
        "PYTHONDONTWRITEBYTECODE": "1",
        "SLT_CACHE_DIR": str(cache),
    }
    return subprocess.run(  # cwd: not the source tree, which would shadow the copy
        [sys.executable, "-c", WARM], env=env, cwd=site, capture_output=True, text=True, check=False
    )


def test_second_process_loads_kernels_from_a_read_only_install(tmp_path: Path) -> None:
    """A copy of the package with no write permission: compile once, then load from the cache."""
    site = tmp_path / "site"
    shutil.copytree(PACKAGE, site / "superlane_tools", ignore=shutil.ignore_patterns("__pycache__"))
    for path in [site, *site.rglob("*")]:
        mode = path.stat().st_mode
        path.chmod(mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    before = _files(site)
    cache = tmp_path / "cache"
    try:
        first = _warm(site, cache)
        assert first.returncode == 0, first.stderr
        assert first.stderr.count(COMPILE_NOTE) == 1, first.stderr
        cached = list((cache / "numba").rglob("*.nbi"))
        assert len(cached) >= 10, cached
        second = _warm(site, cache)
        assert second.returncode == 0, second.stderr
        assert COMPILE_NOTE not in second.stderr
        assert _files(site) == before  # nothing written beside the installed sources
    finally:
        for path in [site, *site.rglob("*")]:
            path.chmod(path.stat().st_mode | stat.S_IWUSR)


def test_unwritable_cache_compiles_in_memory(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache folder should be")
    env = {**os.environ, "SLT_CACHE_DIR": str(blocker), "PYTHONDONTWRITEBYTECODE": "1"}
    code = (
        "from superlane_tools.lanes import _kernels as k; "
        "import numpy as np; print(k._CACHE_OK, k.road_den(0.1, 0.0, 0.0))"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["False", "0.1"]
    assert res.stderr.count(COMPILE_NOTE) == 1


AFTER_COMPILE_ALL = """
import numpy as np
from numba.core import event
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.lanes import FitParams, fit_frame
cam = CameraModel(Intrinsics(1280, 720, 1000.0, 1000.0, 639.5, 359.5), Extrinsics(1.5, 0.06))
x = np.linspace(6.0, 50.0, 300)
def pixels(offsets, z=0.0):
    return np.concatenate([
        cam.project(np.stack([x, np.full_like(x, o) + 2e-4 * x**2, np.full_like(x, z)], 1))[0]
        for o in offsets
    ])
lane, road = pixels((-1.8, 1.8, 5.4)), pixels(np.linspace(-3.0, 3.0, 7))
codes = np.zeros(len(lane), dtype=np.intp)
with event.install_recorder("numba:compile") as compiled:
    first = fit_frame(lane, road, cam, FitParams(road_term="always"), attributes=codes)
    again = fit_frame(lane, None, cam, FitParams(order=1, slope=False), init=first)
print(len(first.lanes), len(again.lanes), len(compiled.buffer))
"""


def test_compile_all_covers_every_kernel_the_fit_calls(tmp_path: Path) -> None:
    """What the compiler process caches is all a fit needs: the fit then compiles nothing."""
    env = {**os.environ, "SLT_CACHE_DIR": str(tmp_path)}
    compile_all = (
        "from superlane_tools.lanes.kernel_cache import compile_into_cache; compile_into_cache()"
    )
    done = subprocess.run(
        [sys.executable, "-c", compile_all], env=env, capture_output=True, text=True, check=True
    )
    assert done.stderr.count(COMPILE_NOTE) == 1
    fitted = subprocess.run(
        [sys.executable, "-c", AFTER_COMPILE_ALL],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    assert fitted.stdout.split() == ["3", "3", "0"], fitted.stdout + fitted.stderr
    assert COMPILE_NOTE not in fitted.stderr
    # The cache is marked complete for this kernel source: an identical copy of the package
    # finds it warm; an upgrade (a changed _kernels.py or _refit_kernels.py) finds it cold again.
    site = tmp_path / "site"
    shutil.copytree(PACKAGE, site / "superlane_tools", ignore=shutil.ignore_patterns("__pycache__"))
    cold = "from superlane_tools.lanes.kernel_cache import cache_is_cold; print(cache_is_cold())"

    def is_cold() -> str:
        done = subprocess.run(
            [sys.executable, "-c", cold],
            env={**env, "PYTHONPATH": str(site), "PYTHONDONTWRITEBYTECODE": "1"},
            cwd=site,  # not the source tree, which would shadow the copy
            capture_output=True,
            text=True,
            check=True,
        )
        return done.stdout.strip()

    assert is_cold() == "False"
    for name in ("_kernels.py", "_refit_kernels.py"):  # each kernel source counts
        kernels = site / "superlane_tools" / "lanes" / name
        original = kernels.read_text()
        kernels.write_text(original + "\n# a new release\n")
        assert is_cold() == "True", name
        kernels.write_text(original)
        assert is_cold() == "False", name


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="reads /proc")
def test_failed_reprocess_leaves_no_compiler_behind(tmp_path: Path) -> None:
    """A cold cache starts the compiler first thing; a run that fails stops it again."""
    not_a_recording = tmp_path / "drive.mcap"
    not_a_recording.write_text("not a recording")
    cache = tmp_path / "cache"
    env = {**os.environ, "SLT_CACHE_DIR": str(cache)}
    done = subprocess.run(
        [
            str(Path(sys.executable).with_name("slt")),
            "reprocess",
            str(not_a_recording),
            "-o",
            str(tmp_path / "run"),
        ],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 1, done.stderr  # bad input: a one-line error, not a crash
    assert "Traceback" not in done.stderr
    marker = f"SLT_CACHE_DIR={cache}".encode()
    left = []
    for proc in Path("/proc").iterdir():
        try:
            if proc.name.isdigit() and marker in (proc / "environ").read_bytes().split(b"\0"):
                left.append(proc.name)
        except OSError:
            continue
    assert left == []
    assert not any(cache.rglob("complete-*"))


def test_unnamed_marker_leaves_the_kernels_to_numba(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Without numba's version the marker cannot be named: no child, numba decides in process."""
    import importlib.metadata

    from superlane_tools.lanes import kernel_cache

    monkeypatch.setenv("SLT_CACHE_DIR", str(tmp_path))
    assert kernel_cache.cache_is_cold()

    def unknown(name: str) -> str:
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", unknown)
    assert not kernel_cache.cache_is_cold()
    assert kernel_cache.start_compiling() is None
    kernel_cache.mark_complete()  # nothing to write, and no error
    assert list(tmp_path.rglob("complete-*")) == []
