"""Many points at once: local processes, or a Dask cluster.

:class:`Executor` maps a picklable function over items, in order. It is the
tuner's own (the optimisers ask for points a batch at a time, so the pool
stays up between batches); :mod:`hybridsim.runs.sweep` keeps its own loop.
"""
import os
from concurrent.futures import ProcessPoolExecutor

from hybridsim.errors import InputError

#: seconds to wait for a Dask scheduler to answer
DASK_TIMEOUT_S = 10


class Executor:
    """``map(fn, items)`` on ``jobs`` local processes (1: here), or on the Dask scheduler ``dask``.

    Use as a context manager; the pool or client closes on the way out.
    """

    def __init__(self, jobs=None, dask=None):
        if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
            raise InputError(f"jobs must be a whole number >= 1, got {jobs!r}")
        self.jobs = jobs or os.cpu_count() or 1
        self.dask = dask
        self._pool = self._client = None

    def __enter__(self):
        if self.dask is not None:
            if isinstance(self.dask, str):
                from distributed import Client

                try:
                    self._client = Client(self.dask, timeout=f"{DASK_TIMEOUT_S}s")
                except (OSError, TimeoutError, ValueError, TypeError) as exc:
                    raise InputError(f"no Dask scheduler answers at {self.dask!r} "
                                     f"within {DASK_TIMEOUT_S} s: {exc}") from None
            else:
                self._client = self.dask  # a Client given by the caller: left open
        return self

    def __exit__(self, *exc):
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
        if self._client is not None and isinstance(self.dask, str):
            self._client.close()

    @property
    def width(self):
        """How many points run at once (the batch size worth asking for)."""
        if self._client is not None:
            return max(1, sum(self._client.nthreads().values()))
        return self.jobs

    def map(self, fn, items):
        """``[fn(i) for i in items]``, in parallel, in order."""
        items = list(items)
        if self._client is not None:
            return self._client.gather(self._client.map(fn, items, pure=False))
        if self.jobs <= 1 or len(items) <= 1:
            return [fn(i) for i in items]
        if self._pool is None:
            self._pool = ProcessPoolExecutor(self.jobs)
        return list(self._pool.map(fn, items))
