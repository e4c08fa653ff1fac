"""Design studies: one scene solved over a grid or a Monte-Carlo sample of its values.

    df = flexgen.sweep("examples/two_link_finger.toml",
                       vary={"tendon.0.tension": (0.0, 10.0, 11), "load.0.force.1": (0.0, -1.0, 5)})

One row per case, the columns of docs/sweep.md: each varied key as written, ``converged``,
``stable``, ``iterations``, ``reason`` ("" when solved), ``warnings`` and ``notes`` (the
Result's, one per line), per output point ``<point>.x``,
``.y``, ``.angle``, ``.major``, ``.minor``, ``.ellipse_angle``, ``.error_estimate``, per flexure
``<flexure>.max_stress`` and ``.safety_factor`` (NaN when unknown or not solved).

The cases and their order: flexgen/sweep_plan.py; one chunk's solves: flexgen/sweep_chunk.py.
Here: where the chunks run (this process, worker processes, a Dask cluster), progress, and the
table. Every way of running gives the same numbers: the chunks and each case's warm start are
fixed by the study alone.
"""

from __future__ import annotations

import os
import signal
import sys
import time
import uuid
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import current_process, get_context
from typing import TYPE_CHECKING, Any

import numpy as np

from .estimate import estimate_answer
from .scene import Scene, SceneError, as_scene, scene_from_dict
from .settings import SolverSettings
from .solver import Solver, check_flag
from .sweep_chunk import (
    CASE_FIELDS,
    FLEXURE_FIELDS,
    POINT_FIELDS,
    TEXT_FIELDS,
    Chunk,
    run_chunk,
    stress_columns,
)
from .sweep_plan import CHUNK_SIZE, Plan, plan
from .units import result_units

if TYPE_CHECKING:
    import pandas as pd

# Worker processes pay their start-up once per session (the fork server and its workers importing
# flexgen and LAPACK: ~0.8 s measured on 2 cores; later studies reuse the pool: ~0.05 s), so a
# study goes to them only when a probe (one preparation and a few solves of the scene, timed
# here) says it takes longer than twice that start-up on one core.
# the scene keys that are counts: their columns are integers
COUNT_KEYS = frozenset({"modes", "elements"})
START_UP = 0.8  # seconds, the first pool of a session
START_UP_AGAIN = 0.05  # seconds, a pool kept from an earlier study
PLAIN_EVERY = 2.0  # seconds between plain progress lines (stderr not a terminal)


