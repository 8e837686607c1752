"""One process pool for the long jobs (rendering a dataset, evaluating the benchmark's pairs).

:func:`imap_spawn` runs ``fn`` on every task in ``workers`` spawned processes and yields the
results as they finish. Whatever ends the loop (the last result, an error in a worker, the
caller stopping early, Ctrl-C, or ``SIGTERM`` sent to this process, e.g. by ``kill``) ends the
workers too: ``multiprocessing.Pool.terminate``. Without that, a benchmark stopped by ``kill``
left its workers running their pairs to the end.
"""
from __future__ import annotations

import signal
import threading


class _Terminated(SystemExit):
    pass


def _raise_terminated(signum, frame):
    raise _Terminated(128 + signum)


def imap_spawn(fn, tasks, workers: int, *, initializer=None, initargs=()):
    """Yield ``fn(task)`` for every task, in the order they finish, computed by ``workers``
    spawned processes (``fn`` and the tasks must pickle). A worker's exception is raised here."""
    import multiprocessing as mp

    tasks = list(tasks)
    if not tasks:
        return
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _raise_terminated) if main else None
    pool = mp.get_context("spawn").Pool(processes=min(workers, len(tasks)), initializer=initializer,
                                        initargs=initargs)
    try:
        yield from pool.imap_unordered(fn, tasks)
        pool.close()
        pool.join()
    finally:
        pool.terminate()
        pool.join()
        if main:
            signal.signal(signal.SIGTERM, previous)
