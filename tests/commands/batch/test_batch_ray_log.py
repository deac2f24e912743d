"""Ray's driver-side messages go to the batch's log file, not stdout, and only inside the block."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from superlane_tools.commands.batch._ray_log import ray_log

ray_worker = pytest.importorskip("ray._private.worker")

NODE_DEATH = {
    "lines": ["The node with node id: abc has been marked dead", "    [state-dump] x"],
    "pid": "raylet",
    "is_err": False,
}


def test_ray_messages_go_to_the_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "batch_ray.log"
    path.write_text("earlier batch\n")
    with ray_log(path) as log:
        # what Ray's error-listener thread calls, looked up in its module at call time
        ray_worker.print_to_stdstream(NODE_DEATH, ignore_prefix=False)
        logging.getLogger("ray").warning("a ray warning")
        logging.getLogger("ray.util").warning("a child logger's warning")
    captured = capsys.readouterr()
    assert captured.out == captured.err == ""
    text = path.read_text()
    assert text.startswith("earlier batch\n== slt batch ")  # appended, one header per batch
    assert "(raylet) The node with node id: abc has been marked dead\n" in text
    assert "(raylet)     [state-dump] x\n" in text
    assert "WARNING a ray warning\n" in text
    assert "WARNING a child logger's warning\n" in text
    assert log.lines == 2
    # restored afterwards: Ray prints again
    ray_worker.print_to_stdstream(NODE_DEATH, ignore_prefix=True)
    assert "marked dead" in capsys.readouterr().out
    logging.getLogger("ray").warning("after the batch")
    assert "after the batch" not in path.read_text()
