"""`slt batch` through Typer's CliRunner: exit codes, messages, manifest input."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest
import typer
from typer.testing import CliRunner

from superlane_tools.cli import batch

runner = CliRunner()


def _app() -> typer.Typer:
    app = typer.Typer()

    @app.callback()
    def _root() -> None:
        """Test root."""

    batch.register(app)
    return app


def _run(*args: object) -> object:
    return runner.invoke(_app(), ["batch", *map(str, args)], catch_exceptions=False)


def test_cli_manifest_run_and_rerun(tmp_path: Path, make_drives: Callable[..., list[Path]]) -> None:
    paths = make_drives(2, 1)
    manifest = tmp_path / "m.csv"
    pd.DataFrame({"path": [p.name for p in paths], "category": ["highway", "city", "city"]}).to_csv(
        tmp_path / "recs" / "m.csv", index=False
    )
    manifest = tmp_path / "recs" / "m.csv"
    config = tmp_path / "c.toml"
    config.write_text('frame_format = "none"\n')
    out = tmp_path / "out"
    res = _run(
        "--manifest",
        manifest,
        "--out",
        out,
        "--job",
        "extract",
        "--config",
        config,
        "--workers",
        "2",
    )
    assert res.exit_code == 3, res.output  # type: ignore[attr-defined]
    assert "ok 2, partial 0, failed 1, skipped 0" in res.output  # type: ignore[attr-defined]
    assert "slt: skipped: failed recordings (1): corrupt_0-" in res.output  # type: ignore[attr-defined]
    fleet = pd.read_parquet(out / "summary" / "fleet_status.parquet").set_index("category")
    assert fleet.loc["city", "failed"] == 1
    assert fleet.loc["highway", "ok"] == 1
    res = _run(
        tmp_path / "recs" / "drive_00.mcap", "--out", out, "--job", "extract", "--config", config
    )
    assert res.exit_code == 0, res.output  # type: ignore[attr-defined]
    assert "skipped 1" in res.output  # type: ignore[attr-defined]


def test_cli_all_failed_is_error(tmp_path: Path, make_drives: Callable[..., list[Path]]) -> None:
    make_drives(0, 1)
    res = _run(tmp_path / "recs", "--out", tmp_path / "out", "--job", "extract", "--retries", "0")
    assert res.exit_code == 1, res.output  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((), "one of the two"),
        (("--engine", "spark"), "unknown engine"),
        (("--job", "dance"), "unknown job kind"),
        (("--ray-address", "auto"), "--ray-address needs --engine ray"),
        (("--config", "missing.yaml"), "missing.yaml"),  # click: the file does not exist
    ],
)
def test_cli_usage_errors(
    tmp_path: Path, make_drives: Callable[..., list[Path]], args: tuple[str, ...], match: str
) -> None:
    make_drives(1)
    inputs = () if not args else (tmp_path / "recs",)
    res = _run(*inputs, "--out", tmp_path / "out", *args)
    assert res.exit_code == 2, res.output  # type: ignore[attr-defined]
    assert match in res.output  # type: ignore[attr-defined]
    assert "Traceback" not in res.output  # type: ignore[attr-defined]


def test_cli_ray_missing_names_the_extra(
    tmp_path: Path, make_drives: Callable[..., list[Path]], monkeypatch: pytest.MonkeyPatch
) -> None:
    make_drives(1)
    monkeypatch.setitem(sys.modules, "ray", None)  # what an install without the extra sees
    res = _run(tmp_path / "recs", "--out", tmp_path / "out", "--engine", "ray", "--job", "extract")
    assert res.exit_code == 1, res.output  # type: ignore[attr-defined]
    assert "pip install 'superlane-tools[ray]'" in res.output  # type: ignore[attr-defined]


def test_batch_help_imports_nothing_heavy() -> None:
    import subprocess

    code = (
        "import sys, typer\n"
        "from superlane_tools.cli import batch\n"
        "app = typer.Typer()\n"
        "@app.callback()\n"
        "def _r() -> None: pass\n"
        "batch.register(app)\n"
        "try:\n    app(['batch', '--help'])\n"
        "except SystemExit as e:\n    assert e.code in (0, None)\n"
        "heavy = ('onnxruntime', 'cv2', 'torch', 'matplotlib', 'ray', 'pandas')\n"
        "print('HEAVY', [m for m in heavy if m in sys.modules])\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    ).stdout
    assert "HEAVY []" in out, out
    assert "--manifest" in out


def test_cli_manifest_path_list_is_usage_error(
    tmp_path: Path, make_drives: Callable[..., list[Path]]
) -> None:
    (path,) = make_drives(1)
    manifest = tmp_path / "m.yaml"
    manifest.write_text(f"- path: {path}\n- path: [{path.name}]\n")
    out = tmp_path / "out"
    res = _run("--manifest", manifest, "--out", out, "--job", "extract")
    assert res.exit_code == 2, res.output  # type: ignore[attr-defined]
    assert "row 2: path must be one recording path (text), not a list" in res.output  # type: ignore[attr-defined]
    assert "cannot read" not in res.output  # type: ignore[attr-defined]
    assert not (out / "summary").exists()
