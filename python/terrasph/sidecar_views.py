"""The per-set XDMF sidecars' virtual datasets made while a run steps, by a child interpreter on
another core (:class:`SidecarViews`).

A run's sidecars that meshio reads (:func:`terrasph.io.write_xdmf_sets`) hold a virtual HDF5 dataset per
frame, particle set and component, each ~70 µs to create in HDF5 itself: on a robot on RFT, whose
frames come every 25 steps of ~14 µs, as much as the stepping. A view needs only the frame datasets'
names, shapes and types and the frame's index, not the frame, so the run loop
(:class:`terrasph.run_loop.RunLoop`) starts a child interpreter (running :func:`main`, a new
process, not a fork of one holding HDF5 files) once the first frame is written, which makes the
side file with the views of the frames the run plans, :data:`CHUNK_FRAMES` at a time, while the run
steps. When the run has finished, the loop asks the child to stop after its chunk (SIGTERM), takes
the frames it made and completes the file itself (the views of frames not reached dropped, those of
frames the child did not make made) with the XML files: the same files as written at the end alone,
and the run never waits for more than a chunk.

Only the child writes the side file while it runs; the run writes only the run file, which the
child never opens, and opens the side file only once the child has ended. The child is in a session
of its own (Ctrl-C in a terminal stops the run, which then ends it, not the child directly) and ends
when its work is done, when the run stops it or when it finds the run's process gone; a run that ends
other than finished (interrupted, unstable, failed) kills it and writes its sidecars itself, as does a
run whose child failed, after a warning of one line with the child's error.
"""

from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import sys
import warnings
from collections.abc import Mapping

import numpy as np

__all__ = ["CHUNK_FRAMES", "MIN_VIEWS", "SidecarViews", "main"]

#: fewer views than this (frames × views per frame) are made at the run's end (~70 µs each): a child
#: interpreter costs ~0.15 s of a core to start and import h5py, so below this it gains nothing
#: (benchmarks/performance/bench_run_overhead.py: the helper's CPU, helpers_cpu, was 0.29 s for 2205 views)
MIN_VIEWS = 2000
#: frames whose views the child makes between two looks at whether to stop (the run's wait at most:
#: ~10 ms with a robot's five views a frame)
CHUNK_FRAMES = 25


