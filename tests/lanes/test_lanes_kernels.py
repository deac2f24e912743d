"""The numba kernels agree with the pure-numpy reference: cost, Nelder-Mead, whole fits."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

from superlane_tools.lanes import CostFunction, FitParams, FitParamsError, Histogram, fit_frame
from superlane_tools.lanes.multilane_fit import _nelder_mead

REPO = Path(__file__).resolve().parents[2]


def _cost(seed: int, n_lane: int = 600, n_road: int = 0, jacobian: bool = False) -> CostFunction:
    rng = np.random.default_rng(seed)
    # Rays from beyond the flat horizon (iq < 0) to 1 m ahead; lines spread over +-8 m.
    iq = rng.uniform(-0.01, 0.5, n_lane)
    r = rng.normal(0.0, 0.3, n_lane) + rng.choice([-0.05, 0.0, 0.05], n_lane)
    road_iq = rng.uniform(0.005, 0.3, n_road)
    road_r = rng.normal(0.0, 0.1, n_road)
    return CostFunction(
        iq,
        r,
        1.5,
        200.0,
        Histogram.symmetric(15.0, 0.1),
        2.0,
        road_iq if n_road else None,
        road_r if n_road else None,
        lambda_road=0.001,
        jacobian=jacobian,
    )


def _thetas(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.stack(
        [
            rng.uniform(-0.2, 0.2, n),
            rng.uniform(-0.01, 0.01, n),
            rng.uniform(-0.04, 0.04, n),
            rng.uniform(-5.0, 5.0, n),
        ],
        axis=1,
    )


@pytest.mark.parametrize("jacobian", [False, True])
@pytest.mark.parametrize("n_road", [0, 300])
def test_kernel_cost_matches_numpy_reference(n_road: int, jacobian: bool) -> None:
    cost = _cost(1, n_road=n_road, jacobian=jacobian)
    thetas = _thetas(2, 64)
    reference = np.array([cost.reference(t) for t in thetas])
    single = np.array([cost(t) for t in thetas])
    np.testing.assert_allclose(single, reference, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cost.batch(thetas), reference, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cost.reference_batch(thetas), reference, rtol=0, atol=1e-9)
    assert cost.evaluations == 4 * 64
    # Rays beyond the horizon fall out of range for most slopes: the penalty term varies.
    assert np.ptp(reference) > 0.1


def test_kernel_cost_with_no_point_in_range() -> None:
    cost = CostFunction(
        np.full(10, -0.5), np.zeros(10), 1.5, 200.0, Histogram.symmetric(1.0, 0.5), 2.0
    )
    theta = np.zeros(4)
    assert cost(theta) == pytest.approx(cost.reference(theta), abs=1e-12)
    assert cost(theta) == pytest.approx(np.log(5) + 2.0 * 10)


@pytest.mark.parametrize("jacobian", [False, True])
def test_kernel_nelder_mead_follows_scipy(jacobian: bool) -> None:
    params = FitParams()
    free = [0, 1, 2]
    start = np.array([0.02, 0.0005, 0.01, 0.0])
    compiled = _cost(5, jacobian=jacobian)
    reference = _cost(5, jacobian=jacobian)
    reference.backend = "numpy"
    theta_c, nit_c, ok_c = _nelder_mead(compiled, start, free, params)
    theta_r, nit_r, ok_r = _nelder_mead(reference, start, free, params)
    np.testing.assert_allclose(theta_c, theta_r, rtol=0, atol=1e-9)
    assert (nit_c, ok_c) == (nit_r, ok_r)
    assert compiled.evaluations == reference.evaluations > 10


def test_kernel_nelder_mead_on_a_quadratic_bowl_with_bounds() -> None:
    """The kernel's optimiser, on its own: converges, and respects the bounds."""
    cost = _cost(6)
    params = replace(FitParams(), xatol=1e-4, fatol=1e-7)
    theta, nit, ok = _nelder_mead(cost, np.array([0.5, 0.0, 0.03, 0.0]), [0, 1, 2], params)
    assert ok
    assert nit > 5
    assert abs(theta[0]) <= 2 * params.heading_bound_rad + 1e-12
    assert abs(theta[2]) <= params.slope_bound + 1e-12
    scipy = minimize(
        lambda v: cost.reference(np.array([v[0], v[1], v[2], 0.0])),
        theta[:3],
        method="Nelder-Mead",
        options={"xatol": 1e-6, "fatol": 1e-9},
    )
    assert cost(theta) <= scipy.fun + 0.05  # a local optimum: scipy cannot improve it much


