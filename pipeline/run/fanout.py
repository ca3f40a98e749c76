"""Fan a study's runs out over dask.distributed workers and keep every result.

The client submits :func:`pipeline.run.runner.run_case` futures and collects
them with ``as_completed``; each record is written to the ledger as it
arrives (only the client writes files).  Workers are processes with one
thread each and ``NUMBA_NUM_THREADS=1``; a worker plugin loads the numba
kernels once per worker, before its first run.

A worker that dies is replaced by its nanny and the scheduler reschedules
its runs; a run that kills ``allowed-failures`` + 1 workers ends as a
``KilledWorker`` error, which is recorded as a failed run.

Which runs to compute comes from a *planner*: the grid planner hands out
every missing case at once; the bisection planner (:mod:`pipeline.study.boundary`)
hands out the next probes as results come back.
"""

from __future__ import annotations

import contextlib
import logging
import os
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from distributed.diagnostics.plugin import WorkerPlugin

from pipeline.data.netcdf import write_netcdf
from pipeline.data.studyset import study_dataset
from pipeline.kinds import adapter_of
from pipeline.provenance import PROJECT_ROOT, git_commit, now
from pipeline.run.ledger import FAILED, Ledger
from pipeline.run.runner import compile_kernels, run_case, warm_up
from pipeline.study.boundary import BisectionPlanner
from pipeline.study.multifidelity import MultiFidelityPlanner, add_multifidelity
from pipeline.study.spec import Case, Study, lattice

RESULTS = PROJECT_ROOT / "results"

log = logging.getLogger(__name__)

WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
ALLOWED_FAILURES = 2  # a run that kills 3 workers is recorded as failed
WORKER_SATURATION = 1.0  # runs sent to a worker per thread; the queue stays on the scheduler


class Planner(Protocol):
    def propose(self) -> list[Case]:
        """Cases to compute next (each proposed once)."""

    def record(self, case: Case, record: dict[str, Any]) -> None:
        """Take a finished (or reused) run."""

    def expected(self) -> int | None:
        """How many runs the planner will need in total, if known."""


class GridPlanner:
    """Every case of the full grid."""

    def __init__(self, study: Study) -> None:
        self.cases = study.cases()
        self._given = False

    def propose(self) -> list[Case]:
        if self._given:
            return []
        self._given = True
        return list(self.cases)

    def record(self, case: Case, record: dict[str, Any]) -> None:
        pass

    def expected(self) -> int | None:
        return len(self.cases)


class WarmUp(WorkerPlugin):
    """Worker plugin: one thread for numba and the kernels of ``kinds`` (None: every kind) loaded before the
    first run."""

    name = "hdi-warm-up"

    def __init__(self, kinds: tuple[str, ...] | None = None) -> None:
        self.kinds = kinds

    def setup(self, worker) -> None:
        os.environ.update(WORKER_ENV)
        seconds = warm_up(self.kinds)
        log.info("worker %s warmed up in %.2f s", getattr(worker, "address", "?"), seconds)


@contextlib.contextmanager
def dask_client(
    workers: int | None = None, scheduler: str | None = None, kinds: tuple[str, ...] | None = None
) -> Iterator[Any]:
    """A client on ``scheduler`` (tcp://host:port), or on an embedded LocalCluster of worker processes whose
    workers load the kernels of ``kinds`` (None: every kind) before their first run."""
    import dask
    from distributed import Client, LocalCluster

    plugin = WarmUp(kinds)
    if scheduler:
        client = Client(scheduler, timeout="30s")
        try:
            client.register_plugin(plugin)
            yield client
        finally:
            client.close()
        return
    n = workers or os.cpu_count() or 1
    compile_kernels(kinds)  # once here, not in every worker at the same time: the workers then load them
    if not log.isEnabledFor(logging.INFO):  # the scheduler lives in this process: keep its chatter out
        logging.getLogger("distributed").setLevel(logging.ERROR)
    with dask.config.set(
        {
            "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
            # one run per worker thread at a time: a run queued on a worker that another run kills counts that
            # death against itself (dask's default 1.1 sends two runs to a one-thread worker), and an innocent run
            # queued three times beside a crashing one was recorded as KilledWorker (seen in the test suite)
            "distributed.scheduler.worker-saturation": WORKER_SATURATION,
            "distributed.worker.daemon": True,
            "distributed.nanny.pre-spawn-environ": WORKER_ENV,
        }
    ):
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
            env=WORKER_ENV,
        )
        client = Client(cluster)
        try:
            client.register_plugin(plugin)
            yield client
        finally:
            client.close()
            cluster.close()


