"""
Producing the items of an iterator in a thread, a bounded number ahead of the consumer.

:func:`read_ahead` lets the records of a bag's chunks be read from the file (a ``read`` releases
the interpreter lock while the kernel copies) while the caller decodes and computes on the ones
before: the same items in the same order, no copy of them, at most ``depth`` waiting (memory
stays flat).  An error of the producer is raised in the consumer where the item would have come.
The thread does no numpy work: measured on the replay, decoding in the thread as well cost CPU
(the two threads contend for the interpreter lock) without a wall-time gain on a busy machine.
"""

from __future__ import annotations

from queue import Empty, Full, Queue
import threading
from typing import Generator, Iterator, TypeVar

T = TypeVar('T')


def read_ahead(items: Iterator[T], depth: int, *,
               name: str = 'read ahead') -> Generator[T, None, None]:
    """
    Yield the items of ``items``, produced by a thread up to ``depth`` (>= 1) ahead.

    Closing the returned generator (or leaving its loop) stops the thread after the item it is
    producing, then closes ``items`` in the caller's thread.

    :raises BaseException: whatever ``items`` raised, when the consumer reaches it.

    """
    queue: Queue = Queue(maxsize=max(1, int(depth)))
    stop = threading.Event()

    def offer(entry: tuple[bool, object]) -> bool:
        while not stop.is_set():
            try:
                queue.put(entry, timeout=0.1)
                return True
            except Full:
                continue
        return False

    def produce() -> None:
        try:
            for item in items:
                if not offer((True, item)):
                    return
            offer((False, None))
        except BaseException as error:  # noqa: B036 - handed to the consumer, raised there
            offer((False, error))

    thread = threading.Thread(target=produce, name=name, daemon=True)
    thread.start()
    try:
        while True:
            ok, item = queue.get()
            if ok:
                yield item
                continue
            if item is not None:
                raise item
            return
    finally:
        stop.set()
        while thread.is_alive():  # a producer waiting for room sees the stop within 0.1 s
            try:
                queue.get_nowait()
            except Empty:
                thread.join(0.05)
        close = getattr(items, 'close', None)
        if close is not None:
            close()
