"""The sweep SPEC (terrasph.sweeps.spec) and input schedules (terrasph.schedules): bad input is
refused naming it before any run; the designs have their defining properties."""

from __future__ import annotations

import numpy as np
import pytest
from sweep_helpers import TINY_FIXED, tiny_spec
from terrasph import schedules
from terrasph.cli import main
from terrasph.config import ConfigError
from terrasph.sweeps.spec import load_spec, parse_spec


def _with(spec: dict, path: list[str], value: object) -> dict:
    node = spec
    for key in path[:-1]:
        node = node[key]
    if value is None:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return spec


BAD = [  # (where in the SPEC, new value (None: removed), what the error must name)
    (["fixed", "radius"], 0.1, "unknown parameter 'radius'"),
    (["design", "vary", "mu"], {"range": [0.1, 0.5]}, "unknown parameter 'mu'"),
    (["design", "vary", "load"], {"range": [-1.0, 3.0]}, "design.vary.load.range.*'load' = -1.0"),
    (["design", "vary", "legs"], {"range": [2, 20]}, "design.vary.legs.range.*'legs' = 20"),
    (["design", "vary", "numerics.fixed_dt"], {"values": [-1.0]}, "numerics.fixed_dt"),
    (["design", "vary", "mu1_deg"], {"range": [-5.0, 20.0]}, "design.vary.mu1_deg.range.*'mu1_deg' = -5.0"),
    (["design", "vary", "mu1_deg"], {"range": [20.0, 40.0]}, "'mu1_deg' = 40.0.*<= mu2_deg = 33.0"),
    (["design", "vary", "water_content"], {"values": [0.0, 0.5]}, "'water_content' = 0.5.*pendular"),
    (["design", "vary", "wheel"], {"values": []}, "empty design.*design.vary.wheel.values"),
    (["design", "vary", "wheel"], {"values": ["square"]}, "'wheel' = 'square'"),
    (["design", "runs"], 0, "empty design.*design.runs"),
    (["design", "method"], "sobol", "design.method"),
    (["design", "input", "range"], [-1.0, 2.0], "design.input.range.*omega_schedule"),
    (["design", "input", "kinds"], ["sine"], "design.input.kinds"),
    (["scene"], "moon-rover", "scene 'moon-rover' is not registered"),
    (["walltime"], 5, "unknown entry 'walltime'"),
]


