"""The drive record's compact row buffers: same numbers as lists of tuples, growing past a block."""

from __future__ import annotations

import math

import numpy as np

from superlane_tools.drive.record import FLUSH_ROWS, _Rows


def test_rows_grow_and_keep_every_value_exactly() -> None:
    rng = np.random.default_rng(3)
    rows = [(*rng.normal(size=4).tolist(), math.nan) for _ in range(3 * FLUSH_ROWS + 7)]
    buffer = _Rows(5)
    for row in rows:
        buffer.append(row)
    assert len(buffer) == len(rows)
    got = buffer.array()
    np.testing.assert_array_equal(got, np.asarray(rows, dtype=np.float64))
    got[0, 0] = 99.0  # a copy: the buffer is not changed through it
    assert buffer.array()[0, 0] == rows[0][0]
    times = _Rows(1, np.int64)
    times.append((1_700_000_000_123_456_789,))
    assert times.array()[0, 0] == 1_700_000_000_123_456_789  # int64 exact, not via float
    flags = _Rows(2, np.bool_)
    flags.append((True, False))
    assert flags.array().tolist() == [[True, False]]
    assert _Rows(3).array().shape == (0, 3)
