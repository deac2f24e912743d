"""Fast fuzz subset: a hundred damaged inputs through the real ``slt`` CLI, each with a
timeout; every one must end clean (no traceback, no internal error, no hang, the documented
exit code, the undamaged data recovered, nothing written outside ``--out``).

The full campaign (>= 1000 cases and the SIGKILL campaign) is ``benchmarks/fuzz.py``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import fuzzcases as fc  # tests/fuzz/conftest.py puts the harness on sys.path
import fuzzcases_wave2  # noqa: F401 - registers the second-wave families
import pytest

FAST = {
    "mcap": 12,
    "images": 10,
    "timestamps": 12,
    "topics": 6,
    "canlog": 12,
    "blf_asc": 9,
    "nmea": 9,
    "dbc": 8,
    "bags": 8,
    "paths_configs": 12,
    "reprocess": 2,
    "disk_full": 6,
    "sqlite": 4,  # second wave (issue 27 item 8): few each, the campaign runs hundreds
    "text_junk": 5,
    "wrong_topic": 4,
    "manifest": 2,
    "recover": 4,
}

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="the harness forks")


@pytest.fixture(scope="module")
def warm(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Import the toolkit once (children fork warm); keep generated base files in tmp."""
    fc.preload()
    old = os.environ.get("SLT_FUZZ_CACHE")
    os.environ["SLT_FUZZ_CACHE"] = str(tmp_path_factory.mktemp("fuzz-base"))
    yield
    if old is None:
        del os.environ["SLT_FUZZ_CACHE"]
    else:
        os.environ["SLT_FUZZ_CACHE"] = old


@pytest.mark.parametrize("family", sorted(FAST))
def test_fuzz_family_is_clean(family: str, warm: None, tmp_path: Path) -> None:
    cases = fc.all_cases({family: FAST[family]}, seed=17)
    assert len(cases) == FAST[family]
    outcomes = [fc.run_case(case, tmp_path, timeout_s=60) for case in cases]
    bad = [o for o in outcomes if o.findings != ["clean"]]
    assert not bad, "\n".join(f"{o.case}: {o.findings} exit {o.code}: {o.detail}" for o in bad)


def test_the_harness_finds_what_it_should(warm: None, tmp_path: Path) -> None:
    """Wrong exit codes, missing data and files outside --out are findings, not passes."""
    good = next(c for c in fc.all_cases({"canlog": 1}) if c.family == "canlog")
    wrong = fc.Case("canlog", "wrong-exit", good.build, frozenset({2}), good.need)
    assert fc.run_case(wrong, tmp_path).findings == ["wrong_exit"]
    greedy = fc.Case("canlog", "greedy", good.build, good.expect, fc.Need(0, 10**6, 0).check)
    assert fc.run_case(greedy, tmp_path).findings == ["data_lost"]

    def stray(work: Path) -> list[str]:
        good.build(work)
        return ["extract", "d.log", "--out", "not-out"]

    assert (
        "escaped_out"
        in fc.run_case(fc.Case("canlog", "stray", stray, frozenset({0, 3})), tmp_path).findings
    )


@pytest.mark.slow
@pytest.mark.parametrize("command", ["extract", "reprocess", "batch"])
def test_sigkill_then_rerun_is_complete_and_clean(command: str, tmp_path: Path) -> None:
    trials = 3 if command != "reprocess" else 2
    outcomes = fc.kill_campaign(command, trials, tmp_path, seed=5)
    problems = [(o.kill_after_s, o.problems) for o in outcomes if o.problems]
    assert not problems
