"""Log records of spawned worker processes, handled by the run's own handlers.

A process started with ``spawn`` begins with no logging configuration: Python's last-resort handler prints its
warnings to stderr and drops everything below, so the lines a worker logs at INFO (each scene's renderer, with why
``renderer=auto`` picked it) reached neither the console nor ``<out_dir>/<tool>.log`` of a run with ``workers=2``,
while a run with ``workers=1`` had them. Here the workers put their records on a queue and the run's process hands
each to its logger of the same name, so its handlers (Hydra's console, the run's log file) and levels apply as to
its own records (the standard library's `logging.handlers.QueueHandler` and `QueueListener`)::

    with forwarded(ctx) as queue:                      # the run's process, around the pool's life
        pool = ctx.Pool(n, initializer=start, initargs=(queue, ...))
    def start(queue, ...):                             # each worker, first thing
        log_to(queue)
"""
from __future__ import annotations

import contextlib
import logging
from logging.handlers import QueueHandler, QueueListener
from typing import Iterator


class _ToOwnLogger(logging.Handler):
    """The run's side: a worker's record to the run's logger of its name, when that logger takes its level."""

    def handle(self, record: logging.LogRecord) -> bool:
        logger = logging.getLogger(record.name)
        if logger.isEnabledFor(record.levelno):
            logger.handle(record)
        return True

    def emit(self, record: logging.LogRecord) -> None:  # handle() does it all
        pass


@contextlib.contextmanager
def forwarded(ctx) -> Iterator[tuple]:
    """Within: the workers of multiprocessing context ``ctx`` that call ``log_to(*args)`` with the yielded args log
    through this process's loggers. Left normally (the workers joined), the records they sent are handled, then the
    listener stops; left by an error or an early stop, nothing is waited for: a worker terminated while it sent a
    record may hold the queue's lock, and the listener's thread (a daemon) is left to the process's end."""
    queue = ctx.Queue()
    listener = QueueListener(queue, _ToOwnLogger())
    listener.start()
    try:
        yield queue, logging.getLogger().getEffectiveLevel()
    except BaseException:
        queue.cancel_join_thread()
        raise
    listener.stop()
    queue.close()
    queue.join_thread()


def log_to(queue, level: int) -> None:
    """In a worker: every record at ``level`` or above (the run's root level) to ``queue`` (`forwarded`), instead of
    the last-resort handler."""
    root = logging.getLogger()
    for handler in list(root.handlers):
        root.removeHandler(handler)
    root.addHandler(QueueHandler(queue))
    root.setLevel(level)


__all__ = ["forwarded", "log_to"]
