"""Every code block of README.md and of the manual's tutorials runs as written, at a small size.

Blocks run in the order of DOCUMENTS (README first, then the tutorials as the manual lists them)
in one scratch directory (later blocks use the files earlier ones write: the surrogate snippet
reads the dataset and model the commands above it make). Each ```python block runs in its own
interpreter, so it must carry its own imports. ```text blocks are shown, not run (a command with a
placeholder such as ROBOT.xml, or one a block above runs already). ```bash lines run command by
command, with these changes, each documented here and each asserted to apply, so an edit that
breaks one fails this test instead of going unnoticed:

* `pip install …` and `python -m pip install …` are skipped: the package under test is installed;
* the `python -m pytest …` line is skipped: it is the command that runs this test;
* `terrasph ARGS` runs as `python -m terrasph.cli ARGS` with this interpreter (a line ending in a
  backslash continues on the next);
* SIZE shrinks the runs (simulated time, sweep speed, dataset size, epochs), in SIZE's order, and
  gives the repository's files the commands name (a model) their path in this checkout.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: the documents whose blocks run, in this order
DOCUMENTS = [ROOT / "README.md", *(ROOT / "docs" / "tutorials" / f"{name}.md" for name in
                                  ("column", "leg", "leg_wheel", "own_robot", "sand_gym", "sweep_surrogate")),
             ROOT / "docs" / "howto" / "runs.md"]
ROVER4 = ROOT / "python" / "terrasph" / "robots" / "models" / "rover4.xml"

#: (text in a README block, replacement): the small size each block is run at
SIZE = [
    ("--spacing 0.002 --thickness 0.006", "--spacing 0.005 --thickness 0.015"),
    ("--settle-time 0.2 --t-end 2.5 --out leg_wheel.h5", "--settle-time 0.02 --t-end 0.1 --out leg_wheel.h5"),
    ('ColumnCollapse(resolution="coarse", water_content=0.005)',
     'ColumnCollapse(resolution="coarse", water_content=0.005, t_end=0.02)'),
    ("--resolution coarse --out column_collapse.h5", "--resolution coarse --out column_collapse.h5 --t-end 0.02"),
    ("result = sim.run(0.8,", "result = sim.run(0.02,"),
    ("pause, omega = 2.0, 0.2", "pause, omega = 0.01, 40.0"),
    ("scene.add_block(0.0, 0.0, 0.24, 0.15)", "scene.add_block(0.0, 0.0, 0.24, 0.07)"),
    ("reference=(0.12, 0.17)", "reference=(0.12, 0.09)"),
    ("--leg c-leg --omega 0.2 --out c_leg.h5",
     "--leg c-leg --omega 40 --settle-time 0.01 --bed-depth 0.07 --out c_leg.h5"),
    ("terrasph run plate-intrusion --out plate.h5",
     "terrasph run plate-intrusion --out plate.h5 --max-depth 0.006 --speed 0.1 --settle-time 0.01"),
    ("--runs 120 --duration 3", "--runs 6 --duration 1"),
    ("--settle-time 0.2 --t-end 1.0 --out lw.h5", "--settle-time 0.02 --t-end 0.04 --out lw.h5"),
    ("--settle-time 0.2 --t-end 1.0 --out rover.h5", "--settle-time 0.02 --t-end 0.04 --out rover.h5"),
    ("--out wheel.tslstm", "--out wheel.tslstm --epochs 3 --no-progress"),
    ("python/terrasph/robots/models/rover4.xml --terrain rft --settle-time 0.5 --t-end 2.5",
     f"{ROVER4} --terrain rft --element-length 0.03 --settle-time 0.02 --t-end 0.04"),
]


def code_blocks() -> list[tuple[str, str]]:
    """(language, text) of every fenced block with a language but ``text``, in DOCUMENTS order."""
    blocks = [block for document in DOCUMENTS
              for block in re.findall(r"^```(\w+)\n(.*?)^```", document.read_text(), re.S | re.M)]
    return [(language, body) for language, body in blocks if language != "text"]


def shrink(blocks: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """The blocks with every SIZE substitution applied; each must apply exactly once."""
    text = "\x00".join(f"{lang}\x01{body}" for lang, body in blocks)
    for old, new in SIZE:
        assert text.count(old) == 1, f"the documents no longer hold {old!r} exactly once: update SIZE"
        text = text.replace(old, new)
    return [tuple(part.split("\x01", 1)) for part in text.split("\x00")]  # type: ignore[misc]


def bash_commands(body: str) -> list[list[str]]:
    """The commands of a bash block (lines joined at a trailing backslash, `&&` chains, comments
    dropped) minus install and pytest."""
    commands = []
    for line in body.replace("\\\n", " ").splitlines():
        line = line.split(" #", 1)[0].strip()
        for command in filter(None, (c.strip() for c in line.split("&&"))):
            words = shlex.split(command)
            if words[:2] == ["pip", "install"] or words[:4] == ["python", "-m", "pip", "install"]:
                continue
            if words[:3] == ["python", "-m", "pytest"]:
                continue
            assert words[0] == "terrasph", f"command not covered by this test: {command!r}"
            commands.append([sys.executable, "-m", "terrasph.cli", *words[1:]])
    return commands


def test_readme_and_tutorial_blocks_run_as_written(tmp_path: Path) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["MPLBACKEND"] = "Agg"
    ran = {"python": 0, "bash": 0}
    for language, body in shrink(code_blocks()):
        assert language in ran, f"block in {language!r}: teach this test to run it"
        commands = bash_commands(body) if language == "bash" else [[sys.executable, "-c", body]]
        for command in commands:
            result = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
            assert result.returncode == 0, f"{command[2:]}\n{result.stdout[-2000:]}\n{result.stderr[-3000:]}"
            ran[language] += 1
    assert ran["python"] == 6 and ran["bash"] >= 6
    # the files the documents say the commands write
    for name in ("quickstart.h5", "quickstart.png", "leg_wheel.h5", "leg_wheel.png", "leg_wheel.mp4", "column_collapse.h5", "column_collapse.xdmf",
                 "column_collapse.grains.xdmf", "column_collapse.png", "column_collapse.gif", "my_run.h5", "leg.h5",
                 "c_leg.h5", "plate.h5", "wheel.tslstm", "lw.h5", "rover.h5", "rover4_rft.h5"):
        assert (tmp_path / name).is_file(), name
