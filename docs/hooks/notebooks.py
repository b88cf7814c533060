"""MkDocs hook: the notebooks of notebooks/ as pages of the manual (Tutorials → Notebooks).

Each notebook becomes ``notebooks/NAME.md``: its Markdown cells as they are, its code cells as
Python blocks, and the outputs stored in the file (text, and PNG figures as images). A notebook
that runs in about a minute is stored with the outputs of its full run, so its page shows its
figures; the others take minutes each and are stored without outputs (the slow test tier executes
every notebook in quick mode: tests/test_notebooks.py), so their pages show text and code: run one
(`jupyter lab notebooks/NAME.ipynb`) for its figures. Plain JSON is read here, so building the
manual needs neither nbconvert nor a kernel.
"""

from __future__ import annotations

import json
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]


def _text(source: str | list[str]) -> str:
    return source if isinstance(source, str) else "".join(source)


def notebook_markdown(path: Path) -> str:
    """The page of one notebook."""
    notebook = json.loads(path.read_text())
    shown = any("image/png" in output.get("data", {}) for cell in notebook["cells"] for output in cell.get("outputs", []))
    parts = [f"*Notebook `notebooks/{path.name}`: " + ("shown with the outputs of its full run.*\n" if shown else
                                                        "run it with Jupyter for its figures.*\n")]
    for cell in notebook["cells"]:
        source = _text(cell["source"]).rstrip()
        if cell["cell_type"] == "markdown":  # its links to docs/ made relative to docs/notebooks/
            parts.append(source.replace("](../docs/", "](../"))
        elif cell["cell_type"] == "code" and source:
            parts.append(f"```python\n{source}\n```")
            for output in cell.get("outputs", []):
                data = output.get("data", {})
                if "image/png" in data:
                    parts.append(f"![output](data:image/png;base64,{_text(data['image/png']).strip()})")
                elif "text/plain" in data or "text" in output:
                    parts.append(f"```text\n{_text(data.get('text/plain', output.get('text', ''))).rstrip()}\n```")
    return "\n\n".join(parts) + "\n"


def _title(path: Path) -> str:
    for cell in json.loads(path.read_text())["cells"]:
        if cell["cell_type"] == "markdown":
            first = _text(cell["source"]).strip().splitlines()[0]
            return first.lstrip("# ").strip()
    return path.stem


def on_files(files, config):
    """Add one generated page per notebook and their index."""
    notebooks = sorted((ROOT / "notebooks").glob("*.ipynb"))
    index = ["# Notebooks", "", "Studies that import the package, shown here as text and code, with the "
             "figures of those stored with their outputs (the slow test tier runs each one).", ""]
    for path in notebooks:
        files.append(File.generated(config, f"notebooks/{path.stem}.md", content=notebook_markdown(path)))
        index.append(f"* [{_title(path)}]({path.stem}.md) — `notebooks/{path.name}`")
    files.append(File.generated(config, "notebooks/index.md", content="\n".join(index) + "\n"))
    return files
