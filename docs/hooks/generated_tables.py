"""MkDocs hook: tables generated from the code and from the benchmarks' result files.

* ``<!-- parameters: GROUP -->`` (GROUP ``material`` or ``numerics``): every parameter of the
  group with its default, unit and allowed range, from the core's one parameter table
  (``terrasph.config.PARAMETERS``, defined in cpp/include/terrasph/params.hpp).
* ``<!-- tiers -->``: each scene's fidelity tiers and the numerics they set
  (``terrasph.fidelity.scene_tiers``).
* ``<!-- results: NAME -->``: the rows of ``benchmarks/results/NAME.json`` as a table, under a line
  saying when, on which CPU, with which commit and by which command they were measured (the file's
  ``provenance``); the columns are the file's own ``columns`` ([key, heading, format string] each)
  if it names them, else those of :data:`RESULT_COLUMNS` that every row has.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MARKER = re.compile(r"^<!-- (parameters|tiers|results)(?:: ([\w.-]+))? -->$", re.M)


def _number(value: object) -> str:
    """A default as the docs write it."""
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, float):
        return f"{value:.6g}"
    return f"`{value}`" if isinstance(value, str) else str(value)


def parameters_table(group: str) -> str:
    """Markdown table of one parameter group."""
    from terrasph.config import PARAMETERS

    rows = ["| parameter | default | unit | allowed | meaning |", "|---|---|---|---|---|"]
    for entry in PARAMETERS:
        if entry.group == group:
            doc = entry.doc.replace("|", "\\|")
            rows.append(f"| `{entry.name}` | {_number(entry.default)} | {entry.unit} | {entry.allowed} | {doc} |")
    if len(rows) == 2:
        raise ValueError(f"no parameter group {group!r}")
    return "\n".join(rows)


def tiers_table() -> str:
    """Markdown table of every scene's tiers."""
    from terrasph.fidelity import DEFAULT_TIER, TIERS, scene_tiers
    from terrasph.scenes import SCENES

    header = " | ".join(f"{tier} (default)" if tier == DEFAULT_TIER else tier for tier in TIERS)
    rows = [f"| scene | {header} |", "|---|" + "---|" * len(TIERS)]
    for scene in SCENES:
        tiers = scene_tiers(scene)
        cells = []
        for tier in TIERS:
            settings = ", ".join(f"`{name}` = {_number(value)}" for name, value in tiers[tier].numerics.items())
            cells.append(settings or "—")
        rows.append(f"| {scene} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


#: the columns a result table shows, by the keys of its rows: (key, heading, format)
RESULT_COLUMNS = (
    ("level", "level", "{}"), ("granular_particles", "particles", "{}"), ("spacing", "Δx (mm)", "mm"),
    ("steps", "steps", "{:,}"), ("time", "at rest at (s)", "{:.2f}"), ("cpu_time", "CPU time (s)", "{:.1f}"),
    ("runout_normalised", "L*", "{:.3f}"), ("final_height_normalised", "H*", "{:.3f}"),
    ("runout_change", "ΔL* vs finest", "%"), ("height_change", "ΔH* vs finest", "%"), ("status", "status", "{}"),
)


def _cell(value: object, form: str) -> str:
    if form == "mm":
        return f"{1e3 * float(value):.2f}"
    if form == "%":
        return f"{100 * float(value):.1f} %"
    text = form.format(value)
    return text.replace(",", " ") if isinstance(value, (int, float)) else text  # thousands apart by spaces


def results_table(name: str) -> str:
    """Markdown of a result file: its provenance line and its rows."""
    data = json.loads((ROOT / "benchmarks" / "results" / f"{name}.json").read_text())
    if not isinstance(data, dict) or "provenance" not in data:
        raise ValueError(f"benchmarks/results/{name}.json has no provenance: re-run its benchmark")
    rows, meta = data["rows"], data["provenance"]
    columns = [tuple(c) for c in data["columns"]] if "columns" in data else \
        [c for c in RESULT_COLUMNS if all(c[0] in row for row in rows)]
    lines = [f"*Measured {meta['date']} with terrasph {meta['terrasph']} (commit `{meta['commit']}`) on "
             f"{meta['cpu']}, {meta['threads']} thread(s) of {meta['cores']} cores; from "
             f"`benchmarks/results/{name}.json`, written by `{meta['command']}`.*", "",
             "| " + " | ".join(c[1] for c in columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        cells = ["—" if c[2] == "%" and row is rows[-1] else _cell(row[c[0]], c[2]) for c in columns]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def render(match: re.Match) -> str:
    kind, argument = match.group(1), match.group(2)
    if kind == "parameters":
        return parameters_table(argument)
    if kind == "tiers":
        return tiers_table()
    return results_table(argument)


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Replace each marker by its generated table."""
    return MARKER.sub(render, markdown)
