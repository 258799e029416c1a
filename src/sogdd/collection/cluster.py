"""A batch on a Dask distributed cluster (``pip install 'sogdd[distributed]'``).

The connection is made before any work is shown or submitted, so an unreachable
scheduler is one error and nothing else. A task whose workers keep dying (Dask
retries it elsewhere, then gives up with ``KilledWorker``) costs only that task.
"""

from __future__ import annotations

import socket
from collections.abc import Callable, Sequence

from .processes import died_item

__all__ = ["connect", "run_dask"]


def connect(scheduler: str):
    """A ``distributed.Client`` connected to ``scheduler``.

    ``ValueError`` if Dask is not installed or the scheduler cannot be reached.
    """
    try:
        from distributed import Client
    except ImportError as exc:
        raise ValueError("--scheduler needs Dask: pip install 'sogdd[distributed]'") from exc
    _probe_scheduler(scheduler)
    try:
        return Client(scheduler, timeout="10s")
    except OSError as exc:
        raise ValueError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from exc


def run_dask(client, work: Callable, args: Sequence[tuple], done: Callable, *,
             died: Callable[[tuple, str], object] = died_item) -> None:
    """``work(*a)`` for each ``a`` in ``args`` on the cluster of ``client``; ``done`` gets each outcome.

    A task that Dask gives up on because its workers died gives ``died(a, why)``.
    """
    from distributed import KilledWorker, as_completed

    futures = {client.submit(work, *a, pure=False): a for a in args}
    for f in as_completed(list(futures)):
        try:
            out = f.result()
        except KilledWorker:
            out = died(futures[f], "Dask workers died running it (killed by the system, e.g. out of memory)")
        done(out)


def _probe_scheduler(address: str) -> None:
    """Fail at once when nothing listens at a ``tcp://host:port`` scheduler (Dask would retry for 10 s).

    Only a refused or unresolvable address fails here; one that does not answer
    within a second is left to Dask's own timeout.
    """
    scheme, _, rest = address.rpartition("://")
    if scheme not in ("", "tcp"):
        return  # tls://, ucx://, inproc://: Dask's business
    host, _, port = rest.rpartition(":")
    if not host or not port.isdigit():
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=1.0).close()
    except (ConnectionRefusedError, socket.gaierror) as exc:
        raise ValueError(f"cannot reach the Dask scheduler at {address}: "
                         f"{exc.strerror or exc} (is it running?)") from None
    except OSError:
        pass  # a timeout or an unreachable network: Dask's timeout decides