def _failure(case: Case, message: str) -> dict[str, Any]:
    return {"run_id": case.run_id, "status": FAILED, "message": message, "wall_time": float("nan")}


def _finish(case: Case, record: dict[str, Any], study: Study) -> dict[str, Any]:
    """Add what the client knows: where the run sits in the study, the code, the time."""
    record = dict(record)
    record.update(
        run_id=case.run_id,
        study=study.name,
        coords=case.coords,
        overrides=case.overrides,
        git_commit=git_commit(),
        finished=now(),
    )
    return record


class Progress:
    """One line per finished run: counts, the run's verdict and cost, elapsed time and time left."""

    def __init__(self, total: int | None, workers: int, stream=None, quiet: bool = False) -> None:
        self.total, self.workers = total, max(workers, 1)
        self.stream = stream or sys.stdout
        self.quiet = quiet
        self.t0 = time.perf_counter()
        self.done = 0
        self.walls: list[float] = []

    def __call__(self, case: Case, record: dict[str, Any]) -> None:
        self.done += 1
        wall = record.get("wall_time", float("nan"))
        if wall == wall:
            self.walls.append(wall)
        if self.quiet:
            return
        elapsed = time.perf_counter() - self.t0
        status = record.get("status", FAILED)
        if status == FAILED:
            verdict = f"FAILED ({record.get('message', '')[:80]})"
        else:
            verdict = adapter_of(case.scene_dict).progress(record)
        count = f"{self.done}/{self.total}" if self.total else f"{self.done}"
        left = ""
        if self.total and self.walls:
            remaining = (self.total - self.done) * statistics.median(self.walls) / self.workers
            left = f"  left ~{_clock(remaining)}"
        print(f"[{count:>9}] {case.label():<36} {verdict}  {wall:5.2f} s  elapsed {_clock(elapsed)}{left}",
              file=self.stream, flush=True)  # fmt: skip


def _clock(seconds: float) -> str:
    m, s = divmod(int(round(seconds)), 60)
    return f"{m}:{s:02d}"


def execute(
    study: Study,
    planner: Planner,
    ledger: Ledger,
    connect: Callable[[], Any] | None,
    on_record: Callable[[Case, dict[str, Any]], None] | None = None,
    runner: Callable[..., dict[str, Any]] = run_case,
) -> list[tuple[Case, dict[str, Any], bool]]:
    """Compute what the planner asks for, reusing the ledger; returns (case, record, reused) of every run.

    ``connect()`` returns the dask client; it is called once, when the first
    run has to be computed (a study found complete in the ledger starts no
    cluster).  ``connect=None`` runs every case in this process, one after
    the other (for debugging and tiny studies).  Cases with one run id (the realisations of a cell whose input
    is not stochastic) are computed once: the others take its record as reused.
    """
    taken: list[tuple[Case, dict[str, Any], bool]] = []
    sharing: dict[str, list[Case]] = {}  # run id -> the cases waiting for its run (the computed one first)

    def take(case: Case, record: dict[str, Any], reused: bool) -> None:
        taken.append((case, record, reused))
        if not reused and on_record is not None:
            on_record(case, record)
        planner.record(case, record)

    def proposals() -> list[Case]:
        """New cases to compute; cases already in the ledger are taken at once (which may unlock more)."""
        todo: list[Case] = []
        while True:
            batch = planner.propose()
            if not batch:
                return todo
            for case in batch:
                record = ledger.finished(case.run_id)
                if record is not None:
                    take(case, record, reused=True)
                elif case.run_id in sharing:
                    sharing[case.run_id].append(case)
                else:
                    sharing[case.run_id] = [case]
                    todo.append(case)

    def computed(case: Case, record: dict[str, Any]) -> None:
        ledger.put(record)
        take(case, record, reused=False)
        for other in sharing.pop(case.run_id)[1:]:
            take(other, record, reused=True)

    if connect is None:
        todo = proposals()
        while todo:
            for case in todo:
                computed(case, _finish(case, runner(case.scene_dict, case.run_id, study.impacts_kept), study))
            todo = proposals()
        return taken

    from distributed import as_completed

    futures: dict[Any, Case] = {}
    client = None

    def submit(cases: list[Case]) -> list[Any]:
        nonlocal client
        out = []
        for case in cases:
            client = client or connect()
            fut = client.submit(runner, case.scene_dict, case.run_id, study.impacts_kept, key=f"run-{case.run_id}",
                                pure=False)  # fmt: skip
            futures[fut] = case
            out.append(fut)
        return out

    first = proposals()
    if not first:
        return taken
    pending = as_completed(submit(first))
    try:
        for fut in pending:
            case = futures.pop(fut)
            try:
                record = fut.result()
            except Exception as err:  # KilledWorker, or the task could not be run at all
                record = _failure(case, f"{type(err).__name__}: {err}")
            computed(case, _finish(case, record, study))
            for new in submit(proposals()):
                pending.add(new)
    except BaseException:
        for fut in futures:
            fut.cancel()
        raise
    return taken


