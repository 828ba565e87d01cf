"""Log records of spawned worker processes, handled by the run's own handlers.

A process started with ``spawn`` begins with no logging configuration: Python's last-resort handler prints its
warnings to stderr and drops everything below, so the lines a worker logs at INFO (each scene's renderer, with why
``renderer=auto`` picked it) reached neither the console nor ``<out_dir>/<tool>.log`` of a run with ``workers=2``,
while a run with ``workers=1`` had them. Here each worker filters its records by the levels the run's loggers had
when it started and puts them on a queue; the run's process hands each to its logger of the same name, whose
handlers (Hydra's console, the run's log file) write it as one of its own (the standard library's
`logging.handlers.QueueHandler` and `QueueListener`)::

    with spawned_pool(n, threads, initializer, initargs) as pool:   # a pool: rvn-eval's, rvn-gen's
        ...
    with forwarded(ctx) as logs:                       # other workers, around their life (or `Forwarder`)
        ctx.Process(target=work, args=(logs, ...))
    def work(logs, ...):                               # each worker, first thing
        log_to(*logs)
"""
from __future__ import annotations

import contextlib
import logging
import multiprocessing as mp
from logging.handlers import QueueHandler, QueueListener
from typing import Callable, Iterator

from rvn_data.worker_threads import worker_threads


class _ToOwnLogger(logging.Handler):
    """The run's side: a worker's record to the run's logger of its name. The worker filtered it by the levels the
    run's loggers had when the worker started (`levels`); checking them again here, in the listener's thread, would
    drop or keep a record by when it arrived after the run changed a level."""

    def handle(self, record: logging.LogRecord) -> bool:
        logging.getLogger(record.name).handle(record)
        return True

    def emit(self, record: logging.LogRecord) -> None:  # handle() does it all
        pass


def levels() -> dict[str, int]:
    """This process's logger levels: the root's (key "") and every logger's that has one of its own."""
    out = {"": logging.getLogger().level}
    for name, logger in logging.Logger.manager.loggerDict.items():
        if isinstance(logger, logging.Logger) and logger.level != logging.NOTSET:
            out[name] = logger.level
    return out


class Forwarder:
    """The run's end of the workers' records, for workers that live as long as an object does (`forwarded` for a
    block): ``args`` go to each worker's ``log_to(*args)``; `close` once the workers have ended."""

    def __init__(self, ctx):
        self._queue = ctx.Queue()
        self._listener = QueueListener(self._queue, _ToOwnLogger())
        self._listener.start()
        self.args = (self._queue, levels())

    def close(self, clean: bool = True) -> None:
        """``clean`` (every worker ended by itself): the records they sent are handled, then the listener stops.
        Otherwise nothing is waited for: a worker terminated while it sent a record may hold the queue's lock, and
        the listener's thread (a daemon) is left to the process's end."""
        if self._listener is None:
            return
        if clean:
            self._listener.stop()
            self._queue.close()
            self._queue.join_thread()
        else:
            self._queue.cancel_join_thread()
        self._listener = None


@contextlib.contextmanager
def forwarded(ctx) -> Iterator[tuple]:
    """Within: the workers of multiprocessing context ``ctx`` that call ``log_to(*args)`` with the yielded args log
    through this process's loggers. Left normally (the workers joined), every record they sent is handled first;
    left by an error or an early stop (workers terminated), nothing is waited for (`Forwarder.close`)."""
    forwarder = Forwarder(ctx)
    try:
        yield forwarder.args
    except BaseException:
        forwarder.close(clean=False)
        raise
    forwarder.close()


def log_to(queue, run_levels: dict[str, int]) -> None:
    """In a worker: its records to ``queue`` (`forwarded`), instead of the last-resort handler, filtered by the run's
    logger levels ``run_levels`` (`levels`)."""
    root = logging.getLogger()
    for handler in list(root.handlers):
        root.removeHandler(handler)
    root.addHandler(QueueHandler(queue))
    for name, level in run_levels.items():
        logging.getLogger(name or None).setLevel(level)


@contextlib.contextmanager
def spawned_pool(workers: int, threads: int, initializer: Callable | None = None, initargs: tuple = ()):
    """A ``spawn`` pool of ``workers`` processes (GL contexts and torch do not survive fork), each started with
    ``threads`` CPU threads (`rvn_data.worker_threads`), logging through this process's handlers, then running
    ``initializer(*initargs)``. Closed and joined when the work is done (the workers' last records sent), terminated
    on an error or an early stop."""
    ctx = mp.get_context("spawn")
    with forwarded(ctx) as logs:
        with worker_threads(threads):
            pool = ctx.Pool(workers, initializer=_start_pool_worker, initargs=(logs, initializer, initargs))
        with pool:
            yield pool
            pool.close()
            pool.join()


def _start_pool_worker(logs: tuple, initializer: Callable | None, initargs: tuple) -> None:
    log_to(*logs)
    if initializer is not None:
        initializer(*initargs)


__all__ = ["Forwarder", "forwarded", "levels", "log_to", "spawned_pool"]
