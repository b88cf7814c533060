"""The numbers the manual quotes agree with the code and with the result files they come from.

* docs/fidelity.md's table of defaults: each row that names parameters (`numerics.NAME`,
  `material.NAME`) quotes, in its "default now" column, the default the core's parameter table
  (cpp/include/terrasph/params.hpp, through terrasph.config.PARAMETERS) gives.
* docs/fidelity.md's table of tiers: every C = … and mass scaling … of a scene's tier is the one
  terrasph.fidelity sets (or the core's default where the tier sets none), and every scene has a row.
* The tables the manual renders from benchmarks/results/*.json (docs/hooks/generated_tables.py) carry
  the file's provenance and its rows' figures, and the command line reference lists every command.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest
from terrasph.config import PARAMETERS, parameter
from terrasph.fidelity import TIERS, scene_tiers
from terrasph.scenes import SCENES

ROOT = Path(__file__).resolve().parent.parent
FIDELITY = (ROOT / "docs" / "fidelity.md").read_text()
NUMBER = r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?"


def table_after(heading: str, text: str) -> list[list[str]]:
    """The cells of the first Markdown table after `heading`, header row first."""
    section = text[text.index(heading):]
    rows = []
    for line in section.splitlines()[1:]:
        if line.startswith("|"):
            rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
        elif rows:
            break
    return [row for row in rows if not set("".join(row)) <= set("-: ")]


def documented_value(cell: str, kind: str) -> object:
    """The default a 'default now' cell states: on/off for a switch, else the number after its
    first '=' (``ν ρ_s = 1519.2 kg/m³`` → 1519.2) or its first number (``1e-7 1/s`` → 1e-7)."""
    if kind == "bool":
        word = cell.split()[0]
        assert word in ("on", "off"), cell
        return word == "on"
    head = cell.split("=", 1)[1] if "=" in cell.split("(")[0] else cell
    number = re.search(NUMBER, head.replace("−", "-"))
    assert number, cell
    return float(number.group(0))


def test_the_defaults_fidelity_md_quotes_are_the_cores() -> None:
    rows = table_after("## The defaults", FIDELITY)
    header, body = rows[0], rows[1:]
    column = header.index("default now")
    checked = 0
    for row in body:
        names = re.findall(r"`((?:numerics|material)\.\w+)`", row[0])
        for name in names:
            entry = parameter(name)
            value = documented_value(row[column], entry.kind)
            assert value == pytest.approx(entry.default, rel=1e-12), f"docs/fidelity.md: {name} = {row[column]!r}"
            checked += 1
    assert checked >= 6  # α_Π, the step's C, the density scheme, pairs, cell order, ρ0, ε, ∇W


def tier_setting(scene: str, tier: str, name: str) -> float:
    """What a tier of a scene sets for `name`, or the core's default where it sets nothing."""
    return float(scene_tiers(scene)[tier].numerics.get(name, parameter(f"numerics.{name}").default))


def test_the_tiers_fidelity_md_lists_are_the_codes() -> None:
    rows = table_after("## The tiers", FIDELITY)
    header, body = rows[0], rows[1:]
    columns = {tier: k for k, cell in enumerate(header) if (tier := cell.split()[0]) in TIERS}
    assert set(columns) == set(TIERS)
    named = set()
    for row in body:
        scenes = [name.strip() for name in row[0].split(",")]
        named.update(scenes)
        for scene in scenes:
            for tier, k in columns.items():
                cell = row[k]
                steps = re.findall(rf"C = ({NUMBER})", cell)
                assert steps, f"docs/fidelity.md: {scene}/{tier} names no C"
                assert float(steps[0]) == tier_setting(scene, tier, "cfl"), f"{scene}/{tier}: {cell!r}"
                scaling = re.findall(rf"mass scaling ({NUMBER})", cell)
                assert (float(scaling[0]) if scaling else 1.0) == tier_setting(scene, tier, "mass_scaling"), cell
                assert ("active domain" in cell) == (tier_setting(scene, tier, "freeze_speed") > 0), cell
    assert named >= set(SCENES) - {"plate-drag"}  # the calibration scene is a tool, not a tier study


