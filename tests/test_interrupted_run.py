"""An interrupted run is usable: Ctrl-C ends `terrasph run` within a few
seconds however slow the steps, `/run` records the time and step reached, the XDMF sidecar and
the PNG are written, and `terrasph info` / `terrasph plot` work on the file.

The run is the default leg scene (~9 000 particles, a few ms per step) with SIGINT sent once its
first frame is on disk. Before the fix the core was entered for 500 steps at a time (55 s under
load) and `/run` held only the status.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import h5py
import pytest
from terrasph.cli import main
from terrasph.io import read_run

#: Allowed time from SIGINT to exit. One chunk of core steps is ~0.2 s of wall time; the rest is
#: writing the last frame, the XDMF and the PNG (matplotlib import included) on a busy machine.
EXIT_WITHIN = 30.0


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("interrupted") / "leg.h5"
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    process = subprocess.Popen([sys.executable, "-m", "terrasph.cli", "run", "leg-rotation", "--out", str(out),
                                "--no-progress", "--threads", "1"], env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and process.poll() is None:
        if out.exists() and _frames(out) >= 1:
            break
        time.sleep(0.5)
    time.sleep(1.0)  # into the stepping, past the first frame
    process.send_signal(signal.SIGINT)
    sent = time.monotonic()
    _, err = process.communicate(timeout=EXIT_WITHIN + 60)
    return out, process.returncode, err, time.monotonic() - sent


def _frames(path) -> int:
    try:
        with h5py.File(path, "r", locking=False) as f:
            return int(f["frames/time"].shape[0])
    except (OSError, KeyError):
        return 0


def test_ctrl_c_ends_the_run_promptly(interrupted) -> None:
    _, code, err, seconds = interrupted
    assert code == 130, err
    assert "Traceback" not in err
    assert seconds < EXIT_WITHIN


def test_run_group_records_how_far_it_got(interrupted) -> None:
    out, *_ = interrupted
    run = read_run(out)
    status = run.group_attrs["/run"]
    assert status["status"] == "interrupted"
    assert status["steps"] > 0 and status["time"] > 0
    # the last frame is the state at the interruption
    assert status["time"] == pytest.approx(run.times[-1]) and status["steps"] == run.steps[-1]


def test_xdmf_and_png_are_written(interrupted) -> None:
    out, *_ = interrupted
    assert out.with_suffix(".xdmf").is_file()
    assert out.with_suffix(".png").is_file()


def test_info_and_plot_read_the_file(interrupted, capsys) -> None:
    out, *_ = interrupted
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "status interrupted" in text and "reached t =" in text and "terrasph resume" in text
    out.with_suffix(".png").unlink()
    assert main(["plot", str(out), "--force"]) == 0  # the run wrote its figure and sidecars: replace them
    assert out.with_suffix(".png").is_file()