def test_solve_ridged_matches_numpy() -> None:
    from superlane_tools.lanes._refit_kernels import solve_ridged

    rng = np.random.default_rng(7)
    a = rng.normal(size=(40, 6))
    normal = a.T @ a
    rhs = rng.normal(size=6)
    ridged = normal + np.eye(6) * 1e-9 * (np.trace(normal) / 6 + 1.0)
    np.testing.assert_allclose(solve_ridged(normal, rhs), np.linalg.solve(ridged, rhs), rtol=1e-9)


@pytest.mark.parametrize(
    ("offsets", "a1", "a2", "slope", "dashed", "road"),
    [
        ((-5.4, -1.8, 1.8, 5.4), 0.02, 1.0 / 600, 0.015, False, False),
        ((-1.7, 1.9), -0.03, -1.0 / 400, -0.02, True, False),
        ((-5.2, -1.6, 2.0), 0.0, 0.0, 0.0, True, True),
    ],
)
def test_fit_frame_backends_agree(renderer, camera_factory, offsets, a1, a2, slope, dashed, road):
    camera = camera_factory()
    lane_uv, road_uv = renderer(camera, offsets, a1, a2, slope, dashed=dashed)
    params = FitParams(road_term="always" if road else "auto")
    compiled = fit_frame(lane_uv, road_uv, camera, params)
    reference = fit_frame(lane_uv, road_uv, camera, replace(params, backend="numpy"))
    assert compiled.reason == reference.reason == ""
    for name in ("a1", "a2", "b", "cost", "quality"):
        assert getattr(compiled, name) == pytest.approx(getattr(reference, name), abs=1e-8)
    assert compiled.iterations == reference.iterations
    assert len(compiled.lanes) == len(reference.lanes) == len(offsets)
    for lc, lr in zip(compiled.lanes, reference.lanes, strict=True):
        for name in ("offset_m", "a1", "a2", "range_min_m", "range_max_m"):
            assert getattr(lc, name) == pytest.approx(getattr(lr, name), abs=1e-8)
        assert (lc.style, lc.colour, lc.n_points) == (lr.style, lr.colour, lr.n_points)
    # Warm start from the solution: fewer evaluations, same answer.
    warm = fit_frame(lane_uv, road_uv, camera, params, init=compiled)
    assert warm.evaluations < compiled.evaluations
    assert warm.a1 == pytest.approx(compiled.a1, abs=2e-3)
    assert warm.curvature == pytest.approx(compiled.curvature, abs=2e-4)


NOBODY = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"]
"""Run a command as the unprivileged user ``nobody``."""
KERNEL_SCRIPT = (
    "import numpy as np\n"
    "from superlane_tools.lanes import _kernels as k\n"
    "hist = np.zeros(8)\n"
    "cfg = np.array([1 / 1.5, 1 / 200, 10.0, 3.0, 5.0, 2.0, 0.0, 1 / 3])\n"
    "print(k.lane_cost(np.array([0.1, 0.2]), np.zeros(2), 0.0, 0.0, 0.0, 0.0, cfg, hist))\n"
)


@pytest.mark.skipif(
    not (hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("setpriv")),
    reason="needs root and setpriv to run as an unprivileged user",
)
def test_kernels_work_from_a_read_only_install() -> None:
    """With no writable cache location numba compiles in memory instead of failing."""
    # Not tmp_path: pytest's base folder is private to root, the unprivileged user must read.
    root = Path(tempfile.mkdtemp(prefix="slt-ro-"))
    try:
        _check_read_only_install(root)
    finally:
        shutil.rmtree(root)


