"""Smoke runs of the notebooks in a fresh kernel: each executes top to bottom in quick mode, and
every figure it shows renders as an image, once.

A figure that a cell leaves as its value used to show only as text ("<Figure size …>") until some
cell had created a pyplot figure, and a pyplot figure also returned as the value was shown twice.
Checked per cell: a cell whose value is a figure has exactly one image/png output and no
"<Figure" text; no cell writes a warning to stderr (such as tqdm's "IProgress not found").
"""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def figure_cells(notebook) -> list:
    """Code cells whose last line is a bare `fig` (the figure is the cell's value)."""
    cells = []
    for cell in notebook.cells:
        lines = [line for line in cell.source.strip().splitlines() if line.strip()]
        if cell.cell_type == "code" and lines and lines[-1].strip() == "fig":
            cells.append(cell)
    return cells


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_and_shows_each_figure_once(path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv("TERRASPH_NOTEBOOK_QUICK", "1")
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel's own default, as for a user
    notebook = nbformat.read(path, as_version=4)
    # run where a user runs it: in a notebooks/ folder beside the repository's examples/ and
    # benchmarks/ (linked, so that what the notebook writes stays in tmp_path), whether terrasph is
    # imported from the source tree or installed
    for folder in ("examples", "benchmarks"):
        (tmp_path / folder).symlink_to(ROOT / folder, target_is_directory=True)
    (tmp_path / "notebooks").mkdir()
    client = nbclient.NotebookClient(notebook, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path / "notebooks")}})
    client.execute()
    code_cells = [cell for cell in notebook.cells if cell.cell_type == "code"]
    outputs = [o for cell in code_cells for o in cell.get("outputs", [])]
    assert not any(o.get("output_type") == "error" for o in outputs)
    stderr = [o.get("text", "") for o in outputs if o.get("output_type") == "stream" and o.get("name") == "stderr"]
    assert not stderr, stderr
    cells = figure_cells(notebook)
    assert cells, "the notebook shows no figure"
    for cell in cells:
        images = [o for o in cell.outputs if "image/png" in o.get("data", {})]
        assert len(images) == 1, f"{len(images)} images from cell:\n{cell.source}"
        texts = [o["data"].get("text/plain", "") for o in cell.outputs if "data" in o and "image/png" not in o["data"]]
        assert not any("<Figure" in t for t in texts), texts
