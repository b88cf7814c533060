"""One run loop for every scene: it owns time, frames, series, progress, checkpoints, signals, the
run's status and the final write; the physics of a step comes from a *stepper*.

The stepper protocol (:class:`Stepper`) is what a terrain model gives the loop — the plain SPH
:class:`terrasph.Simulation` and the MuJoCo-coupled
:class:`terrasph.terrain.sph_coupling.CoupledSimulation` provide it:

* ``time`` (s) and ``step_count``;
* ``advance(t_end, max_steps) -> int``: at most `max_steps` steps toward `t_end` (the loop calls
  it in chunks of about :data:`CHUNK_SECONDS` of wall time so Ctrl-C and the progress bar stay
  responsive); a blow-up raises :class:`terrasph.InstabilityError`;
* ``checkpoint(path, progress)`` and ``restore(path) -> progress``: the whole state, bit for bit,
  with the loop's `progress` (plain data) beside it;
* ``frame_fields()``, ``static_arrays()``: the per-particle arrays of each frame (a terrain without
  grains, RFT's, gives its bodies' only; arrays of their own, not views of the state, since the
  loop keeps a frame until its batch is written) and those written
  once (``/frames``, ``/static``); ``diagnostics()``: one row of ``/series/diagnostics`` (the loop
  adds ``wall_time``); ``run_attributes()``: the particle counts and leak counter for ``/run``.

Series sampled every `sample_interval` come from *recorders* (:class:`Recorder`), registered by the
module that needs them (the bodies' and fixed walls' loads by terrasph.simulation, the robot's by
terrasph.robots.run): each returns one row per series group at every sample.

The output contract (docs/hdf5_schema.md), whatever the stepper: ``/run`` holds the status
(completed, at_rest, end_of_bed, interrupted, unstable or failed) with the time, steps, wall time
and leak counter reached (and the reason of a run its `end_check` ended early); the XDMF sidecars
are written however the run ends; every run but an unstable or failed one leaves a checkpoint
(:func:`checkpoint_path`) from which ``resume=True`` continues it, bitwise the longer run: an
interrupted run from where it stopped, a finished one from the start of
its last stretch (the step that lands on the end time is cut short, so the state at the end time
is not on the longer run's path, the state before that stretch is).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import os
import pathlib
import signal
import sys
import threading
import time as wallclock
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from terrasph.config import ConfigError

__all__ = ["BUILD_QUIET_SECONDS", "CHUNK_SECONDS", "END_OF_BED", "FINISHED_STATUSES", "SERIES_WRITE_SECONDS",
           "LoopResult", "Recorder", "RunLoop", "Stepper", "StopRequest", "building_scene", "check_end_time",
           "check_run_options", "checkpoint_path", "claimed_output", "lock_path", "output_lock", "recorded_end",
           "simulated_time_bar"]

#: Wall time (s) between writes of the frames and the series' rows into the run file (and before every
#: checkpoint, on a stop and at the end, so a checkpoint's frame and row counts are what the file holds):
#: a write costs a resize, a write per dataset and a flush, 2.8 ms per series group and 0.4 ms per frame
#: on the leg-wheel, which written on every frame (20 a simulated second) cost several times RFT's
#: stepping (benchmarks/performance/bench_run_overhead.py). A reader of a running file sees its first
#: frame at once, later frames and series up to this far behind; a killed run loses only what came after its checkpoint, which a
#: resumed run rewrites.
SERIES_WRITE_SECONDS = 1.0

#: Wall time (s) one call into the stepper may take, so Ctrl-C and the progress bar stay responsive
#: however slow a step is; the steps per call follow from the last call's seconds per step.
CHUNK_SECONDS = 0.2
MAX_STEPS_PER_CHUNK = 500
#: the status of a robot's run that ended where its bed ends (terrasph.robots.run.BedEnds)
END_OF_BED = "end_of_bed"
#: the statuses of a run that reached its end: its end time, a state at rest, or (a robot) the end of its bed
FINISHED_STATUSES = ("completed", "at_rest", END_OF_BED)
#: a scene build quieter than this (s of wall time) shows nothing; a longer one a status line
BUILD_QUIET_SECONDS = 2.0

#: the status line of the scene being built (:func:`building_scene`), ended by the run loop when it starts
_BUILD_STATUS: contextvars.ContextVar[Callable[[], None] | None] = contextvars.ContextVar("terrasph_build_status",
                                                                                          default=None)


class Stepper(Protocol):
    """What a terrain model gives the run loop (module docstring)."""

    @property
    def time(self) -> float: ...

    @property
    def step_count(self) -> int: ...

    def advance(self, t_end: float, max_steps: int) -> int: ...

    def checkpoint(self, path: str | os.PathLike[str], progress: dict[str, Any] | None = None) -> pathlib.Path: ...

    def restore(self, path: str | os.PathLike[str]) -> dict[str, Any]: ...

    def frame_fields(self) -> dict[str, np.ndarray]: ...

    def static_arrays(self) -> dict[str, np.ndarray]: ...

    def diagnostics(self) -> dict[str, float]: ...

    def run_attributes(self) -> dict[str, int]: ...


class Recorder(Protocol):
    """A source of time series: at each sample, one row (name → scalar or vector) per group."""

    def rows(self) -> dict[str, dict[str, Any]]: ...


def checkpoint_path(output: str | os.PathLike[str]) -> pathlib.Path:
    """Where a run writing `output` keeps its checkpoint: ``run.h5`` → ``run.checkpoint.h5``."""
    path = pathlib.Path(output)
    return path.with_name(path.stem + ".checkpoint.h5")


def check_run_options(intervals: dict[str, float], checkpoint_every: float | None, resume: bool,
                      output: str | os.PathLike[str] | None) -> None:
    """ConfigError naming the first bad option of a run: every interval > 0 s, `checkpoint_every`
    > 0 s or None, `resume` only with an `output`."""
    for name, value in intervals.items():
        if not value > 0:
            raise ConfigError(f"parameter '{name}' = {value} is invalid: allowed > 0 s")
    if checkpoint_every is not None and not checkpoint_every > 0:
        raise ConfigError(f"parameter 'checkpoint_every' = {checkpoint_every} is invalid: allowed > 0 s or None")
    if resume and output is None:
        raise ConfigError("parameter 'resume' needs 'output', the file of the run to continue")


def lock_path(output: str | os.PathLike[str]) -> pathlib.Path:
    """The lock file a run writing `output` holds: ``run.h5`` → ``run.h5.lock``."""
    path = pathlib.Path(output)
    return path.with_name(path.name + ".lock")


@contextlib.contextmanager
def output_lock(output: str | os.PathLike[str]) -> Iterator[None]:
    """Holds the lock of `output` (:func:`lock_path`) for the block: the lock file is created if need
    be, locked exclusively (``flock``: the lock ends with the process, so a killed run's lock file is
    no obstacle) and given this run's pid, host and start time; removed at the end. While another
    live run holds it, FileExistsError names that run, in one line, whatever ``--force`` says."""
    import datetime
    import fcntl
    import json
    import socket

    path = lock_path(output)
    while True:
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(descriptor, 4096).decode("utf-8", "replace")
            os.close(descriptor)
            try:
                other = json.loads(holder)
                who = f"pid {other['pid']} on {other['host']}, started {other['started']}"
            except (ValueError, KeyError, TypeError):
                who = "its lock is being written"
            raise FileExistsError(f"--out {output}: another run is writing it ({who}); wait for it to end or stop "
                                  f"it, then rerun") from None
        except OSError as error:  # a filesystem without locks (ENOLCK, EOPNOTSUPP): run, but say so
            import warnings

            warnings.warn(f"{path}: cannot lock it ({error.strerror}); a second run into {output} would not be "
                          "refused", RuntimeWarning, stacklevel=3)
        try:  # the file locked is still the one at `path` (not one a finishing run just removed)
            same = os.path.samestat(os.fstat(descriptor), os.stat(path))
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(descriptor)
    try:
        started = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        os.ftruncate(descriptor, 0)
        os.write(descriptor, json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                                         "started": started}).encode())
        yield
    finally:
        path.unlink(missing_ok=True)  # before the lock ends, so a waiting run locks a new file
        os.close(descriptor)


@contextlib.contextmanager
def claimed_output(output: str | os.PathLike[str], force: bool) -> Iterator[pathlib.Path]:
    """Claims `output` for one run before any work: its lock (:func:`output_lock`) refuses a second
    run while one writes it, even with `force`; the file is then created exclusively (``O_EXCL``).
    Without `force` an existing file, or a stale checkpoint beside it, is refused; with `force` both
    are replaced. An empty file no live run holds (the claim of a run killed before it wrote
    anything) is no obstacle. If the run fails or is stopped before writing its file (say, a scene
    the spacing cannot build, or Ctrl-C while it is built), the empty claim is removed again."""
    from terrasph.cli_common import check_output_file

    path = pathlib.Path(output)
    checkpoint = checkpoint_path(path)
    check_output_file(path, force=True)  # its directory exists and it is not a directory
    with output_lock(path):
        if path.is_file() and path.stat().st_size == 0:  # a dead run's claim: nothing in it
            path.unlink()
        if force:
            path.unlink(missing_ok=True)
            checkpoint.unlink(missing_ok=True)
        elif checkpoint.exists():
            raise FileExistsError(f"--out {path}: its checkpoint {checkpoint.name} exists (use --force to replace it)")
        try:
            os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
        except FileExistsError:
            raise FileExistsError(f"--out {path}: file exists (use --force to replace it)") from None
        try:
            yield path
        except BaseException:
            if path.is_file() and path.stat().st_size == 0:  # still the claim: the run wrote nothing
                path.unlink()
            raise


def simulated_time_bar(total: float, progress: bool) -> Any:
    """A progress bar over `total` seconds of simulated time (tqdm's), or, unless `progress`, a bar
    that shows nothing (:class:`_HiddenBar`: no tqdm to import, ~25 ms, for a run that shows none)."""
    if not progress:
        return _HiddenBar(round(total, 9))
    from tqdm.auto import tqdm

    return tqdm(total=round(total, 9), unit="s", mininterval=0.5,
                bar_format="{l_bar}{bar}| {n:.3f}/{total:.3f} s simulated [{elapsed}<{remaining}]{postfix}")


@dataclass
class _HiddenBar:
    """The members of a tqdm bar a run loop uses, showing nothing."""

    total: float
    n: float = 0.0

    def update(self, amount: float) -> None:
        self.n += amount

    def set_postfix(self, **values: Any) -> None:
        """Shows nothing."""

    def refresh(self) -> None:
        """Shows nothing."""

    def close(self) -> None:
        """Shows nothing."""


def _raise_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def recorded_end(output: str | os.PathLike[str]) -> tuple[str | None, float | None, float | None]:
    """The status, the simulated time reached and the end time aimed at of the run in `output`, as its
    ``/run`` group records them (each None if not recorded: the run file of an older version has no
    end time, one still being written no status)."""
    import h5py

    with h5py.File(output, "r") as file:
        attrs = dict(file["run"].attrs) if "run" in file else {}
    status, reached, end = attrs.get("status"), attrs.get("time"), attrs.get("t_end")
    return (None if status is None else str(status), None if reached is None else float(reached),
            None if end is None else float(end))


def check_end_time(t_end: float, reached: float, name: str = "t_end") -> None:
    """ConfigError unless the end time `t_end` lies after the time `reached` by the run to continue
    (the time its file records, the one ``terrasph info`` prints, not its checkpoint's, which may be
    before it)."""
    if not t_end > reached:
        raise ConfigError(f"parameter '{name}' = {t_end!r} is invalid: allowed > the time the run reached, "
                          f"t = {reached:.6g} s")


@contextlib.contextmanager
def building_scene(progress: bool, what: str = "the scene") -> Iterator[None]:
    """The time before a run loop starts (building the scene): SIGINT and SIGTERM raise
    KeyboardInterrupt, also where the process was started with SIGINT ignored (a shell's background
    job), so a build of minutes stops at once and the callers' cleanup runs (an empty output claim
    removed); with `progress`, once the build has taken BUILD_QUIET_SECONDS, a status line on stderr
    says what is built and for how long, until the run loop's own bar starts (or the block ends)."""
    finished = threading.Event()
    started = wallclock.monotonic()

    def show() -> None:
        if finished.wait(BUILD_QUIET_SECONDS):
            return
        tty = sys.stderr.isatty()
        while True:
            line = f"terrasph: building {what}: {wallclock.monotonic() - started:.0f} s (Ctrl-C stops it)"
            sys.stderr.write(f"\r{line}" if tty else f"{line}\n")
            sys.stderr.flush()
            if finished.wait(1.0 if tty else 10.0):
                if tty:
                    sys.stderr.write(f"\rterrasph: built {what} in {wallclock.monotonic() - started:.0f} s"
                                     + " " * 20 + "\n")
                return

    watcher = threading.Thread(target=show, daemon=True) if progress else None

    def end() -> None:
        finished.set()
        if watcher is not None and watcher.is_alive():
            watcher.join()

    previous = {}
    if threading.current_thread() is threading.main_thread():
        previous = {sig: signal.signal(sig, _raise_interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}
    token = _BUILD_STATUS.set(end)
    if watcher is not None:
        watcher.start()
    try:
        yield
    finally:
        end()
        _BUILD_STATUS.reset(token)
        for sig, handler in previous.items():
            signal.signal(sig, handler)


class StopRequest:
    """Turns SIGINT and SIGTERM into a request that the run loop honours at the next step
    boundary, so a stop never lands in the middle of writing a frame or a checkpoint; a second
    Ctrl-C stops at once. Outside the main thread (where Python cannot install handlers) signals
    keep their default behaviour."""

    def __init__(self) -> None:
        self.requested = False

    @contextlib.contextmanager
    def catching_signals(self) -> Iterator[None]:
        """Installs the handlers for the duration of the block."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return

        def request(signum: int, frame: object) -> None:
            if self.requested:  # a second Ctrl-C: stop now
                raise KeyboardInterrupt
            self.requested = True

        previous = {sig: signal.signal(sig, request) for sig in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


@dataclass
class LoopResult:
    """How a run ended and what it recorded: the whole run's series by group (a resumed run's
    included), each ``{name: array}``."""

    time: float
    steps: int
    wall_time: float
    frames: int
    status: str
    series: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)


@dataclass
class RunLoop:
    """Runs a :class:`Stepper` to an end time, writing the run file `output` (None: nothing
    written) — frames every `frame_interval` s, the recorders' series every `sample_interval` s —
    and checkpointing every `checkpoint_every` s of wall time (None: only at the end). `at_rest`,
    given a frame's diagnostics row, ends the run early (status ``at_rest``); `end_check`, asked on
    each frame, ends it early when it returns a (status, reason) pair (a status of
    :data:`FINISHED_STATUSES`; the reason goes to ``/run``); `on_frame` is called after each frame."""

    stepper: Stepper
    output: str | os.PathLike[str] | None = None
    frame_interval: float = 0.05
    sample_interval: float = 0.01
    recorders: Sequence[Recorder] = ()
    config: Mapping[str, Any] = field(default_factory=dict)
    versions: Mapping[str, str] = field(default_factory=dict)
    checkpoint_every: float | None = 600.0
    progress: bool = False
    at_rest: Callable[[dict[str, float]], bool] | None = None
    on_frame: Callable[[], None] | None = None
    end_check: Callable[[], tuple[str, str] | None] | None = None

    def run(self, t_end: float, resume: bool = False) -> LoopResult:
        """Runs to `t_end` (s); ``resume=True`` continues the run in `output` from its checkpoint
        (frames and rows written after it are dropped, so each appears once). Ctrl-C or SIGTERM
        ends the run at the next step boundary with its last frame, a checkpoint and status
        ``interrupted``, then raises KeyboardInterrupt (a second Ctrl-C stops it at once, without
        either: it then continues from its last checkpoint); an InstabilityError or any other error is
        recorded (``unstable``, ``failed``) before it propagates."""
        from terrasph import _core
        from terrasph.sidecar_views import SidecarViews
        from terrasph.threads import LoadWatch

        check_run_options({"frame_interval": self.frame_interval, "sample_interval": self.sample_interval},
                          self.checkpoint_every, resume, self.output)
        end_of_build = _BUILD_STATUS.get()
        if end_of_build is not None:
            end_of_build()  # the scene is built: the run's own bar follows
        stepper = self.stepper
        reached = recorded_end(self.output)[1] if resume else None  # before the run file is reopened
        saved = stepper.restore(checkpoint_path(self.output)) if resume else {}
        check_end_time(t_end, stepper.time if reached is None else max(reached, stepper.time))
        writer = self._open_writer(saved, resume)
        sampled = bool(self.recorders)
        series: dict[str, list[dict[str, Any]]] = {}  # each group's rows of this run, in order
        series_rows: dict[str, int] = dict(saved.get("series_rows", {}))
        frames = saved.get("frames", 0)
        start = wallclock.perf_counter() - saved.get("wall_time", 0.0)
        if resume:
            next_frame, next_sample = saved["next_frame"], saved["next_sample"]
        else:
            next_frame = stepper.time + self.frame_interval
            next_sample = stepper.time + self.sample_interval if sampled else math.inf

        # when the leak counter first rose above 0 (a frame's time), warned of once and kept in /run
        leak: dict[str, float] = {"first_leak_time": saved["first_leak_time"]} if "first_leak_time" in saved else {}
        written: dict[str, int] = {}  # each group's rows of `series` written to the file, the rest in the next batch
        unwritten_frames: list[tuple[float, int, dict[str, np.ndarray]]] = []  # frames since it, likewise
        last_write = -math.inf  # the run's first frame is written at once: a reader sees the run has begun

        def append(group: str, row: dict[str, Any]) -> None:
            series.setdefault(group, []).append(row)
            if writer:
                series_rows[group] = series_rows.get(group, 0) + 1

        def write_pending() -> None:
            """The frames and rows recorded since the last call into the file (all frames one write,
            each group one): every SERIES_WRITE_SECONDS on a frame, before every checkpoint, on a stop
            and at the end, so `frames` and `series_rows` are what is written."""
            nonlocal last_write
            batch = list(unwritten_frames)
            groups = {group: rows[written.get(group, 0):] for group, rows in series.items()}
            unwritten_frames.clear()  # before the writes: a batch that fails is not written again at the end
            written.update({group: len(rows) for group, rows in series.items()})
            if writer:
                writer.write_frames(batch)
                for group, rows in groups.items():
                    if rows:
                        writer.append_series_rows(group, rows)
            last_write = wallclock.perf_counter()

        def add_frame() -> None:
            """The stepper's frame now, written with the next batch (write_pending)."""
            nonlocal frames
            unwritten_frames.append((stepper.time, stepper.step_count, stepper.frame_fields()))
            frames += 1

        def record_frame() -> dict[str, float]:
            row = {"time": stepper.time, **stepper.diagnostics(), "wall_time": wallclock.perf_counter() - start}
            if writer:
                add_frame()
            append("diagnostics", row)
            if row.get("leaked_particles", 0) > 0 and not leak:
                leak["first_leak_time"] = stepper.time
                warnings.warn(f"{int(row['leaked_particles'])} grain(s) came inside a wall or body (closer than Δx/2 "
                              f"to its interior particles) by t = {stepper.time:.4g} s: a leak, counted as "
                              "leaked_particles in the run file (a part too thin for its load, or too coarse a "
                              "spacing); the run goes on", RuntimeWarning, stacklevel=2)
            if wallclock.perf_counter() - last_write >= SERIES_WRITE_SECONDS:
                write_pending()
            if self.on_frame:
                self.on_frame()
            return row

        def record_sample() -> None:
            for recorder in self.recorders:
                for group, row in recorder.rows().items():
                    append(group, row)

        def save_checkpoint() -> None:
            write_pending()
            if writer:
                stepper.checkpoint(checkpoint_path(self.output), {
                    "t_end": t_end, "next_frame": next_frame, "next_sample": next_sample, "frames": frames,
                    "series_rows": series_rows, "wall_time": wallclock.perf_counter() - start, **leak})

        def record_end(status: str, **extra: Any) -> None:
            """The final /run attributes, the file closed and its XDMF sidecars, however the run ends
            (those of a finished run with the views its helper made: terrasph.sidecar_views)."""
            from terrasph.io import write_xdmf

            if not writer:
                return
            write_pending()
            writer.set_attrs("/run", {"status": status, "t_end": t_end, "wall_time": wallclock.perf_counter() - start,
                                      "steps": stepper.step_count, "time": stepper.time,
                                      **stepper.run_attributes(), **leak, **extra})
            writer.close()
            views_made = 0
            if views is not None:
                if status in FINISHED_STATUSES:
                    views_made = views.finish()
                else:  # an interrupted or failed run ends at once, with the frames it has
                    views.stop()
            if frames:
                write_xdmf(self.output, views_made=views_made)

        def start_views() -> SidecarViews | None:
            """The helper that makes the sidecars' views of the frames this run plans while it
            steps (terrasph.sidecar_views), once the run file has its first frame."""
            if not writer or not frames:
                return None
            planned = frames + max(0, math.ceil((t_end - next_frame) / self.frame_interval - 1e-9)) + 1
            return SidecarViews.start(self.output, writer.frame_shapes, planned)

        t_start = stepper.time
        bar = simulated_time_bar(t_end - t_start, self.progress)
        chunk_steps = 1  # steps per call into the stepper, adapted to CHUNK_SECONDS of wall time
        load_watch = LoadWatch(_core.set_num_threads, _core.get_max_threads)
        final_stretch_saved = False
        status = "completed"
        ended: dict[str, str] = {}  # the reason of an early end by end_check
        at_step_boundary = False  # a second Ctrl-C may stop the run anywhere, even inside a step
        stop = StopRequest()
        views: SidecarViews | None = None
        try:  # the sidecars' helper ends with the run, however it ends
            try:
                with stop.catching_signals():
                    if not resume:
                        record_frame()
                        if sampled:
                            record_sample()
                    views = start_views()
                    last_checkpoint = wallclock.perf_counter()
                    last_step = 0.0  # the simulated time of the last step taken (s)
                    end_time = t_end * (1 - 1e-14)  # a time this close to t_end is the end (rounding of sums)
                    now, steps_now = stepper.time, stepper.step_count  # read once per call into the stepper
                    while now < end_time:
                        target = min(next_frame, next_sample, t_end)
                        # the stretch that reaches the end: a frame or sample time summed to within rounding
                        # of t_end ends the run as t_end itself does (at_end below); or a step that may carry
                        # past t_end before the target does (samples closer than a step: twice the last
                        # step, the step bound's growth between steps being far less)
                        if not final_stretch_saved and (target >= end_time or now + 2.0 * last_step >= t_end):
                            save_checkpoint()  # the last state on the path of a longer run (module docstring)
                            final_stretch_saved = True
                        load_watch.follow()
                        started, steps_before, time_before = wallclock.perf_counter(), steps_now, now
                        stepper.advance(target, chunk_steps)
                        elapsed = wallclock.perf_counter() - started
                        now, steps_now = stepper.time, stepper.step_count
                        taken = max(1, steps_now - steps_before)
                        last_step = (now - time_before) / taken
                        chunk_steps = max(1, min(MAX_STEPS_PER_CHUNK, int(CHUNK_SECONDS / max(elapsed / taken, 1e-9))))
                        if self.progress:  # the bar shows simulated time, never past its total (the last step may end past t_end)
                            bar.update(min(bar.total, round(now - t_start, 9)) - bar.n)
                            bar.set_postfix(steps=steps_now, refresh=False)
                        at_end = now >= end_time
                        if now >= next_sample * (1 - 1e-12) or (sampled and at_end):
                            record_sample()
                            next_sample += self.sample_interval
                        if now >= next_frame * (1 - 1e-12) or at_end:
                            row = record_frame()
                            next_frame += self.frame_interval
                            if self.at_rest is not None and self.at_rest(row):
                                status = "at_rest"
                                save_checkpoint()  # a stop on a frame: the longer run's path
                                break
                            early_end = self.end_check() if self.end_check is not None else None
                            if early_end is not None:
                                status, ended["reason"] = early_end
                                save_checkpoint()
                                break
                            now, steps_now = stepper.time, stepper.step_count  # as a frame's callback may have left them
                        if at_end:  # no checkpoint here: the end state is off a longer run's path
                            break
                        if stop.requested:
                            at_step_boundary = True
                            raise KeyboardInterrupt
                        if self.checkpoint_every is not None and \
                                wallclock.perf_counter() - last_checkpoint >= self.checkpoint_every:
                            save_checkpoint()
                            last_checkpoint = wallclock.perf_counter()
            except KeyboardInterrupt:
                bar.close()
                if writer and at_step_boundary:
                    save_checkpoint()  # before the extra frame below, which a resumed run drops
                    add_frame()
                # stopped inside a step, the run continues from its last checkpoint, if it has one
                resumable = writer is not None and checkpoint_path(self.output).is_file()
                record_end("interrupted", **({"checkpoint": checkpoint_path(self.output).name} if resumable else {}))
                raise
            except _core.InstabilityError as error:
                bar.close()
                record_end("unstable", message=str(error), step=error.step, particle=error.particle, time=error.time)
                raise
            except Exception as error:
                bar.close()
                if writer and not writer.closed:
                    record_end("failed", message=f"{type(error).__name__}: {error}")
                raise
            bar.total = bar.n  # a run that ends early (at rest) ends its bar at 100 %
            bar.refresh()
            bar.close()
            record_end(status, **ended, **({"checkpoint": checkpoint_path(self.output).name} if writer else {}))
        finally:
            if views is not None:
                views.stop()
        if resume:  # the whole run's series, not only the resumed part
            from terrasph.io import read_run

            whole = read_run(self.output)
            return LoopResult(stepper.time, stepper.step_count, wallclock.perf_counter() - start, whole.n_frames,
                              status, whole.series)
        arrays = {group: {key: np.asarray([row[key] for row in rows]) for key in rows[0]}
                  for group, rows in series.items()}
        return LoopResult(stepper.time, stepper.step_count, wallclock.perf_counter() - start, frames, status, arrays)

    def _open_writer(self, saved: dict[str, Any], resume: bool) -> Any:
        """The run file's writer: reopened at the checkpoint's frame and row counts, or created (an
        earlier run's checkpoint beside it removed) with the configuration, versions and static
        arrays; None without an output."""
        from terrasph.io import RunWriter

        if self.output is None:
            return None
        if resume:
            return RunWriter.reopen(self.output, frames=saved["frames"], series_rows=saved["series_rows"])
        writer = RunWriter(self.output, self.config, versions=self.versions)
        checkpoint_path(self.output).unlink(missing_ok=True)  # an earlier run's, which this file no longer is
        for name, values in self.stepper.static_arrays().items():
            writer.write_static(name, values)
        return writer

