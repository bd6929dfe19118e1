r"""The Dask cluster a data set runs on: a local cluster started and closed by :func:`connect`, or an
existing scheduler, and the worker plugin that lets a local cluster close without a false alarm.

Why a clean close needs help. A Dask worker reports to its scheduler every
:math:`T_h = 0.5` s (clusters of up to 10 workers) with a ``heartbeat_worker`` request over a
pooled connection and waits for the answer, which takes a round trip :math:`t_r` (the
worker's metrics, the connection, the scheduler's turn on its event loop). ``Worker.close``
stops that periodic call but does not wait for a heartbeat already sent: a few milliseconds
later it closes its connection pool, and a heartbeat still waiting for its answer fails with
``CommClosedError: ... ConnectionPool.heartbeat_worker ...: Stream is closed``, which the
worker logs at ERROR level with a traceback (a known, open race in Dask distributed). Nothing
is lost (the worker was closing anyway), but a user reads a traceback as a failure. A
heartbeat is in flight a fraction of the time, so each closing worker hits it with probability

.. math::
    p \approx \min\!\left(1,\ \frac{t_r}{T_h}\right),

under 1 % when the scheduler answers in a millisecond, several per cent when the machine is
short of CPU: other work on it, or, at the end of a local run, the worker processes that have
already closed spending 1-3 s each in the interpreter's and the native libraries' teardown on
the same cores as the scheduler and the workers still closing. Hiding the log would also hide a
scheduler that really is gone, so :class:`HeartbeatDrain` removes the race instead: as the first
step of every close of a worker (plugin teardown runs before the worker closes its connections,
whatever asked it to close), it stops the heartbeat and waits for the one in flight to get its
answer. A scheduler that does not answer within :data:`DRAIN_TIMEOUT` is not waited for any
longer (the close goes on, and the failed heartbeat is logged as the real fault it then is).
"""

from __future__ import annotations

import asyncio
import contextvars
import logging
import os

from distributed import WorkerPlugin

from .index import DatasetError

#: Seconds a closing worker waits for its heartbeat in flight. A local cluster's nanny gives a
#: closing worker 4 s (``Nanny.close``'s 5 s x 0.8) before it kills the process; the drain takes
#: at most half of that, and a heartbeat answer takes milliseconds on a responsive scheduler.
DRAIN_TIMEOUT = 2.0

#: The heartbeat (its completion future) whose call this code runs in, if any: a context variable,
#: so that it follows the call into the tasks the worker's close spawns (``asyncio.gather``).
_HEARTBEAT: contextvars.ContextVar = contextvars.ContextVar("sionnafmcw_heartbeat", default=None)


class HeartbeatDrain(WorkerPlugin):
    """Worker plugin: a worker that closes first stops its heartbeat and lets the one in flight finish.

    ``setup`` wraps the worker's periodic heartbeat so that each call in flight is known (a
    future completed when the heartbeat returns or fails); ``teardown``, which ``Worker.close``
    runs before it closes its connection pool, stops the periodic call and waits (at most
    ``timeout`` seconds) for the calls in flight. A heartbeat that itself closes the worker
    (the scheduler answered that it no longer knows it) is not waited for by its own close; one
    that gets that answer while another close is under way waits for that close, which then
    goes on after ``timeout`` (a scheduler that forgot a worker before it closed: not the local
    cluster's order, which removes a worker when the worker's own stream closes).
    """

    name = "sionnafmcw-heartbeat-drain"

    def __init__(self, timeout: float = DRAIN_TIMEOUT):
        self.timeout = float(timeout)

    def setup(self, worker) -> None:
        self._in_flight: set = set()  # one future per heartbeat in flight, done when it returns or fails
        periodic = worker.periodic_callbacks.get("heartbeat")
        if periodic is None:
            return
        beat, in_flight = periodic.callback, self._in_flight

        async def tracked_heartbeat():
            done = asyncio.get_running_loop().create_future()
            in_flight.add(done)
            token = _HEARTBEAT.set(done)
            try:
                return await beat()
            finally:
                _HEARTBEAT.reset(token)
                in_flight.discard(done)
                done.set_result(None)

        periodic.callback = tracked_heartbeat

    async def teardown(self, worker) -> None:
        periodic = worker.periodic_callbacks.get("heartbeat")
        if periodic is not None:
            periodic.stop()
        running_me = _HEARTBEAT.get()  # this close was called by that heartbeat: it cannot finish first
        pending = [done for done in getattr(self, "_in_flight", ()) if done is not running_me]
        if pending:
            await asyncio.wait(pending, timeout=self.timeout)


def connect(scheduler, workers, n_tasks, cluster_options):
    """``(client, close, threads)``: a new LocalCluster, or a client of an existing scheduler.

    A local cluster has one process per worker (1 thread each) and :class:`HeartbeatDrain` on
    every worker; ``close`` closes the client, then the cluster (workers first, then the
    scheduler). ``threads``: CPU threads per item (``simulate``'s ``threads``:
    :mod:`sionnafmcw.threads`), ``cores // workers`` on a local cluster (so the workers do not
    oversubscribe the cores), None (the worker machine's cores) on another cluster, whose
    workers are left as they are (running, no plugin added)."""
    from distributed import Client, LocalCluster

    if scheduler is None:
        cores = os.cpu_count() or 1
        n = int(workers) if workers else max(1, min(cores, n_tasks))
        if n < 1:
            raise ValueError(f"generate: workers must be >= 1, got {workers}")
        options = {"n_workers": n, "threads_per_worker": 1, "processes": True, "dashboard_address": ":0",
                   "silence_logs": logging.ERROR, **(cluster_options or {})}
        cluster = LocalCluster(**options)
        try:
            client = Client(cluster)
            client.register_plugin(HeartbeatDrain())
        except BaseException:
            cluster.close()
            raise

        def close():
            client.close()
            cluster.close()

        return client, close, max(1, cores // n)
    if workers is not None or cluster_options:
        raise ValueError("generate: workers= and cluster_options= configure the local cluster only; with "
                         "scheduler= size the cluster behind that scheduler itself")
    if isinstance(scheduler, Client):
        return scheduler, (lambda: None), None
    if isinstance(scheduler, str):
        try:
            client = Client(scheduler, timeout="30s")
        except OSError as exc:
            raise DatasetError(f"generate: cannot reach the Dask scheduler at {scheduler!r} ({exc}); start it "
                               "(e.g. `dask scheduler`, `dask worker ADDRESS --nthreads 1`) or pass scheduler=None "
                               "for a local cluster") from exc
        return client, client.close, None
    raise TypeError(f"generate: scheduler must be None, a scheduler address or a distributed.Client, got "
                    f"{type(scheduler).__name__}")


__all__ = ["DRAIN_TIMEOUT", "HeartbeatDrain", "connect"]
