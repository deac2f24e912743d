"""BLAS thread pools held to one thread while reprocess's own workers fill the cores.

``slt reprocess`` overlaps frames on its own thread pool (one onnxruntime thread per session).
Left alone, OpenBLAS (numpy's ``lstsq`` in the lane fit) starts one thread per core on top of
that, and its threads spin after each call: measured on 2 cores, 12 ms of CPU per frame burnt
waiting (benchmarks/results/reprocess.json, ``pass_other``), about a sixth of the whole run. One
thread gives the same results without the spinning.

OpenCV's own pool is left alone on purpose: ``cv2.setNumThreads`` blocks forever in a process
forked from one whose OpenCV pool had started (a forking harness or job runner), which the fuzz
suite found as hangs.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def single_native_threads() -> Iterator[None]:
    """Limit BLAS to one thread inside the block; restore it afterwards."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield
