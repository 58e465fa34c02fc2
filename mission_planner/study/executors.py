"""Run many trials: local worker processes (default) or a Dask distributed cluster.

:func:`run_trials` is the one entry point. It skips the trials a study directory has already
logged, runs the rest on the chosen executor, logs each row the moment it arrives, shows a
progress bar with an ETA, and returns the rows of all requested trials in the requested order.
Rows are a function of the trial spec and the planner options alone (except the wall-time
column), so the same specs give the same table on any executor, in any completion order.

A trial whose site or planner fails is a row with an error, logged like any other. A worker
that dies (killed, out of memory, a lost Dask worker) is not a trial result: the study stops
with an :class:`ExecutorError`, keeping what finished, and a re-run resumes.
"""

from __future__ import annotations

import functools
import multiprocessing
import os
import re
import socket
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, TypeVar

from mission_planner.study.store import TrialLog, check_manifest, read_log
from mission_planner.study.trials import Row, is_failed, run_trial
from validator.errors import InputError

if TYPE_CHECKING:
    from distributed import Client

    from mission_planner.optimize import PlannerOptions

CONNECT_TIMEOUT_S = 10
SCHEDULER_RE = re.compile(r"^tcp://[^\s:/]+:\d{1,5}$")
# Worker processes fork from a server that has already imported the planner (cvxpy), so each
# starts in milliseconds; forking the caller itself is unsafe once it runs threads (Dask, tqdm).
_PRELOAD = ["mission_planner.study.trials", "mission_planner.optimize"]


class ExecutorError(RuntimeError):
    """The executor lost a worker or the cluster; finished trials are kept in the log."""


@dataclass
class StudyRun:
    """What :func:`run_trials` did: all rows in spec order, and how many trials ran now."""

    rows: list[Row]
    executed: int
    skipped: int
    failed: list[Row] = field(default_factory=list)


def default_workers() -> int:
    """The CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def check_scheduler(address: str) -> str:
    """Accept ``tcp://HOST:PORT``; anything else is an :class:`InputError`."""
    if not SCHEDULER_RE.match(address):
        raise InputError(f"--scheduler: expected tcp://HOST:PORT, got {address!r}")
    return address


class Spec(Protocol):
    """What :func:`run_trials` runs: a trial's parameters, hashable, known by its ``key``."""

    @property
    def key(self) -> str: ...

    def __hash__(self) -> int: ...


S = TypeVar("S", bound=Spec)


def _map_inline(fn: Callable[[S], Row], specs: Sequence[S]
                ) -> Iterator[Row]:
    for spec in specs:
        yield fn(spec)


def _process_context() -> multiprocessing.context.BaseContext:
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(_PRELOAD)
        return ctx
    return multiprocessing.get_context("spawn")


def _map_processes(fn: Callable[[S], Row], specs: Sequence[S],
                   workers: int) -> Iterator[Row]:
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=_process_context())
    finished = False
    try:
        pending: set[Future[Row]] = {pool.submit(fn, s) for s in specs}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                try:
                    yield fut.result()
                except Exception as err:
                    raise ExecutorError(f"a worker process failed: {err!r}") from err
        finished = True
    finally:
        if not finished:
            _terminate(pool)
        pool.shutdown(wait=True, cancel_futures=True)


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop the workers now. Cancelling is not enough: the pool hands each worker its next trial
    ahead of time, and a worker interrupted by Ctrl-C would go on to run it."""
    terminate = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()


def _connect(address: str) -> Client:
    """A ``distributed.Client`` for the scheduler at ``address``, or an :class:`InputError`."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler: needs dask distributed (pip install 'nfz-mission[study]')"
                         ) from None
    host, port = address.removeprefix("tcp://").rsplit(":", 1)
    try:
        # A plain connect first: refused or unknown hosts fail at once, not after the timeout.
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
        return Client(address, timeout=f"{CONNECT_TIMEOUT_S}s", set_as_default=False)
    except OSError as err:
        raise InputError(f"--scheduler: cannot reach {address} ({err})") from None


def _map_dask(fn: Callable[[S], Row], specs: Sequence[S],
              client: Client) -> Iterator[Row]:
    from distributed import as_completed

    try:
        # pure=False: never reuse a result the cluster may hold from another study.
        futures = client.map(fn, list(specs), pure=False)
        for fut in as_completed(futures, loop=client.loop):
            try:
                yield fut.result()
            except Exception as err:
                raise ExecutorError(f"a Dask task failed outside the trial: {err!r}") from err
            finally:
                fut.release()
    finally:
        client.close()


def run_trials(
    specs: Sequence[Spec],
    directory: str | Path,
    *,
    options: PlannerOptions | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool | None = None,
    retry_errors: bool = False,
    on_row: Callable[[Row], None] | None = None,
    manifest: dict[str, object] | None = None,
    trial: Callable[..., Row] = run_trial,
) -> StudyRun:
    """Run the ``specs`` not yet logged in ``directory``; return every spec's row, in order.

    - ``workers``: local processes (default: all CPUs); 1 runs the trials in this process.
    - ``scheduler``: ``tcp://HOST:PORT`` of a Dask scheduler; runs there instead. Its workers
      need this package installed.
    - ``progress``: show a progress bar (None: only when stderr is a terminal).
    - ``retry_errors``: run again the logged trials that ended in an error.
    - ``on_row``: called with each new row after it is logged.
    - ``manifest``: settings recorded beside the log (see :func:`check_manifest`).
    - ``trial``: what runs one spec, ``trial(spec, options=options) -> row`` (default
      :func:`run_trial`; the wind study's :func:`~mission_planner.study.wind.run_wind_trial`);
      any spec with a ``key`` and its function's row with the same ``key`` will do.

    Duplicate specs run once. Raises :class:`ExecutorError` if a worker dies.
    """
    from tqdm.auto import tqdm

    if workers is not None and workers < 1:
        raise InputError(f"--workers: must be >= 1, got {workers}")
    if scheduler is not None:
        check_scheduler(scheduler)
    directory = Path(directory)
    wanted = list(dict.fromkeys(specs))
    done = read_log(directory)
    todo = [
        s for s in wanted
        if s.key not in done or (retry_errors and is_failed(done[s.key]))
    ]
    fn = functools.partial(trial, options=options)
    if manifest is not None:
        check_manifest(directory, manifest)
    rows: Iterator[Row]
    if not todo:
        rows = iter(())
    elif scheduler is not None:
        rows = _map_dask(fn, todo, _connect(scheduler))
    else:
        n = min(workers or default_workers(), max(len(todo), 1))
        rows = _map_inline(fn, todo) if n == 1 else _map_processes(fn, todo, n)

    executed = 0
    todo_keys = {s.key for s in todo}
    failed = sum(is_failed(done[k]) for k in (s.key for s in wanted) if k not in todo_keys)
    bar = tqdm(total=len(wanted), initial=len(wanted) - len(todo), unit="trial", desc="trials",
               disable=None if progress is None else not progress, dynamic_ncols=True,
               smoothing=0.05)
    try:
        with TrialLog(directory, manifest) as log:
            for row in rows:
                log.append(row)
                done[str(row["key"])] = row
                executed += 1
                bar.update(1)
                if is_failed(row):
                    failed += 1
                    bar.set_postfix(failed=failed, refresh=False)
                if on_row is not None:
                    on_row(row)
    finally:
        close = getattr(rows, "close", None)
        if close is not None:
            close()  # stop the executor now, even when interrupted
        bar.close()
    out = [done[s.key] for s in wanted]
    return StudyRun(rows=out, executed=executed, skipped=len(wanted) - len(todo),
                    failed=[r for r in out if is_failed(r)])