@pytest.mark.parametrize(("path", "value", "message"), BAD, ids=[m.split("'")[1] if "'" in m else m for *_, m in BAD])
def test_bad_spec_is_refused_naming_the_entry(path: list[str], value: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_spec(_with(tiny_spec(), path, value))


def test_a_design_with_nothing_varied_is_refused() -> None:
    spec = tiny_spec(vary={})
    del spec["design"]["input"]
    with pytest.raises(ConfigError, match="empty design"):
        parse_spec(spec)


def test_bad_spec_on_the_command_line_stops_before_any_run(tmp_path, capsys) -> None:
    spec = tmp_path / "bad.toml"
    spec.write_text('scene = "leg-wheel"\n[design]\nmethod = "grid"\n[design.vary.load]\nrange = [1.0, -2.0]\n')
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as stop:
        main(["sweep", str(spec), "--out", str(out)])
    assert stop.value.code == 2
    message = capsys.readouterr().err
    assert "design.vary.load.range" in message and "low <= high" in message
    assert not out.exists()  # nothing started: no sweep directory


def test_latin_hypercube_puts_one_case_in_each_stratum_and_is_seeded() -> None:
    spec = parse_spec(tiny_spec(runs=8))
    loads = np.array([case.varied["load"] for case in spec.cases])
    strata = np.floor((loads - 2.0) / (4.0 / 8)).astype(int)
    assert sorted(strata) == list(range(8))  # a Latin hypercube: each of 8 equal load intervals once
    wheels = [case.varied["wheel"] for case in spec.cases]
    assert wheels.count("c-leg") == wheels.count("wheel") == 4  # the strata of the morphology: balanced
    assert [c.case_id for c in parse_spec(tiny_spec(runs=8)).cases] == [c.case_id for c in spec.cases]
    reseeded = tiny_spec(runs=8)
    reseeded["seed"] = 2
    assert {c.case_id for c in parse_spec(reseeded).cases}.isdisjoint({c.case_id for c in spec.cases})


def test_grid_is_the_product_of_its_levels_and_every_case_is_a_valid_configuration(tmp_path) -> None:
    spec_file = tmp_path / "grid.yaml"
    spec_file.write_text("scene: leg-wheel\nfixed: {spacing: 0.01, thickness: 0.03, leg_length: 0.04, "
                         "bed_width: 0.2, start_x: 0.08}\ndesign:\n  method: grid\n  vary:\n"
                         "    load: {range: [1.0, 5.0], levels: 5}\n    legs: {values: [2, 3, 4]}\n"
                         "  input: {parameter: omega_schedule, kinds: [step, ramp], range: [1.0, 2.0]}\n")
    spec = load_spec(spec_file)
    assert len(spec.cases) == 5 * 3 * 2
    assert sorted({c.varied["load"] for c in spec.cases}) == [1.0, 2.0, 3.0, 4.0, 5.0]
    for case in spec.cases:
        values = [u for _, u in case.config["omega_schedule"]]
        assert min(values) >= 1.0 and max(values) <= 2.0
        assert {k: case.config[k] for k in ("spacing", "bed_width")} == {"spacing": 0.01, "bed_width": 0.2}


def test_schedules_step_ramp_and_hold() -> None:
    step = schedules.step(1.0, 3.0, at=0.5)
    assert schedules.evaluate(step, [0.0, 0.49, 0.5, 2.0]).tolist() == [1.0, 1.0, 3.0, 3.0]
    ramp = schedules.ramp(1.0, 3.0, 0.5, 1.5)
    assert schedules.evaluate(ramp, [0.25, 1.0, 1.5, 9.0]).tolist() == [1.0, 2.0, 3.0, 3.0]
    rng = np.random.default_rng(0)
    knots = schedules.random_piecewise(rng, 2.0, 0.5, 3.0, segments=5)
    values = schedules.evaluate(knots, np.linspace(0, 2.5, 1001))
    assert values.min() >= 0.5 and values.max() <= 3.0 and len(np.unique(values)) > 5


def test_leg_wheel_commands_its_schedule_after_the_pause() -> None:
    from terrasph.scenes.leg_wheel import LegWheel

    config = LegWheel(**TINY_FIXED, omega_schedule=((0.0, 1.0), (0.2, 1.0), (0.2, 2.5)))
    assert config.commanded_omega(np.array([0.05, 0.15, 0.35])).tolist() == [0.0, 1.0, 2.5]
    with pytest.raises(ConfigError, match="omega_schedule"):
        LegWheel(omega_schedule=((0.0, -1.0),))


def test_a_yaml_error_names_its_line_in_the_one_line_message(tmp_path, capsys) -> None:
    from terrasph.cli import main

    spec_file = tmp_path / "bad.yaml"
    spec_file.write_text("scene: leg-wheel\nfixed:\n  spacing: 0.01\n   load: 2\n")  # line 4 indented too far
    with pytest.raises(SystemExit) as exit_info:
        main(["sweep", str(spec_file), "--out", str(tmp_path / "out"), "--dry-run"])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and len(err.splitlines()) == 1 and "line 4" in err, err


def test_a_sweep_of_cases_too_big_is_refused_before_any_run(tmp_path, capsys) -> None:
    """The size guard judges every case as one worker's run, before the cluster starts."""
    from terrasph.cli import main

    spec_file = tmp_path / "big.yaml"
    spec_file.write_text("scene: leg-wheel\nfixed: {spacing: 0.0001}\ndesign:\n  method: grid\n"
                         "  vary:\n    load: {values: [2.0, 3.0]}\n")
    with pytest.raises(SystemExit) as exit_info:
        main(["sweep", str(spec_file), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and len(err.splitlines()) == 1 and "--yes" in err, err
    assert not (tmp_path / "out").exists()


def test_draws_run_each_point_with_several_schedules_that_share_its_settled_start() -> None:
    from terrasph.scenes import scene_entry
    from terrasph.settle_cache import pre_drive_fields

    raw = tiny_spec(runs=3)
    raw["design"]["input"] = {"parameter": "omega_schedule", "kinds": ["constant", "step", "ramp", "random"],
                              "range": [0.5, 3.0], "draws": 4}
    cases = parse_spec(raw).cases
    assert len(cases) == 3 * 4
    entry = scene_entry("leg-wheel")
    points: dict[str, list] = {}
    for index, case in enumerate(cases):
        settled = pre_drive_fields(entry.config_from(case.config))  # what the settle cache keys on
        points.setdefault(repr(sorted(settled.items())), []).append((index, case))
    assert len(points) == 3  # one settled start per point of the design
    for members in points.values():
        assert [index % 3 for index, _ in members] == [members[0][0]] * 4  # draw by draw: point k at k, k+3, ...
        assert sorted(case.varied["input_kind"] for _, case in members) == ["constant", "ramp", "random", "step"]
        schedules_drawn = {repr(case.config["omega_schedule"]) for _, case in members}
        assert len(schedules_drawn) == 4
    bad = tiny_spec(runs=3)
    bad["design"]["input"] = {"parameter": "omega_schedule", "range": [0.5, 3.0], "draws": 0}
    with pytest.raises(ConfigError, match=r"design\.input\.draws"):
        parse_spec(bad)
