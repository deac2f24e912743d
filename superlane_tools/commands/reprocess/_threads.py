"""Native thread pools held to one thread while reprocess's own workers fill the cores.

``slt reprocess`` overlaps frames on its own thread pool (one onnxruntime thread per session).
Left alone, OpenBLAS (numpy's ``lstsq`` in the lane fit) and OpenCV start one thread per core
on top of that, and OpenBLAS threads spin after each call: measured on 2 cores, 12 ms of CPU per
frame burnt waiting (benchmarks/results/reprocess.json, ``pass_other``), about a sixth of the
whole run. One thread each gives the same results without the spinning.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def single_native_threads() -> Iterator[None]:
    """Limit BLAS and OpenCV to one thread inside the block; restore them afterwards."""
    import cv2  # late: heavy import
    from threadpoolctl import threadpool_limits

    previous = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            yield
    finally:
        cv2.setNumThreads(previous)