@dataclass
class Outcome:
    dataset: Any  # xarray.Dataset
    computed: int
    reused: int
    failed: int
    wall_time: float
    run_time: float  # sum of the computed runs' wall times [s]
    ledger: Path


def default_output(study: Study) -> Path:
    suffix = {"boundary": "_boundary", "multifidelity": "_multifidelity"}.get(study.mode, "")
    return RESULTS / f"{study.name}{suffix}.nc"


def default_ledger(study: Study, output: Path) -> Path:
    return output.parent / ".ledger" / study.name


def run_study(
    study: Study,
    output: Path,
    *,
    ledger_dir: Path | None = None,
    client: Any | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    quiet: bool = False,
    runner: Callable[..., dict[str, Any]] = run_case,
    on_record: Callable[[Case, dict[str, Any]], None] | None = None,
) -> Outcome:
    """Run (or resume) a study and write its dataset atomically to ``output``.

    ``client``: an existing dask client; otherwise one on ``scheduler``, or an
    embedded LocalCluster of ``workers`` processes; ``workers=0`` runs in this process.
    """
    t0 = time.perf_counter()
    ledger = Ledger(ledger_dir or default_ledger(study, output))
    planner: Any
    if study.mode == "boundary":
        planner = BisectionPlanner(study)
    elif study.mode == "multifidelity":
        planner = MultiFidelityPlanner(study)
    else:
        planner = GridPlanner(study)
    n_workers = 1 if workers == 0 else (workers or os.cpu_count() or 1)
    expected = planner.expected()
    if isinstance(planner, GridPlanner):  # the progress counts the runs still to compute
        expected = len({case.run_id for case in planner.cases if ledger.finished(case.run_id) is None})
    progress = Progress(expected, n_workers, quiet=quiet)

    def seen(case: Case, record: dict[str, Any]) -> None:
        progress(case, record)
        if on_record is not None:
            on_record(case, record)

    with contextlib.ExitStack() as stack:

        def connect() -> Any:
            if client is not None:
                return client
            own = stack.enter_context(dask_client(workers, scheduler, kinds=(adapter_of(study.base).name,)))
            if not quiet:
                n = len(own.scheduler_info().get("workers", {}))
                print(f"dask: {scheduler or 'local cluster'}, {n} workers", flush=True)
            return own

        in_process = workers == 0 and client is None
        if in_process:
            warm_up((adapter_of(study.base).name,))
        taken = execute(study, planner, ledger, None if in_process else connect, seen, runner)
    cells = {case.index: (case, record) for case, record, _ in taken}
    if study.mode == "multifidelity":  # full-model records replace the cheap ones where re-run
        cells.update({c.index: (c, r) for c, r, _ in taken if c.run_id in planner.full_ids})
    if study.mode == "boundary":
        ds = study_dataset(study, cells, {study.axis(study.boundary.axis).dim: lattice(study)}, planner.summary())
    else:
        ds = study_dataset(study, cells)
    if study.mode == "multifidelity":
        add_multifidelity(ds, study, planner.summary())
    computed = [r for _, r, reused in taken if not reused]
    write_netcdf(ds, output)
    return Outcome(
        dataset=ds,
        computed=len(computed),
        reused=len(taken) - len(computed),
        failed=int(ds.attrs["failed_runs"]),
        wall_time=time.perf_counter() - t0,
        run_time=float(np.nansum([r.get("wall_time", np.nan) for r in computed])),
        ledger=ledger.folder,
    )