def sweep(
    scene: Scene | Mapping[str, Any] | str | os.PathLike,
    vary: Mapping[str, Any],
    samples: int | None = None,
    seed: int | None = None,
    workers: int | None = None,
    client: Any = None,
    progress: bool | None = None,
    *,
    estimate: bool = True,
    stress: bool = True,
    settings: SolverSettings | None = None,
    chunk_size: int = CHUNK_SIZE,
) -> pd.DataFrame:
    """Solve ``scene`` for every case of the study ``vary`` and return one row per case.

    - ``vary``: ``{path: (start, stop, count)}`` or ``{path: [values]}`` for a full factorial
      grid (rows in C order: the first key slowest); with ``samples=N``, ``{path: ("normal",
      mean, sd)}`` or ``("uniform", low, high)``, drawn from ``numpy.random.default_rng(seed)``.
      A path as ``Scene.with_value`` reads it (``tendon.0.tension``, ``flexure.proximal.
      thickness``).
    - ``workers``: processes on this machine (None: every core, unless a probe finds the
      study shorter than twice the workers' start-up, ``START_UP``: then this process; 1: this
      process only; N >= 2: N processes, as asked, at most one per chunk: a study of one chunk
      runs in this process). A script that runs a study on worker processes needs the
      ``if __name__ == "__main__":`` guard: each worker imports it.
    - ``client``: a ``dask.distributed.Client``: the chunks run as its tasks instead.
    - ``progress``: True a bar on a terminal, else a plain line on stderr at most every
      ``PLAIN_EVERY`` seconds (as cases finish in this process, as chunks finish on worker
      processes or a cluster); False nothing; None (default) the bar only when stderr is a
      terminal and the study goes to worker processes or a cluster (long enough to wait for).
    - ``estimate``: each point's ``error_estimate`` (Newton on the richer model, ``fg_estimate``;
      False: NaN, and a load study is about twice as fast).
    - ``stress``: each flexure's ``max_stress`` and ``safety_factor`` (``stress.peak_stress``,
      bending, a few us a case; with a strip's width also axial: the statics of a chunk's
      cases at once, ``stress.peak_stresses``, about 5 us a case more on the two-link finger:
      docs/sweep.md, "Speed", ``make bench-sweep``; False: NaN).
    - ``chunk_size``: cases per chunk (a task); part of the study's definition, since each
      chunk's first case solves cold.

    Bad input (an unknown path, a count < 1, a value the scene refuses) is a one-line
    ``SceneError`` naming the key, raised before anything is solved; a case without an
    equilibrium is a row with ``converged`` False and its ``reason``.
    """
    _refuse_in_a_starting_worker()
    sc = as_scene(scene)
    _check_scene(sc)
    study = plan(sc, vary, samples, seed)
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        raise ValueError(f"chunk_size: must be an integer >= 1, got {chunk_size!r}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)):
        raise ValueError(f"workers: must be an integer >= 1, got {workers!r}")
    if workers is not None and workers < 1:
        raise ValueError(f"workers: must be an integer >= 1, got {workers}")
    check_flag(estimate, "estimate")  # a string such as "no" would be truthy
    check_flag(stress, "stress")
    if client is not None and not all(hasattr(client, m) for m in ("map", "gather")):
        raise ValueError(
            f"client: expected a dask.distributed.Client, got {type(client).__name__} (an "
            f"address: Client({client!r}) connects to it)"
            if isinstance(client, str)
            else f"client: expected a dask.distributed.Client, got {type(client).__name__}"
        )
    chunks = _chunks(sc, study, chunk_size, estimate, stress, settings)
    bar = _progress(progress, study.cases, interactive=client is not None)
    try:
        if client is not None:
            results = _on_dask(client, chunks, bar)
        else:
            results = _local(chunks, workers or os.cpu_count() or 1, progress, bar, workers is None)
    finally:
        bar.close()
    return _table(sc, study, results)


class WorkerDied(RuntimeError):
    """A worker process ended without returning its chunk (exit 1 of ``flexgen sweep``)."""


WORKER_DIED = (
    "a worker process ended without returning its chunk (killed by the system, e.g. out of "
    "memory; or, from a script, the script starts a study outside an "
    '`if __name__ == "__main__":` guard, so each worker, which imports it, starts one too: '
    "add the guard, or pass workers=1)"
)


def _refuse_in_a_starting_worker() -> None:
    """A study asked for while a worker process imports the parent's main script (spawn and
    fork server workers do, before they take work: multiprocessing marks that phase
    ``_inheriting``, as its own check of the same mistake reads it): the script has no
    ``__main__`` guard. One short error instead of a study per worker (the parent then reports
    WORKER_DIED)."""
    if getattr(current_process(), "_inheriting", False):
        raise WorkerDied(
            "flexgen.sweep called while a worker process imports the main script: put the "
            'study under `if __name__ == "__main__":`'
        )


def _check_scene(scene: Scene) -> None:
    """SceneError for what a study does not solve: the exact reference model (Python, a
    different answer shape) and a tolerance (a mode selection per solve)."""
    if any(f.model.kind == "exact" for f in scene.flexures):
        raise SceneError("sweep: the exact model is a reference solver; study a chain model")
    from .select import scene_tolerance

    if scene_tolerance(scene) is not None:
        raise SceneError(
            "sweep: the scene asks for a tolerance, which chooses the modes per solve; give "
            "modes instead (flexgen select SCENE --tol T says which)"
        )


def _chunks(
    scene: Scene,
    study: Plan,
    size: int,
    estimate: bool,
    stress: bool,
    settings: SolverSettings | None,
) -> list[Chunk]:
    source = scene.editable_source()
    order = scene._kinds_in_order()
    solve_values = study.values[study.order]
    token = uuid.uuid4().hex
    return [
        Chunk(
            study=token,
            source=source,
            order=order,
            name=scene.name,
            settings=settings,
            keys=study.keys,
            targets=study.targets,
            values=solve_values[a:b],
            first=a,
            row_length=study.row_length,
            estimate=estimate,
            stress=stress,
        )
        for a, b in study.chunks(size)
    ]


Result = tuple[np.ndarray, list[tuple[str, str, str]]]


def _local(
    chunks: list[Chunk], workers: int, progress: bool | None, bar: Any, probe: bool
) -> list[Result]:
    """In this process, or in worker processes (started by a fork server where there is one,
    else spawned: both safe with threads, and the workers import flexgen once): asked for
    (``probe`` False, workers >= 2), or, with ``probe``, where the probe says the study is long
    enough. Interrupted (Ctrl-C), the workers are stopped before the interrupt goes on: they
    ignore it themselves, and would otherwise go on with every queued chunk while the process
    waits for them at exit."""
    start_up = START_UP_AGAIN if _pool_workers == min(workers, len(chunks)) else START_UP
    if workers == 1 or len(chunks) == 1 or (probe and _serial_time(chunks) < 2 * start_up):
        # in this process the progress is reported per case: a chunk of slow cases would
        # otherwise be minutes of silence
        return [run_chunk(chunk, bar.update) for chunk in chunks]
    if progress is None:  # long enough to show, when stderr is a terminal
        bar.enable()
    done: dict[int, Result] = {}
    pool = _pool(min(workers, len(chunks)))
    try:
        futures = {pool.submit(run_chunk, c): i for i, c in enumerate(chunks)}
        for future in as_completed(futures):
            i = futures[future]
            done[i] = future.result()
            bar.update(len(chunks[i].values))
    except BrokenProcessPool:
        _stop_pool()
        raise WorkerDied(WORKER_DIED) from None
    except BaseException:  # KeyboardInterrupt above all: the workers stop with the study
        _stop_pool()
        raise
    return [done[i] for i in range(len(chunks))]


# set by the flexgen sweep command (``own_process``): the process is flexgen's own (``_context``)
OWN_PROCESS = False


def own_process() -> None:
    """Say that this process is flexgen's own (the flexgen sweep command): its study workers
    may ignore Ctrl-C from their start (``_context``)."""
    global OWN_PROCESS
    OWN_PROCESS = True


_pool_executor: ProcessPoolExecutor | None = None
_pool_workers = 0


def _pool(workers: int) -> ProcessPoolExecutor:
    """The worker processes, kept for the session's next study (their imports and prepared
    scenes warm; concurrent.futures shuts them down at exit); a new pool for another size."""
    global _pool_executor, _pool_workers
    if _pool_executor is None or _pool_workers != workers:
        if _pool_executor is not None:
            _pool_executor.shutdown()
        _pool_executor = ProcessPoolExecutor(
            workers, mp_context=_context(), initializer=_leave_interrupts_to_the_parent
        )
        _pool_workers = workers
    return _pool_executor


def _leave_interrupts_to_the_parent() -> None:
    """A worker ignores Ctrl-C (a terminal sends it to the whole process group): a worker
    interrupted mid-chunk would report the interrupt as that chunk's error and go on with the
    next; the parent stops the workers instead (``_stop_pool``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _stop_pool() -> None:
    """Terminate the worker processes and forget the pool: its queued chunks are dropped and
    nothing waits for them at exit. (``ProcessPoolExecutor`` has no public way to end running
    workers before Python 3.14's ``terminate_workers``; its ``_processes`` map is where every
    version keeps them.)"""
    global _pool_executor, _pool_workers
    pool, _pool_executor, _pool_workers = _pool_executor, None, 0
    if pool is None:
        return
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        process.terminate()
    # dead before this process exits and its queues' semaphores go: a worker still starting
    # would otherwise find them gone and print a FileNotFoundError traceback (review)
    for process in processes:
        process.join(1.0)
    pool.shutdown(wait=False, cancel_futures=True)


def _context() -> Any:
    """The fork server (POSIX: ~0.4 s to start two workers with flexgen imported, against ~1 s
    spawned, and safe where a plain fork of a process with threads is not), else spawn."""
    try:
        ctx = get_context("forkserver")
    except ValueError:  # Windows
        return get_context("spawn")
    # where flexgen owns the process (flexgen sweep), its workers ignore Ctrl-C from their
    # start: first, before the slow imports (flexgen/_forkserver_preload.py). Not for a
    # program calling flexgen.sweep: the fork server is the program's, and its own children
    # would ignore Ctrl-C too (review)
    first = ["flexgen._forkserver_preload"] if OWN_PROCESS else []
    ctx.set_forkserver_preload([*first, "flexgen.sweep_chunk", "scipy.linalg"])
    if OWN_PROCESS:
        _start_fork_server_deaf()
    return ctx


def _start_fork_server_deaf() -> None:
    """Start the fork server (flexgen sweep's, ``_context``) with SIGINT blocked. The blocked
    mask passes through fork and exec, so a Ctrl-C while the server imports flexgen, before
    ``_forkserver_preload`` ignores SIGINT and unblocks it, stays pending there and is then
    dropped (review: a KeyboardInterrupt traceback from the server's imports, 1 s into a
    study); in this process it is delivered when the mask is restored: "interrupted"."""
    from multiprocessing import forkserver, resource_tracker

    # the fork server's start starts the resource tracker first, which unblocks SIGINT after
    # its own start: started here before the mask is set, it is not started again
    resource_tracker.ensure_running()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        forkserver.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _serial_time(chunks: list[Chunk], probes: int = 5) -> float:
    """The study's time on one core, roughly: a preparation of the scene times its designs plus
    a solve (with the estimate when asked for) times its cases. Timed after one warm-up solve
    (the first loads LAPACK and the kernels: a cost of the session, not of each design)."""
    first = chunks[0]
    scene = scene_from_dict(first.source, order=first.order, default_name=first.name)
    _solve_timed(Solver(scene, settings=first.settings), first, 1)
    start = time.perf_counter()
    solver = Solver(scene, settings=first.settings)
    solve = _solve_timed(solver, first, probes)
    prepare = time.perf_counter() - start - probes * solve
    design = [k for k, t in enumerate(first.targets) if t is None]
    designs = 0
    for chunk in chunks:
        v = chunk.values[:, design]
        designs += 1 + int(np.count_nonzero(np.any(v[1:] != v[:-1], axis=1))) if design else 1
    cases = sum(len(c.values) for c in chunks)
    return designs * prepare + cases * solve


def _solve_timed(solver: Solver, chunk: Chunk, probes: int) -> float:
    """Seconds per case: one cold solve, then warm ones from its answer (as most cases are),
    each with the estimate and the stress when the study asks for them."""
    start = time.perf_counter()
    q0 = None
    for _ in range(probes):
        status = solver.run(q0=q0)
        if chunk.estimate:
            estimate_answer(solver, status)
        if chunk.stress:
            stress_columns(solver, solver.workspace.q)
        q0 = {n: solver.workspace.q[sl].copy() for n, sl in solver.problem.chain.slices.items()}
    return (time.perf_counter() - start) / probes


def _on_dask(client: Any, chunks: list[Chunk], bar: Any) -> list[Result]:
    """One task per chunk on a Dask cluster, gathered in order."""
    from distributed import as_completed as dask_completed

    futures = client.map(run_chunk, chunks, pure=False)
    sizes = {f.key: len(c.values) for f, c in zip(futures, chunks)}
    for future in dask_completed(futures):
        bar.update(sizes[future.key])
    return list(client.gather(futures))


def _table(scene: Scene, study: Plan, results: Iterable[Result]) -> pd.DataFrame:
    import pandas as pd

    data = np.concatenate([r[0] for r in results])
    texts = [s for r in results for s in r[1]]
    # back from solve order to table order
    table = np.empty_like(data)
    table[study.order] = data
    why = np.empty((len(texts), len(TEXT_FIELDS)), dtype=object)
    if texts:
        why[study.order] = texts
    points = list(scene.output_points())
    flexures = [f.name for f in scene.flexures]
    cols: dict[str, Any] = {k: study.values[:, i] for i, k in enumerate(study.keys)}
    for k in study.keys:  # the counts a scene gives as integers (modes, elements) stay integers
        if k.rsplit(".", 1)[-1] in COUNT_KEYS and np.all(cols[k] == np.round(cols[k])):
            cols[k] = cols[k].astype(np.int64)
    cols["converged"] = table[:, 0] == 1.0
    cols["stable"] = table[:, 1] == 1.0
    cols["iterations"] = table[:, 2].astype(np.int64)
    for i, name in enumerate(TEXT_FIELDS):
        cols[name] = why[:, i]
    j = len(CASE_FIELDS)
    for p in points:
        for f in POINT_FIELDS:
            cols[f"{p}.{f}"] = table[:, j]
            j += 1
    for name in flexures:
        for f in FLEXURE_FIELDS:
            cols[f"{name}.{f}"] = table[:, j]
            j += 1
    df = pd.DataFrame(cols)
    units = result_units(scene)
    if units is not None:  # the numbers' units, as a Result's JSON gives them (kept by Parquet)
        df.attrs["units"] = units
    return df


# -- progress ---------------------------------------------------------------------------------


class _Silent:
    def update(self, n: int) -> None:
        pass

    def enable(self) -> None:
        pass

    def close(self) -> None:
        pass


class _Lines:
    """Plain lines for a log ("sweep: 4000/10000 cases, 2.1 s"), at most every PLAIN_EVERY."""

    def __init__(self, total: int, write: Callable[[str], Any]):
        self.total, self.done, self.write = total, 0, write
        self.start = self.last = time.perf_counter()

    def update(self, n: int) -> None:
        self.done += n
        now = time.perf_counter()
        if now - self.last >= PLAIN_EVERY or self.done >= self.total:
            self.last = now
            self.write(f"sweep: {self.done}/{self.total} cases, {now - self.start:.1f} s\n")

    def enable(self) -> None:
        pass

    def close(self) -> None:
        pass


class _Deferred:
    """A tqdm bar that appears only once enabled (progress=None: a long study on a terminal)."""

    def __init__(self, total: int, shown: bool):
        self.total, self.done = total, 0
        self.bar: Any = None
        if shown:
            self.enable()

    def enable(self) -> None:
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, unit="case", desc="sweep", file=sys.stderr)
            self.bar.update(self.done)

    def update(self, n: int) -> None:
        self.done += n
        if self.bar is not None:
            self.bar.update(n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _progress(progress: bool | None, total: int, interactive: bool) -> Any:
    terminal = sys.stderr is not None and sys.stderr.isatty()
    if progress is False or (progress is None and not terminal):
        return _Silent()
    if not terminal:
        return _Lines(total, sys.stderr.write)
    return _Deferred(total, shown=bool(progress) or interactive)
