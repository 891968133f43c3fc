"""Where many runs happen: here, on local processes, or on a Dask cluster - one argument chooses.

:class:`Executor` is the only pool of hybridsim (a compiled
:meth:`~hybridsim.engine.simulator.Simulator.run_batch` keeps its threads inside the
engine). It hands out picklable calls and gives their results back as they finish;
the pool (or the Dask client) stays up between calls until the executor closes, so a
search that asks for points a few at a time, or a worker that keeps what it built
(:mod:`hybridsim.runs.experiment`), pays for starting once.
"""
import contextlib
import os
import signal

import numpy as np

from hybridsim.errors import InputError

#: seconds to wait for a Dask scheduler to answer
DASK_TIMEOUT_S = 10


def check_jobs(jobs):
    """Refuse a number of processes that is not None or a whole number >= 1."""
    if jobs is not None and (isinstance(jobs, (bool, np.bool_)) or not isinstance(jobs, (int, np.integer))
                             or jobs < 1):
        raise InputError(f"jobs must be a whole number >= 1, got {jobs!r}")
    return None if jobs is None else int(jobs)


class Executor:
    """Runs calls serially (``jobs=1``), on ``jobs`` local processes, or on a Dask cluster.

    Use it as a context manager; the pool or client closes on the way out. Raises
    :class:`~hybridsim.errors.InputError` for a bad ``jobs`` or a scheduler that does not
    answer within :data:`DASK_TIMEOUT_S`.

    Parameters
    ----------
    jobs : int, optional
        Local processes (default: one per core); 1 runs everything here, in order.
    dask : str or distributed.Client, optional
        A scheduler address (``tcp://host:8786``; connected on entry, closed on exit) or a
        client (left open); then ``jobs`` is not used.
    """

    def __init__(self, jobs=None, dask=None):
        self.jobs = check_jobs(jobs) or os.cpu_count() or 1
        if dask is not None and not isinstance(dask, str) and not hasattr(dask, "submit"):
            raise InputError(f"dask is a scheduler address ('tcp://host:8786') or a distributed.Client, got {dask!r}")
        self.dask = dask
        self._pool = self._client = None
        self._size = 0

    def __enter__(self):
        if self.dask is not None and self._client is None:
            self._client = connect(self.dask) if isinstance(self.dask, str) else self.dask
        return self

    def __exit__(self, kind, *exc):
        # an interrupt (Ctrl-C, SIGTERM): the workers are stopped, not waited for (a pool whose
        # workers an interrupt reached could wait for ever)
        self.close(abort=kind is not None and not issubclass(kind, Exception))

    def close(self, abort=False):
        """Shut the local pool down (``abort``: stop its workers at once) and close a client this
        executor opened."""
        if self._pool is not None:
            if abort:
                workers = list((getattr(self._pool, "_processes", None) or {}).values())
                self._pool.shutdown(wait=False, cancel_futures=True)
                for w in workers:
                    w.terminate()
                for w in workers:
                    w.join(5)
            else:
                self._pool.shutdown(cancel_futures=True)
            self._pool = None
        if self._client is not None and isinstance(self.dask, str):
            self._client.close()
        self._client = None

    @property
    def width(self):
        """How many calls run at once (the batch size worth asking for)."""
        if self._client is not None:
            return max(1, sum(self._client.nthreads().values()))
        return self.jobs

    def as_completed(self, fn, items):
        """Yield ``(index, fn(item))`` for each of ``items`` as it finishes (here: in order).

        An exception raised by a call is raised here, when its turn comes."""
        items = list(items)
        if self._client is not None:
            from distributed import as_completed

            futures = {self._client.submit(fn, item, pure=False): k for k, item in enumerate(items)}
            for fut in as_completed(futures):
                yield futures[fut], fut.result()
            return
        if self.jobs <= 1 or len(items) <= 1:
            for k, item in enumerate(items):
                yield k, fn(item)
            return
        from concurrent.futures import as_completed

        want = min(self.jobs, len(items))  # -j 2000 for 2 points: 2 processes, not 2000 started
        if self._pool is None or self._size < want:
            from concurrent.futures import ProcessPoolExecutor

            if self._pool is not None:
                self._pool.shutdown()
            self._pool, self._size = ProcessPoolExecutor(want, initializer=_quiet_worker), want
        futures = {self._pool.submit(fn, item): k for k, item in enumerate(items)}
        try:
            for fut in as_completed(futures):
                yield futures[fut], fut.result()
        finally:
            for fut in futures:
                fut.cancel()

    def map(self, fn, items):
        """``[fn(item) for item in items]``, in parallel, in order."""
        items = list(items)
        out = [None] * len(items)
        for k, value in self.as_completed(fn, items):
            out[k] = value
        return out


def _quiet_worker():
    """A pool worker leaves Ctrl-C to the main process (which stops it) and dies on SIGTERM at once
    (it inherits the command's handler, which would raise inside the pool's queue)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def connect(address):
    """A Dask client for ``address``, or InputError when nothing answers within DASK_TIMEOUT_S."""
    from distributed import Client

    try:
        return Client(address, timeout=f"{DASK_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise InputError(f"cannot reach a Dask scheduler at {address!r} within {DASK_TIMEOUT_S} s "
                         f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'no answer'}); "
                         "is the scheduler running and the address right (tcp://HOST:8786)?") from None


@contextlib.contextmanager
def using(executor=None, jobs=None):
    """The executor to run on: ``executor`` itself when it is one (left open), else a new
    :class:`Executor` of ``executor`` (or ``jobs``) local processes, closed on the way out."""
    if isinstance(executor, Executor):
        yield executor
        return
    with Executor(executor if executor is not None else jobs) as ex:
        yield ex
