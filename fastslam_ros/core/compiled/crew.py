# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The threads of a split reading: worker threads kept from one reading to the next
(``_Crew``), an atomic counter the threads take blocks of particles from (``_claim``), and
how many threads a reading of M particles uses (``threads_for``, ``set_threads``)."""
from __future__ import annotations

import queue
import threading
import time

import numba
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from .jit import _JIT


@intrinsic
def _claim(typingctx, counter, index, amount):
    """Atomically ``counter[index] += amount``; returns the value before (the threads of a
    reading take their particles from one counter this way, and count the particles done in
    another; ``amount`` 0 reads it)."""
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64
            and isinstance(index, types.Integer) and isinstance(amount, types.Integer)):
        return None

    def codegen(context, builder, signature, args):
        array_type = signature.args[0]
        array = context.make_array(array_type)(context, builder, args[0])
        position = context.cast(builder, args[1], signature.args[1], types.intp)
        pointer = cgutils.get_item_pointer(context, builder, array_type, array, [position])
        step = context.cast(builder, args[2], signature.args[2], types.int64)
        return builder.atomic_rmw("add", pointer, step, "seq_cst")

    return types.int64(counter, index, amount), codegen


@njit(**_JIT)
def _await_done(counter, total, spins):
    """Wait (at most ``spins`` polls, without the GIL) until ``counter[1]``, the particles
    the threads of a reading have finished, reaches ``total``; True if it did."""
    for _ in range(spins):
        if _claim(counter, 1, 0) >= total:
            return True
    return _claim(counter, 1, 0) >= total


_crew: _Crew | None = None


def _shared_crew() -> _Crew:
    """The worker threads of ``_reading_threaded`` and ``_run_chunks`` (made on first use,
    as many as the threads beyond the calling one)."""
    global _crew
    if _crew is None:
        _crew = _Crew(max(1, _max_threads - 1))
    return _crew


def _chunk_bounds(num_particles: int, chunks: int) -> list[tuple[int, int]]:
    """(lo, hi) of ``chunks`` nearly equal chunks of the particles."""
    return [(c * num_particles // chunks, (c + 1) * num_particles // chunks)
            for c in range(chunks)]


READING_BLOCK = 16
"""Particles a thread of a split reading takes at a time: small enough that the threads end
within about one block of each other (a particle costs a few microseconds), large enough that
taking one costs nothing."""


def _run_shared(kernel, threads: int, args, total: int) -> None:
    """``kernel(*args)`` on this thread and on ``threads - 1`` worker threads at once (the
    kernel shares the work out itself, ``_Crew``); returns when all ``total`` particles are
    done (a worker's exception is raised here)."""
    _shared_crew().run(kernel, threads - 1, args, total)


DONE_POLLS = 200_000
"""Polls of the particles-done counter (about 1.5 ms) before the calling thread of a split
reading waits by sleeping instead (a worker thread descheduled in the middle of a block)."""


class _Crew:
    """The worker threads of the split readings, kept from one reading to the next, each
    serving its own queue. A reading puts its job in the queues and runs its own share at
    once; the threads take blocks of particles from the reading's counter and count the
    particles they finish, and the reading waits for that count in compiled code, without
    the GIL. A worker that starts late only takes fewer blocks, and no reading waits for a
    worker to wake up or to return to Python."""

    def __init__(self, workers: int) -> None:
        self._queues = [queue.SimpleQueue() for _ in range(workers)]
        self._errors: list[BaseException] = []
        for number, jobs in enumerate(self._queues):
            threading.Thread(target=self._serve, args=(jobs,), daemon=True,
                             name=f"fastslam_kernel_{number}").start()

    def _serve(self, jobs) -> None:
        while True:
            job = jobs.get()
            if job is None:
                return
            kernel, args, reply = job
            error = None
            try:
                kernel(*args)
            except BaseException as caught:  # noqa: BLE001 (raised on the calling thread)
                error = caught
            if reply is not None:
                reply.put(error)
            elif error is not None:
                self._errors.append(error)

    def run(self, kernel, workers: int, args, total: int) -> None:
        """``kernel(*args)`` here and on ``workers`` of the threads, the kernel taking its
        blocks from the reading's counter ``args[0]`` and counting the particles it finished
        in it; returns when all ``total`` are done (a worker's exception is raised here)."""
        for jobs in self._queues[:workers]:
            jobs.put((kernel, args, None))
        kernel(*args)
        counter = args[0]
        while not _await_done(counter, total, DONE_POLLS):
            if self._errors:
                break
            time.sleep(1e-4)
        if self._errors:
            error = self._errors.pop()
            self._errors.clear()
            raise error

    def run_each(self, kernel, argument_sets) -> None:
        """``kernel(*arguments)`` for each of ``argument_sets``: the first here, each other on
        a worker of its own; returns when all are done (a worker's exception is raised
        here)."""
        if len(argument_sets) - 1 > len(self._queues):
            raise ValueError(f"{len(argument_sets)} jobs for {len(self._queues)} workers and "
                             "the calling thread")
        reply = queue.SimpleQueue()
        for jobs, arguments in zip(self._queues, argument_sets[1:]):
            jobs.put((kernel, arguments, reply))
        kernel(*argument_sets[0])
        errors = [reply.get() for _ in argument_sets[1:]]
        for error in errors:
            if error is not None:
                raise error

    def stop(self) -> None:
        for jobs in self._queues:
            jobs.put(None)


def _run_chunks(kernel, bounds, args) -> None:
    """``kernel(lo, hi, *args)`` for every (lo, hi) of ``bounds``: the first on this thread,
    the others on the crew's workers; returns when all are done (a worker's exception is
    raised here)."""
    _shared_crew().run_each(kernel, [(lo, hi, *args) for lo, hi in bounds])


PARALLEL_MIN_PARTICLES = 500
"""Below this many particles a reading runs on the calling thread: waking a second thread
costs more than it saves, and on a busy machine far more (the reading waits for the slower
thread)."""


_max_threads = numba.config.NUMBA_NUM_THREADS


def threads_for(num_particles: int) -> int:
    """Threads a reading of ``num_particles`` runs on (1 below ``PARALLEL_MIN_PARTICLES``)."""
    return 1 if num_particles < PARALLEL_MIN_PARTICLES else _max_threads


def splits(num_particles: int) -> bool:
    """A reading of this many particles runs on several threads."""
    return threads_for(num_particles) > 1


def set_threads(count: int) -> None:
    """At most ``count`` threads for a reading (<= ``NUMBA_NUM_THREADS``, which defaults to
    the machine's cores)."""
    global _max_threads, _crew
    count = max(1, min(int(count), numba.config.NUMBA_NUM_THREADS))
    if count != _max_threads and _crew is not None:
        _crew.stop()
        _crew = None
    _max_threads = count
