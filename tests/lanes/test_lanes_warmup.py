"""The first fit in a process reports per-frame time, not numba's kernel loading."""

from __future__ import annotations

import subprocess
import sys


def _python(code: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a fresh interpreter (kernel state is per process)."""
    return subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
        env=env,
    )


CODE = """
import numpy as np
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.lanes import fit_frame
cam = CameraModel(Intrinsics(1280, 720, 1000.0, 1000.0, 639.5, 359.5), Extrinsics(1.5, 0.06))
x = np.linspace(6.0, 50.0, 300)
uv = np.concatenate([
    cam.project(np.stack([x, np.full_like(x, o), np.zeros_like(x)], axis=1))[0]
    for o in (-1.8, 1.8, 5.4)
])
fit = fit_frame(uv, None, cam)
print(len(fit.lanes), fit.fit_time_s)
"""


def test_first_fit_time_excludes_kernel_loading():
    out = _python(CODE).stdout.split()
    n_lanes, fit_time_s = int(out[0]), float(out[1])
    assert n_lanes == 3
    assert fit_time_s < 0.2  # kernel loading alone takes 0.4 s or more


READY = """
import threading
from superlane_tools.lanes.kernel_cache import kernels_ready, warm_up
before = kernels_ready("numba")
side = threading.Thread(target=warm_up, args=("numba",))
side.start()
side.join()
print(before, kernels_ready("numba"), kernels_ready("numpy"))
"""


def test_kernels_ready_after_a_warm_up_on_another_thread():
    assert _python(READY).stdout.split() == ["False", "True", "True"]


BACKGROUND = """
import subprocess, sys, time
from superlane_tools.lanes._kernels import _CompileNote
from superlane_tools.lanes.kernel_cache import (
    cache_is_cold, kernels_loading, kernels_ready, start_compiling, warm_up_in_background,
)
cold = cache_is_cold()
warm_up_in_background("numba")
loading = kernels_loading("numba")
warm_up_in_background("numba")  # a second call while loading starts nothing more
while kernels_loading("numba"):
    time.sleep(0.05)
print(cold, loading, kernels_ready("numba"), cache_is_cold(), _CompileNote.printed)
idle = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
warm_up_in_background("numpy", idle)  # the numpy reference needs no kernels: stopped
print(idle.wait(timeout=10) != 0, kernels_loading("numpy"), start_compiling() is None)
"""


def test_background_warm_up_compiles_in_a_child_and_loads_here(tmp_path):
    """On a cold cache the kernels compile in a child; this process only loads them."""
    import os

    done = _python(BACKGROUND, {**os.environ, "SLT_CACHE_DIR": str(tmp_path)})
    lines = [line.split() for line in done.stdout.splitlines()]
    # cold, loading at once, then loaded from the cache the child wrote, compiled once (there)
    assert lines[0] == ["True", "True", "True", "False", "False"]
    assert lines[1] == ["True", "False", "True"]  # a warm cache starts no compiler
    assert done.stderr.count("note: compiling lane-fit kernels (first run only)") == 1
    assert list((tmp_path / "numba").rglob("*.nbi"))