class SidecarViews:
    """The child that makes the side file's views of frames 0 … `frames` − 1 of the run file
    `output`, whose frame datasets have the per-frame `layouts` (name → (shape of one frame, dtype)).
    :meth:`start` decides whether one is worth starting; :meth:`finish` stops it after its chunk and
    takes what it made, :meth:`stop` kills it."""

    def __init__(self, output: str | os.PathLike[str], layouts: Mapping[str, tuple[tuple[int, ...], np.dtype]],
                 frames: int) -> None:
        import terrasph
        from terrasph.io import side_file, source_reference

        self.output = pathlib.Path(output)
        self.frames = int(frames)
        side = side_file(self.output.with_suffix(".xdmf"))
        order = {"side": str(side.resolve()), "source": source_reference(self.output, side), "frames": self.frames,
                 "parent": os.getpid(),
                 "layouts": {name: [list(shape), np.dtype(dtype).str] for name, (shape, dtype) in layouts.items()}}
        # this process's terrasph, wherever it came from, and nothing else from its folder
        folder = str(pathlib.Path(terrasph.__file__).resolve().parent.parent)
        child = (f"import sys; sys.path.insert(0, {folder!r}); import terrasph.sidecar_views as views; "
                 f"sys.path.remove({folder!r}); views.main(sys.argv[1]); import os; os._exit(0)")
        self._process: subprocess.Popen[bytes] | None = subprocess.Popen(
            [sys.executable, "-c", child, json.dumps(order)], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, start_new_session=True)

    @classmethod
    def start(cls, output: str | os.PathLike[str], layouts: Mapping[str, tuple[tuple[int, ...], np.dtype]],
              frames: int) -> SidecarViews | None:
        """A child making the views of `frames` planned frames, if they are :data:`MIN_VIEWS` or more
        and this process may run on two cores or more; else None (the sidecars are made at the end),
        also when no child can be started (a RuntimeWarning of one line says why)."""
        from terrasph.io import _Layout, frame_views
        from terrasph.threads import available_cores

        sets = frame_views({name: _Layout(f"/frames/{name}", (frames, *shape), np.dtype(dtype))
                            for name, (shape, dtype) in layouts.items()})
        views = frames * sum(len(components) for _, _, components in sets)
        if views < MIN_VIEWS or available_cores() < 2:
            return None
        try:
            return cls(output, layouts, frames)
        except OSError as error:  # no interpreter to start, no process left: the run writes them at its end
            warnings.warn(f"{output}: the sidecars' helper cannot start ({error.strerror}); the run writes them "
                          "at its end", RuntimeWarning, stacklevel=2)
            return None

    def finish(self) -> int:
        """Asks the child to stop after the chunk it makes and waits for it; the frames whose views it
        made, 0 … returned − 1 (0 if it had not begun, or failed: a RuntimeWarning of one line then
        says why; the run makes the rest)."""
        process, self._process = self._process, None
        if process is None:
            return 0
        try:
            process.send_signal(signal.SIGTERM)  # nothing if it has ended already
            made, errors = process.communicate()
        except BaseException:  # a second Ctrl-C while waiting, say: nothing is left running
            process.kill()
            process.wait()
            raise
        if process.returncode == 0:
            return int(made.decode() or 0)
        if process.returncode == -signal.SIGTERM:  # stopped before it could look: it had made nothing
            return 0
        lines = errors.decode("utf-8", "replace").strip().splitlines()
        why = lines[-1] if lines else f"exit status {process.returncode}"
        warnings.warn(f"{self.output}: the sidecars' helper failed ({why}); the run writes them instead",
                      RuntimeWarning, stacklevel=2)
        return 0

    def stop(self) -> None:
        """Ends the child if it still runs and waits for it (its side file may then be incomplete:
        the run writes the sidecars whole). Nothing is left running."""
        process, self._process = self._process, None
        if process is None:
            return
        if process.poll() is None:
            process.kill()
        process.communicate()


def main(order_json: str) -> None:
    """The child: makes the side file's connectivity and the views of the frames that `order_json`
    orders (the side file, the run file as the side file names it, the frames, the frame datasets'
    layouts), :data:`CHUNK_FRAMES` at a time, until done or asked to stop (SIGTERM, looked at between
    chunks); prints how many frames' views it made. Stops, exit status 1, if its parent (the run) has
    ended meanwhile. The child's interpreter then ends at once (``os._exit``: its file is closed, its
    count printed; no teardown for the run to wait for)."""
    stop: list[int] = []
    signal.signal(signal.SIGTERM, lambda signum, frame: stop.append(signum))
    import h5py

    from terrasph.io import _connectivity, _Layout, frame_views, make_frame_views

    order = json.loads(order_json)
    frames, parent = int(order["frames"]), int(order["parent"])
    sets = frame_views({name: _Layout(f"/frames/{name}", (frames, *shape), np.dtype(dtype))
                        for name, (shape, dtype) in order["layouts"].items()})
    made = 0
    if not stop:
        with h5py.File(order["side"], "w") as views:
            for name, count, _ in sets:
                _connectivity(views, name, count)
            while made < frames and not stop:
                if os.getppid() != parent:  # the run ended without waiting (killed): no one will use the file
                    raise SystemExit(f"the run (pid {parent}) has ended")
                chunk = range(made, min(frames, made + CHUNK_FRAMES))
                make_frame_views(views, order["source"], sets, chunk)
                views.flush()  # a chunk's metadata written now, not all at the close the run may wait for
                made = chunk.stop
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # done: a request to stop now changes nothing
    print(made, flush=True)
