"""Runs the cases of a sweep on Dask: resumable, atomic run files, failures recorded, a manifest.

Layout of a sweep directory::

    runs/<case_id>.h5          a finished run (appears by rename once the run is complete)
    runs/<case_id>.json        its record: varied values, configuration, status, error, wall time,
                               versions, worker
    manifest.json              the SPEC and every case's record (rewritten after each case)
    events.jsonl               one line per event: submitted (client), started, then, for a robot
                               run that starts after its pause, settled (it settled the pause and
                               cached it) or started_from_cache (it found it), with the cache key
                               (terrasph.settle_cache), then finished or failed (worker, after the
                               run file and its record are in place), with the session (one
                               invocation) that caused it

A case counts as finished only if ``runs/<case_id>.h5`` opens as HDF5 and its ``/run`` status is
finished (terrasph.run_loop.FINISHED_STATUSES: completed, at_rest, end_of_bed); anything else (no
file, a partial or corrupted file, a failed run) is run again by the next invocation. A worker runs
in ``runs/<case_id>.partial/`` and moves the run file and the files beside it (figure, XDMF
sidecars) into ``runs/``, the run file last.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import socket
import time
import traceback
import uuid
from pathlib import Path
from typing import Any

from terrasph.run_loop import FINISHED_STATUSES
from terrasph.sweeps.spec import Case, SweepSpec

__all__ = ["check_shared_output", "is_finished", "probe_output", "run_one", "run_sweep"]


def _write_json_atomically(path: Path, data: Any) -> None:
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    temporary.write_text(json.dumps(data, indent=1, sort_keys=True))
    os.replace(temporary, path)


def log_event(out_dir: Path, session: str, event: str, case_id: str, **details: Any) -> None:
    """Appends one line to ``events.jsonl`` (one write on an O_APPEND file: lines of concurrent
    workers do not interleave), with any `details` (plain data) beside the event."""
    line = json.dumps({"session": session, "event": event, "case": case_id, "time": time.time(), **details}) + "\n"
    descriptor = os.open(out_dir / "events.jsonl", os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(descriptor, line.encode())
    finally:
        os.close(descriptor)


def run_file(out_dir: Path, case: Case) -> Path:
    """Where the finished run of `case` lies."""
    return out_dir / "runs" / f"{case.case_id}.h5"


def is_finished(path: Path) -> bool:
    """Whether `path` is a complete run file (opens as HDF5, ``/run`` status finished)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            status = f["run"].attrs.get("status") if "run" in f else None
    except (OSError, KeyError):
        return False
    return (status.decode() if isinstance(status, bytes) else status) in FINISHED_STATUSES


def run_one(scene: str, case: Case, out_dir: str, omp_threads: int, session: str) -> dict[str, Any]:
    """Runs one case on this process (a Dask worker) with `omp_threads` OpenMP threads; returns its
    record. Any exception of the run is recorded with its message, never raised."""
    from terrasph.scenes import run_case
    from terrasph.simulation import versions
    from terrasph.threads import use_threads

    use_threads(omp_threads)
    final = run_file(Path(out_dir), case)
    staging = final.with_name(f"{case.case_id}.partial")  # the run and the files beside it, until finished
    partial = staging / final.name
    record: dict[str, Any] = {"case_id": case.case_id, "varied": case.varied, "config": case.config,
                              "worker": f"{socket.gethostname()}:{os.getpid()}", "omp_threads": omp_threads,
                              "versions": versions()}
    log_event(Path(out_dir), session, "started", case.case_id)
    start = time.perf_counter()
    try:
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir()
        summary = run_case(scene, case.config, partial)
        if not is_finished(partial):
            raise RuntimeError(f"the run of {scene} ended without a finished /run status in its file")
        _log_settled_start(Path(out_dir), session, case.case_id, partial)
        _publish(staging, final)
        record.update(status="completed", summary=summary)
    except Exception as error:
        shutil.rmtree(staging, ignore_errors=True)
        record.update(status="failed", error=f"{type(error).__name__}: {error}",
                      traceback=traceback.format_exc(limit=4))
    record["wall_time"] = time.perf_counter() - start
    _write_json_atomically(final.with_suffix(".json"), record)
    log_event(Path(out_dir), session, "finished" if record["status"] == "completed" else "failed", case.case_id)
    return record


def probe_output(out_dir: str, token: str) -> dict[str, str]:
    """Run on a worker: writes ``<out_dir>/.probe-<token>`` holding `token`, reads it back and says
    where it ran; an OSError is returned as its message (the file then is not there)."""
    where = f"{socket.gethostname()}:{os.getpid()}"
    path = Path(out_dir) / f".probe-{token}"
    try:
        path.write_text(token)
        if path.read_text() != token:
            return {"worker": where, "error": f"read back other contents from {path}"}
    except OSError as error:
        return {"worker": where, "error": f"{type(error).__name__}: {error}"}
    return {"worker": where, "error": ""}


def check_shared_output(client: Any, out_dir: Path, scheduler: str) -> None:
    """Before any case: a probe task on every worker of the cluster at `scheduler` writes a file under
    `out_dir` (:func:`probe_output`) and this client reads it back. ConfigError in one line naming
    the first worker that cannot write there, or whose file this client cannot see (its OUT is on
    another file system): the runs would land on the workers' disks and the manifest point at nothing."""
    from terrasph.config import ConfigError

    workers = sorted(client.scheduler_info()["workers"])
    if not workers:
        raise ConfigError(f"--scheduler {scheduler}: the cluster has no workers")
    tokens = {address: uuid.uuid4().hex for address in workers}
    futures = {address: client.submit(probe_output, str(out_dir), token, workers=[address],
                                      allow_other_workers=False, pure=False, key=f"probe-{token}")
               for address, token in tokens.items()}
    try:
        for address, future in futures.items():
            answer = future.result()
            seen = out_dir / f".probe-{tokens[address]}"
            if answer["error"]:
                raise ConfigError(f"--scheduler {scheduler}: worker {address} ({answer['worker']}) cannot write the "
                                  f"sweep directory {out_dir}: {answer['error']}; give a directory on a file "
                                  "system every worker and this client share")
            if not (seen.is_file() and seen.read_text() == tokens[address]):
                raise ConfigError(f"--scheduler {scheduler}: worker {address} ({answer['worker']}) wrote {seen} "
                                  "but this client does not see it: the sweep directory must be on a file system "
                                  "every worker and this client share")
    finally:
        for token in tokens.values():
            (out_dir / f".probe-{token}").unlink(missing_ok=True)