def _as_nobody(
    python: str, script: str, path: list[Path], timeout: int = 120
) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "HOME": "/nonexistent", "PYTHONPATH": os.pathsep.join(map(str, path))}
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("XDG_CACHE_HOME", None)
    return subprocess.run(
        [*NOBODY, python, "-c", script],
        env=env,
        cwd="/",
        capture_output=True,
        text=True,
        check=False,
        timeout=timeout,
    )


def _link_or_copy(src: str, dst: str) -> None:
    """Hard-link a world-readable file (fast, same content); copy one that is not."""
    if Path(src).stat().st_mode & 0o004:
        try:
            os.link(src, dst)
            return
        except OSError:
            pass
    shutil.copy2(src, dst)
    Path(dst).chmod(0o644)


def _packages_nobody_can_read(install: Path, site: Path) -> tuple[str, list[Path]]:
    """Return a Python and import path with which ``nobody`` can run the kernel script.

    The venv's own Python when ``nobody`` can read it; else (a clone and its ``.venv`` under a
    private home, e.g. root's mode-700 ``/root``) the base interpreter with copies of the
    packages the script imports in ``site``, a world-readable folder. Skips, saying why, when
    not even the base interpreter runs for ``nobody``.
    """
    probe = "import numpy, numba, yaml"
    if _as_nobody(sys.executable, probe, [install]).returncode == 0:
        return sys.executable, [install]
    base = os.path.realpath(sys.executable)
    if _as_nobody(base, "import sys", []).returncode != 0:
        pytest.skip(
            f"the unprivileged user cannot read {sys.executable} nor run {base}: the Python "
            "lies in a private folder (e.g. mode-700 /root); install it world-readable to run "
            "this test"
        )
    listing = (
        "import sys, sysconfig\n"
        f"exec({KERNEL_SCRIPT!r}.rsplit('print', 1)[0])\n"
        "purelib = sysconfig.get_paths()['purelib']\n"
        "for name, mod in list(sys.modules.items()):\n"
        "    f = getattr(mod, '__file__', None) or ''\n"
        "    if '.' not in name and f.startswith(purelib):\n"
        "        print(f[len(purelib) + 1 :].split('/')[0])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", listing],
        env={**os.environ, "PYTHONPATH": str(install)},
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    purelib = Path(sysconfig.get_paths()["purelib"])
    tops = {name for name in done.stdout.split() if name != "superlane_tools"}
    tops |= {p.name for p in purelib.glob("*.libs") if p.name.split(".")[0] in tops}
    site.mkdir()
    for name in sorted(tops):
        src = purelib / name
        if src.is_dir():
            shutil.copytree(src, site / name, copy_function=_link_or_copy)
        elif src.is_file():
            _link_or_copy(str(src), str(site / name))
    return base, [install, site]


def _check_read_only_install(root: Path) -> None:
    install = root / "ro"
    shutil.copytree(
        REPO / "superlane_tools",
        install / "superlane_tools",
        ignore=shutil.ignore_patterns("*.nb*"),
    )
    for path in [root, *install.rglob("*")]:
        path.chmod(0o755 if path.is_dir() else 0o644)
    python, import_path = _packages_nobody_can_read(install, root / "site")
    for path in (root / "site").rglob("*"):
        if path.is_dir():
            path.chmod(0o755)  # new folders; files are world-readable links or copies
    done = _as_nobody(python, KERNEL_SCRIPT, import_path)
    assert done.returncode == 0, done.stderr
    assert float(done.stdout.split()[-1]) == pytest.approx(2.0)  # both points in one bin
    assert not list(install.rglob("*.nbi"))


def test_unknown_backend_is_rejected() -> None:
    with pytest.raises(FitParamsError, match="backend"):
        FitParams(backend="cuda")  # type: ignore[arg-type]
