"""Dask clusters: where ``--dask ADDRESS`` sends the joblib work of a subcommand.

``--dask tcp://host:port`` connects to a running ``dask scheduler``;
``--dask local:N`` starts a local cluster of ``N`` worker processes (one
thread each) for the duration of the call. Inside :func:`dask_cluster`,
joblib's ``Parallel`` runs on the cluster (joblib's ``"dask"`` backend), so
the core (:mod:`terrain_odom.vision`, :mod:`terrain_odom.fitting`) stays
unaware of Dask: feature extraction and the ``--tune`` searches are joblib
calls that return their results in input order, whichever backend runs
them. ``compare``'s models and ``evaluate``'s logs are tasks of
:func:`run_jobs` (a loop here, ``client.map`` on a cluster), in input order too.

Workers receive file *paths* for the images (and the logs of ``evaluate``
batches) and read them themselves: every worker must see the same paths (a
shared file system, or the same data copied to the same place). Logs of
``compare`` are read once by the client and sent as arrays.

Dask is the optional extra ``terrain-odom[dask]``; without it, ``--dask``
raises a one-line :class:`~terrain_odom.errors.ConfigError`.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

from terrain_odom.errors import ConfigError

__all__ = ["LOCAL", "ClusterSpec", "parse_dask_address", "Cluster", "dask_cluster", "run_jobs"]

LOCAL = "local:"
"""Prefix of a local cluster's address: ``local:N`` (``N`` worker processes)."""

CONNECT_TIMEOUT = 10.0
"""Seconds to wait for a scheduler to answer, and for its first worker."""

T = TypeVar("T")

_REMOTE = re.compile(r"^(tcp|tls|ucx|inproc)://\S+$")


@dataclass(frozen=True)
class ClusterSpec:
    """A parsed ``--dask`` value.

    Attributes
    ----------
    address : str or None
        The scheduler's address (``tcp://host:port``); None for a local cluster.
    workers : int
        Worker processes of a local cluster (0 for a scheduler's address).
    """

    address: str | None
    workers: int = 0


def parse_dask_address(text: str) -> ClusterSpec:
    """Parse ``--dask``: ``local:N`` or a scheduler address like ``tcp://10.0.0.5:8786``.

    Raises
    ------
    ConfigError
        Neither form, or ``N < 1``.
    """
    if text.startswith(LOCAL):
        count = text[len(LOCAL) :]
        if not count.isdigit() or int(count) < 1:
            raise ConfigError(
                f"--dask: local:N needs a whole number of workers N >= 1, got {text!r}"
            )
        return ClusterSpec(None, int(count))
    if not _REMOTE.match(text):
        raise ConfigError(
            f"--dask: expected a scheduler address like tcp://host:8786 or local:N, got {text!r}"
        )
    return ClusterSpec(text)


@dataclass(frozen=True)
class Cluster:
    """The cluster a call runs on (see :func:`dask_cluster`).

    Attributes
    ----------
    address : str
        The scheduler's address.
    threads : int
        Worker threads of the cluster when it was joined.
    client : distributed.Client
        This process's client of the scheduler.
    """

    address: str
    threads: int
    client: Any = field(repr=False, compare=False)

    @property
    def jobs(self) -> int:
        """``n_jobs`` to give joblib on the cluster: its threads, at least 2.

        joblib's dask backend uses every worker whatever ``n_jobs`` says; at
        least 2 keeps callers that run ``n_jobs == 1`` in their own process
        (:func:`~terrain_odom.vision.dataset.extract_feature_sets`) on the cluster.
        """
        return max(2, self.threads)


def _distributed() -> Any:
    """Import ``dask.distributed``, or raise the one-line error naming the extra."""
    try:
        import distributed
    except ImportError:
        raise ConfigError(
            "--dask needs Dask: pip install 'terrain-odom[dask]' (dask[distributed])"
        ) from None
    return distributed


@contextlib.contextmanager
def dask_cluster(address: str | None) -> Iterator[Cluster | None]:
    """Run the joblib calls inside on the Dask cluster of ``address`` (nothing without one).

    Parameters
    ----------
    address : str or None
        ``--dask``: ``local:N`` starts ``N`` local worker processes (stopped
        on exit); ``tcp://host:port`` connects to a running scheduler; None
        changes nothing (joblib's own processes), yielding None.

    Yields
    ------
    Cluster or None

    Raises
    ------
    ConfigError
        A malformed address, Dask not installed, or no scheduler (or no
        worker) answering within :data:`CONNECT_TIMEOUT` seconds.
    """
    if address is None:
        yield None
        return
    spec = parse_dask_address(address)
    distributed = _distributed()
    from joblib import parallel_config

    with contextlib.ExitStack() as stack:
        if spec.address is None:
            stack.enter_context(_numpy_friendly_workers())
            cluster = stack.enter_context(
                distributed.LocalCluster(
                    n_workers=spec.workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=":0",  # a free port: None still means 8787
                )
            )
            client = stack.enter_context(distributed.Client(cluster))
        else:
            client = stack.enter_context(_connect(distributed, spec.address))
        stack.enter_context(parallel_config(backend="dask"))
        yield Cluster(client.scheduler.address, sum(client.nthreads().values()), client)


def _numpy_friendly_workers() -> Any:
    """Return a dask config context: worker processes spawned without ``MALLOC_TRIM_THRESHOLD_``.

    Dask's nannies set it by default; any value turns off glibc's dynamic
    mmap threshold, so every array over 128 KiB is mapped and unmapped anew:
    ``compare``'s fits ran about 1.5x slower on such workers.
    """
    import dask

    environ = dask.config.get("distributed.nanny.pre-spawn-environ", {})
    kept = {k: v for k, v in environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
    return dask.config.set({"distributed.nanny.pre-spawn-environ": kept})


@contextlib.contextmanager
def _connect(distributed: Any, address: str) -> Iterator[Any]:
    """Connect to the scheduler at ``address`` and wait for a worker (one-line errors)."""
    try:
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT)
    except OSError as exc:
        raise ConfigError(f"--dask: no Dask scheduler answers at {address} ({exc})") from None
    with client:
        try:
            client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
        except TimeoutError:
            raise ConfigError(
                f"--dask: the scheduler at {address} has no worker "
                f"(none joined within {CONNECT_TIMEOUT:g} s)"
            ) from None
        yield client


def run_jobs(
    function: Callable[..., T], items: Sequence[Any], cluster: Cluster | None, **shared: Any
) -> list[T]:
    """Return ``[function(item, **shared) for item in items]``, in input order.

    Without a cluster, a plain loop in this process. On a cluster, one task
    per item (``client.map``); the ``shared`` arguments are sent to every
    worker once (``client.scatter``), not with each task through the scheduler.
    """
    if cluster is None:
        return [function(item, **shared) for item in items]
    client = cluster.client
    sent = {}
    if shared:
        futures = client.scatter(list(shared.values()), broadcast=True)
        sent = dict(zip(shared, futures, strict=True))
    return list(client.gather(client.map(function, list(items), pure=False, **sent)))