def _log_settled_start(out_dir: Path, session: str, case_id: str, path: Path) -> None:
    """The event of a run that started after a cached pause (terrasph.settle_cache): ``settled`` (it
    settled and cached it) or ``started_from_cache``, with the cache key; nothing for other runs."""
    import h5py

    with h5py.File(path, "r") as f:
        event, key = f.attrs.get("settled_state_event"), f.attrs.get("settled_state_key")
    if event is not None:
        log_event(out_dir, session, "settled" if event == "settled" else "started_from_cache", case_id, key=str(key))


def _publish(staging: Path, final: Path) -> None:
    """Moves a finished case's files from its staging directory beside `final` under the names the
    run gave them (its figure, its XDMF sidecars, which name the run file relative to themselves),
    the run file last, so a case is finished only once all its files are in place. Its checkpoint
    is dropped: a sweep's cases are run again, not continued."""
    from terrasph.run_loop import checkpoint_path

    checkpoint_path(staging / final.name).unlink(missing_ok=True)
    for produced in sorted(staging.iterdir()):
        if produced.name != final.name:
            os.replace(produced, final.parent / produced.name)
    os.replace(staging / final.name, final)
    staging.rmdir()


def _pending(spec: SweepSpec, out_dir: Path) -> tuple[list[Case], dict[str, dict[str, Any]]]:
    """The cases to run and the records of the finished ones (a finished file without a readable
    record gets a minimal one)."""
    pending, records = [], {}
    for case in spec.cases:
        path = run_file(out_dir, case)
        if is_finished(path):
            try:
                records[case.case_id] = json.loads(path.with_suffix(".json").read_text())
            except (OSError, ValueError):
                records[case.case_id] = {"case_id": case.case_id, "varied": case.varied, "config": case.config,
                                         "status": "completed"}
        else:
            pending.append(case)
    return pending, records


def run_sweep(spec: SweepSpec, out_dir: str | os.PathLike[str], *, workers: int = 1, threads_per_worker: int = 1,
              scheduler: str | None = None, progress: bool = True) -> dict[str, Any]:
    """Runs the cases of `spec` not yet finished in `out_dir` on Dask — a LocalCluster of `workers`
    process workers (one task each at a time) unless `scheduler` names an existing cluster — with
    `threads_per_worker` OpenMP threads per run. Writes and returns the manifest. On an existing
    cluster every worker must write `out_dir` where this client reads it (a shared file system,
    the same absolute path): :func:`check_shared_output` refuses the sweep before any case otherwise."""
    from dask.distributed import Client, LocalCluster, as_completed

    if progress:
        from tqdm.auto import tqdm
    else:  # tqdm.auto warns about missing notebook widgets even for a disabled bar
        from tqdm import tqdm

    for name, value in (("workers", workers), ("threads_per_worker", threads_per_worker)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"parameter '{name}' = {value!r} is invalid: allowed an integer >= 1")
    out = Path(out_dir).resolve()  # the workers may start elsewhere: they get the absolute path
    (out / "runs").mkdir(parents=True, exist_ok=True)
    pending, records = _pending(spec, out)
    session = uuid.uuid4().hex[:8]

    def write_manifest() -> dict[str, Any]:
        cases = [records.get(c.case_id, {"case_id": c.case_id, "varied": c.varied, "config": c.config,
                                         "status": "pending"}) for c in spec.cases]
        manifest = {"spec": spec.as_dict(), "cases": cases,
                    "counts": {s: sum(c["status"] == s for c in cases) for s in ("completed", "failed", "pending")}}
        _write_json_atomically(out / "manifest.json", manifest)
        return manifest

    write_manifest()
    # silence_logs: Dask's own INFO/WARNING lines (e.g. a worker slow to stop on a busy machine) stay out;
    # the scheduler's HTTP server on a free port (":0"): with None it still takes 8787 and warns when a
    # second sweep or a notebook's runs beside it (the chapter 4 notebook's test failed so, 2026-12-05)
    cluster = None if scheduler else LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                  dashboard_address=":0", silence_logs=logging.ERROR)
    try:
        with Client(scheduler or cluster) as client:
            if scheduler:
                check_shared_output(client, out, scheduler)
            futures = []
            for case in pending:
                futures.append(client.submit(run_one, spec.scene, case, str(out), threads_per_worker, session,
                                             key=f"sweep-{session}-{case.case_id}", pure=False))
                log_event(out, session, "submitted", case.case_id)
            bar = tqdm(total=len(spec.cases), initial=len(spec.cases) - len(pending), unit="run",
                       disable=not progress, desc=f"sweep {spec.scene}")
            for future in as_completed(futures):
                record = future.result()
                records[record["case_id"]] = record
                write_manifest()
                bar.update(1)
                failed = sum(r["status"] == "failed" for r in records.values())
                bar.set_postfix(failed=failed)
            bar.close()
    finally:
        if cluster is not None:
            cluster.close()
    return write_manifest()
