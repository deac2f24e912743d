"""The README's Quick start: the two commands a newcomer runs, and that .ci/run runs verbatim."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _quickstart() -> list[str]:
    text = (REPO / "README.md").read_text()
    section = text.split("## Quick start", 1)[1]
    block = re.search(r"```bash\n(.*?)```", section, re.S)
    assert block, "README.md: no ```bash block under ## Quick start"
    return [line for line in block.group(1).splitlines() if line.strip()]


def test_quickstart_is_two_commands_core_then_dev() -> None:
    core, dev = _quickstart()
    assert "-r requirements/core.txt -e ." in core
    assert "[" not in core, "command 1 installs core dependencies only, no extras"
    assert "torch" not in core
    assert core.endswith("&& slt reprocess fixtures/sample_drive.mcap")
    assert dev.index("pip install -q torch==2.13.0") < dev.index("requirements/dev.txt")
    assert '-e ".[dev,train,ray]"' in dev
    assert dev.endswith("&& ruff check . && mypy && python -m pytest -q")


def test_ci_runs_the_readme_commands_verbatim() -> None:
    """.ci/run holds both commands verbatim and checks them against README.md (same awk)."""
    script = (REPO / ".ci" / "run").read_text()
    program = re.search(r"mapfile -t commands < <\(awk '(.*?)' README\.md\)", script, re.S)
    assert program, ".ci/run no longer extracts the commands from README.md"
    out = subprocess.run(
        ["awk", program.group(1), "README.md"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout
    assert out.splitlines() == _quickstart()
    core, dev = _quickstart()
    assert f"readme_command_1='{core}'" in script
    assert f"readme_command_2='{dev}'" in script
    assert 'bash -c "$readme_command_1"' in script
    assert 'bash -c "$readme_command_2"' in script
    assert "runs/sample_drive/report.html" in script