@pytest.fixture(scope="module")
def hooks():
    sys.path.insert(0, str(ROOT / "docs" / "hooks"))
    try:
        import cli_reference
        import generated_tables
        yield generated_tables, cli_reference
    finally:
        sys.path.remove(str(ROOT / "docs" / "hooks"))


def test_result_tables_carry_their_files_figures_and_provenance(hooks) -> None:
    generated_tables, _ = hooks
    path = ROOT / "benchmarks" / "results" / "column_convergence.json"
    data = json.loads(path.read_text())
    table = generated_tables.results_table("column_convergence")
    meta = data["provenance"]
    for key in ("date", "commit", "cpu", "command"):
        assert str(meta[key]) in table
    for row in data["rows"]:
        assert f"{row['steps']:,}".replace(",", " ") in table and f"{row['runout_normalised']:.3f}" in table
    docs = (ROOT / "docs" / "benchmarks.md").read_text()
    assert "<!-- results: column_convergence -->" in docs
    assert not re.search(r"\|\s*coarse\s*\|\s*460\s*\|", docs)  # the table is not copied by hand beside it


def test_parameter_tables_list_every_parameter(hooks) -> None:
    generated_tables, _ = hooks
    for group in ("material", "numerics"):
        table = generated_tables.parameters_table(group)
        assert all(f"| `{e.name}` |" in table for e in PARAMETERS if e.group == group)


def test_cli_reference_lists_every_command(hooks) -> None:
    _, cli_reference = hooks
    reference = cli_reference.cli_reference()
    for command in ("run", "resume", "info", "plot", "animate", "train", "predict", "sweep", "dataset"):
        assert f"## `terrasph {command}`" in reference
    for scene in SCENES:
        assert f"### `terrasph run {scene}`" in reference


@pytest.mark.parametrize(("name", "page"), [("sand_substeps", "terrain.md"), ("gym_sand_speed", "terrain.md"),
                                            ("rft_plugin_step", "mujoco_plugin.md")])
def test_the_sand_pages_tables_are_their_result_files(hooks, name: str, page: str) -> None:
    """The substep study, the gym speed benchmark and the plugin's step study are shown from their
    result files (their own columns), with the file's provenance, on the page that cites them."""
    generated_tables, _ = hooks
    data = json.loads((ROOT / "benchmarks" / "results" / f"{name}.json").read_text())
    table = generated_tables.results_table(name)
    for key in ("date", "commit", "command"):
        assert str(data["provenance"][key]) in table
    lines = [line for line in table.splitlines() if line.startswith("| ") and "---" not in line]
    assert len(lines) == 1 + len(data["rows"])
    for row, line in zip(data["rows"], lines[1:]):
        key, _, form = data["columns"][0]
        assert line.startswith(f"| {form.format(row[key])} |")
    assert f"<!-- results: {name} -->" in (ROOT / "docs" / page).read_text()


def test_the_run_overhead_table_of_runs_md_is_its_result_files() -> None:
    """docs/howto/runs.md's table of what a run costs besides its steps quotes the medians of
    benchmarks/results/run_overhead.json (bench_run_overhead.py), side by side, to the digit shown."""
    data = json.loads((ROOT / "benchmarks" / "results" / "run_overhead.json").read_text())
    rows = table_after("What a run costs besides its steps", (ROOT / "docs" / "howto" / "runs.md").read_text())
    assert rows[0][-1] == "total / stepping"
    quoted = {row[0][0]: row for row in rows[1:]}
    assert set(quoted) == set(data["medians"])
    for side, medians in data["medians"].items():
        row = quoted[side]
        assert row[1:7] == [f"{medians[key]:.3f}" for key in ("stepping", "samples", "frames_write", "series_write",
                                                               "sidecars", "loop")]
        assert row[7] == f"{medians['build']:.3f}"
        assert row[8] == f"{medians['after']:.3f} ({medians['figure']:.3f})"
        assert row[9] == f"{medians['total']:.3f}"
        assert row[10] == f"{medians['imports']:.3f} ({medians['matplotlib_import']:.3f})"
        assert row[11] == f"{data['total_over_stepping'][side]:.2f}"
