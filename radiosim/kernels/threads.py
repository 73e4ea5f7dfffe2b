"""
Running a compiled kernel in blocks on several threads: block 0 on the calling thread, the
others on radiosim's own pool of threads, the kernels releasing the GIL (``nogil``), instead of
numba's parallel layer (``parallel=True`` and ``prange``).

Why not ``prange``: numba compiles a parallel loop's body as a function of its own, and the
optimiser then takes every function the body calls through once more (it inlines them into
it), about doubling the integrator kernel's compile, for a loop whose body is one call per
block. Blocks are contiguous ranges of rows, each written by one block
only, so the result does not depend on the number of threads or on their order.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor, wait

__all__ = ["run_blocks", "block_range"]

_POOL: ThreadPoolExecutor | None = None
_POOL_SIZE = 0
_POOL_LOCK = threading.Lock()


def _pool(workers: int) -> ThreadPoolExecutor:
    """A pool of at least ``workers`` threads, made on first use and kept (replaced by a larger
    one when more are asked for: the old one ends its threads once its work is done). The
    caller holds ``_POOL_LOCK`` until it has submitted its blocks, so that no pool is shut down
    between the moment it is handed out and the blocks' submission."""
    global _POOL, _POOL_SIZE
    if _POOL is None or _POOL_SIZE < workers:
        old = _POOL
        _POOL = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="radiosim-kernel")
        _POOL_SIZE = workers
        if old is not None:
            old.shutdown(wait=False)  # its submitted blocks still run
    return _POOL


def block_range(block: int, n_blocks: int, n: int) -> tuple[int, int]:
    """
    The items ``lo`` … ``hi − 1`` of block ``block`` of ``n_blocks`` contiguous blocks of
    ``n`` items (sizes differing by one at most).

    Examples
    --------
    >>> [block_range(b, 3, 10) for b in range(3)]
    [(0, 3), (3, 6), (6, 10)]
    """
    return block * n // n_blocks, (block + 1) * n // n_blocks


def _wait_for_all(futures) -> None:
    """Wait until every future is done, also through an interrupt (Ctrl-C, a signal handler's
    exception) arriving meanwhile, which is raised once they are: the blocks write into arrays
    and per-thread buffers the caller owns and uses again."""
    interrupted = None
    while True:
        try:
            wait(futures)
            break
        except BaseException as exc:  # noqa: BLE001  (raised below, once the blocks are done)
            interrupted = exc
    if interrupted is not None:
        raise interrupted


def run_blocks(kernel, n_blocks: int, *args) -> list:
    """
    ``kernel(b, *args)`` for every block b < ``n_blocks``, block 0 on the calling thread and
    the others on radiosim's pool at the same time; their results in block order. The calling
    thread waits for every block before it returns or raises (an exception of a block, or an
    interrupt, is raised once all are done), so no block outlives the launch.

    Examples
    --------
    >>> run_blocks(lambda b, scale: b * scale, 3, 10)
    [0, 10, 20]
    """
    if n_blocks <= 1:
        return [kernel(0, *args)]
    with _POOL_LOCK:
        # Twice the workers one launch needs: the integrator (main thread) and a scene's
        # frames (prefetch thread) launch at the same time.
        pool = _pool(2 * (n_blocks - 1))
        futures = [pool.submit(kernel, b, *args) for b in range(1, n_blocks)]
    try:
        first = kernel(0, *args)
    finally:
        _wait_for_all(futures)
    return [first, *(future.result() for future in futures)]
