"""The sweep SPEC: a scene, its fixed parameters and a seeded design over the varied ones.

YAML (or the same tables in TOML)::

    scene: leg-wheel            # a name of terrasph.scenes.SCENES
    seed: 7                     # seeds the design and each case's drawn input schedule
    fixed:                      # fields of the scene's configuration
      spacing: 0.01
      t_end: 2.0                # old field names (duration) are read too
    design:
      method: latin-hypercube   # grid | random | latin-hypercube
      runs: 12                  # random and latin-hypercube: number of cases
      vary:                     # fields (or numerics.NAME) of the configuration
        load: {range: [2.0, 6.0]}          # grid: `levels` points (default 3), else drawn
        wheel: {values: [c-leg, wheel]}    # a list of values, drawn or (grid) all taken
      input:                    # optional: the commanded input as a time series
        parameter: omega_schedule          # a knot-list field of the scene (terrasph.schedules)
        kinds: [constant, step, ramp, random]
        range: [0.5, 3.0]       # the input's values
        duration: 1.5           # schedule length (s; default t_end − settle_time of the scene)
        segments: 4             # segments of a "random" schedule
        draws: 1                # schedules per point of the design (> 1: each point runs with
                                # `draws` schedules, the kinds taken in turn; the cases that share a
                                # point share its settled start through the settle cache)

Every range end and every case is checked by building the scene's own configuration (so a range
outside a parameter's allowed range is refused with that parameter's own message), and
``numerics.NAME`` against the parameter table, before anything runs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tomllib

from terrasph import schedules
from terrasph.config import ConfigError, parameter
from terrasph.scenes import scene_entry

__all__ = ["METHODS", "Case", "SweepSpec", "load_spec", "parse_spec"]

METHODS = ("grid", "random", "latin-hypercube")
_TOP_KEYS = {"scene", "seed", "fixed", "design"}
_DESIGN_KEYS = {"method", "runs", "vary", "input"}
_VARY_KEYS = {"range", "values", "levels"}
_INPUT_KEYS = {"parameter", "kinds", "range", "duration", "segments", "draws"}


@dataclass(frozen=True)
class Case:
    """One run of a sweep: its id (index and a digest of its configuration), the varied values and
    the scene's whole configuration (fixed + varied) as plain data."""

    case_id: str
    varied: dict[str, Any]
    config: dict[str, Any]


@dataclass(frozen=True)
class SweepSpec:
    """A validated SPEC and its cases."""

    scene: str
    seed: int
    fixed: dict[str, Any]
    design: dict[str, Any]
    cases: tuple[Case, ...]

    def as_dict(self) -> dict[str, Any]:
        """The SPEC as plain data (for the manifest)."""
        return {"scene": self.scene, "seed": self.seed, "fixed": self.fixed, "design": self.design}


def load_spec(path: str | Path) -> SweepSpec:
    """Reads and validates a SPEC file (.yaml/.yml or .toml)."""
    path = Path(path)
    text = path.read_text()
    if path.suffix in (".yaml", ".yml"):
        import yaml

        try:
            raw = yaml.safe_load(text)
        except yaml.YAMLError as error:  # its text spans lines: the one line names where and what
            mark = getattr(error, "problem_mark", None)
            where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
            what = getattr(error, "problem", None) or str(error).splitlines()[0]
            raise ConfigError(f"sweep spec {path}: not valid YAML{where}: {what}") from None
    elif path.suffix == ".toml":
        try:
            raw = tomllib.loads(text)
        except tomllib.TOMLDecodeError as error:
            raise ConfigError(f"sweep spec {path}: not valid TOML ({error})") from None
    else:
        raise ConfigError(f"sweep spec {path}: allowed a .yaml, .yml or .toml file")
    return parse_spec(raw)


def _require_mapping(value: Any, where: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise ConfigError(f"sweep spec: '{where}' must be a table of names to values, got {value!r}")
    return dict(value)


def _reject_unknown(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise ConfigError(f"sweep spec: unknown entry {unknown[0]!r} in '{where}': allowed {', '.join(sorted(allowed))}")


def parse_spec(raw: Any) -> SweepSpec:
    """Validates the SPEC's plain data and builds its cases; ConfigError naming the first problem."""
    top = _require_mapping(raw, "spec")
    _reject_unknown(top, _TOP_KEYS, "spec")
    if "scene" not in top or "design" not in top:
        raise ConfigError("sweep spec: 'scene' and 'design' are required")
    entry = scene_entry(str(top["scene"]))
    fields = {f.name: f for f in dataclasses.fields(entry.config_type)}
    seed = top.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"sweep spec: 'seed' = {seed!r} is invalid: allowed an integer >= 0")
    fixed = entry.current_names(_require_mapping(top.get("fixed", {}), "fixed"))  # old field names read too
    for name in fixed:
        _check_name(name, fields, "fixed")
    design = _require_mapping(top["design"], "design")
    _reject_unknown(design, _DESIGN_KEYS, "design")
    method = design.get("method")
    if method not in METHODS:
        raise ConfigError(f"sweep spec: 'design.method' = {method!r} is invalid: allowed one of {', '.join(METHODS)}")
    vary = entry.current_names(_require_mapping(design.get("vary", {}), "design.vary"))
    if not vary and "input" not in design:
        raise ConfigError("sweep spec: empty design: 'design.vary' names no parameter and there is no 'design.input'")
    build = _config_builder(entry, fields, fixed)
    build({})  # the fixed parameters alone must make a valid configuration
    dimensions = [_dimension(name, _require_mapping(spec, f"design.vary.{name}"), method, fields, build)
                  for name, spec in vary.items()]
    input_spec = _input(design["input"], fields, build) if "input" in design else None
    rows = _design_rows(method, design, dimensions, input_spec, seed)
    if input_spec is not None and input_spec["draws"] > 1:
        rows = _rows_with_draws(rows, input_spec)
    cases = []
    for index, varied in enumerate(rows):
        if input_spec is not None:
            kind = varied.pop("input_kind")
            rng = np.random.default_rng([seed, index])
            lower, upper = input_spec["range"]
            knots = schedules.draw(kind, rng, input_spec["duration"], lower, upper, input_spec["segments"])
            varied = {**varied, "input_kind": kind, input_spec["parameter"]: [list(k) for k in knots]}
        config = build(varied)
        digest = hashlib.sha256(json.dumps([entry.name, config], sort_keys=True).encode()).hexdigest()[:10]
        cases.append(Case(f"{index:04d}-{digest}", varied, config))
    return SweepSpec(entry.name, seed, fixed, design, tuple(cases))


def _check_name(name: str, fields: Mapping[str, Any], where: str) -> None:
    """A configuration field, or numerics.NAME of the parameter table if the scene has numerics."""
    if name.startswith("numerics.") and "numerics" in fields:
        try:
            parameter(name)
        except KeyError:
            raise ConfigError(f"sweep spec: unknown parameter {name!r} in '{where}'") from None
    elif name not in fields:
        raise ConfigError(f"sweep spec: unknown parameter {name!r} in '{where}': the scene's parameters are "
                          f"{', '.join(fields)} (and numerics.NAME)")


def _config_builder(entry: Any, fields: Mapping[str, Any], fixed: Mapping[str, Any]) -> Any:
    """A function varied values → the scene's whole configuration as plain data, checked by
    building the scene's configuration (and the numerics parameters against their table)."""
    def build(varied: Mapping[str, Any]) -> dict[str, Any]:
        values = {**fixed, **varied}
        values.pop("input_kind", None)
        numerics = dict(values.pop("numerics", {}) or {})
        for name in [n for n in values if n.startswith("numerics.")]:
            numerics[name.split(".", 1)[1]] = values.pop(name)
        for name, value in numerics.items():
            _check_numerics(name, value)
        if numerics:
            values["numerics"] = numerics
        config = entry.config_from(values)
        return json.loads(json.dumps(dataclasses.asdict(config)))
    return build


def _check_numerics(name: str, value: Any) -> None:
    entry = parameter(f"numerics.{name}")
    value = entry.coerce(value)
    if entry.kind in ("double", "int"):
        above = value > entry.lower or (entry.lower_inclusive and value == entry.lower)
        below = value < entry.upper or (entry.upper_inclusive and value == entry.upper)
        if not (above and below):
            raise ConfigError(f"parameter 'numerics.{name}' = {value!r} is invalid: allowed {entry.allowed}")


def _dimension(name: str, spec: dict[str, Any], method: str, fields: Mapping[str, Any], build: Any) -> dict[str, Any]:
    """One varied parameter: its name, kind ("range" or "values") and what the design draws from."""
    _check_name(name, fields, "design.vary")
    _reject_unknown(spec, _VARY_KEYS, f"design.vary.{name}")
    where = f"design.vary.{name}"
    if ("range" in spec) == ("values" in spec):
        raise ConfigError(f"sweep spec: '{where}' needs exactly one of 'range' [low, high] or 'values' [...]")
    integer = name in fields and isinstance(fields[name].default, int) and not isinstance(fields[name].default, bool)
    if "values" in spec:
        values = spec["values"]
        if not isinstance(values, list) or not values:
            raise ConfigError(f"sweep spec: empty design: '{where}.values' must list at least one value")
        for value in values:
            _checked(build, name, value, where)
        return {"name": name, "values": list(values)}
    low, high = _range(spec["range"], where)
    for end in (low, high):
        _checked(build, name, int(end) if integer else end, f"{where}.range [{low}, {high}]")
    levels = spec.get("levels", 3)
    if isinstance(levels, bool) or not isinstance(levels, int) or levels < 1:
        raise ConfigError(f"sweep spec: '{where}.levels' = {levels!r} is invalid: allowed an integer >= 1")
    if "levels" in spec and method != "grid":
        raise ConfigError(f"sweep spec: '{where}.levels' is for the grid design only (method is {method!r})")
    return {"name": name, "range": (low, high), "levels": levels, "integer": integer}


def _range(value: Any, where: str) -> tuple[float, float]:
    ok = (isinstance(value, list) and len(value) == 2
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
    if not ok or value[0] > value[1]:
        raise ConfigError(f"sweep spec: '{where}.range' = {value!r} is invalid: allowed [low, high], low <= high")
    return float(value[0]), float(value[1])


def _checked(build: Any, name: str, value: Any, where: str) -> None:
    try:
        build({name: value})
    except ConfigError as error:
        raise ConfigError(f"sweep spec: '{where}': {error}") from None


def _input(spec: Any, fields: Mapping[str, Any], build: Any) -> dict[str, Any]:
    """The commanded input's schedule kinds, value range, length and segments."""
    spec = _require_mapping(spec, "design.input")
    _reject_unknown(spec, _INPUT_KEYS, "design.input")
    name = spec.get("parameter")
    if name not in fields or not isinstance(fields[name].default, tuple):
        knot_fields = [f for f, v in fields.items() if isinstance(v.default, tuple) and f.endswith("schedule")]
        raise ConfigError(f"sweep spec: 'design.input.parameter' = {name!r} is invalid: allowed a schedule of "
                          f"the scene ({', '.join(knot_fields) or 'it has none'})")
    kinds = spec.get("kinds", list(schedules.KINDS))
    if not isinstance(kinds, list) or not kinds or any(k not in schedules.KINDS for k in kinds):
        raise ConfigError(f"sweep spec: 'design.input.kinds' = {kinds!r} is invalid: allowed a non-empty list of "
                          f"{', '.join(schedules.KINDS)}")
    low, high = _range(spec.get("range"), "design.input")
    for end in (low, high):
        _checked(build, name, [[0.0, end]], f"design.input.range [{low}, {high}]")
    defaults = build({})
    duration = spec.get("duration", defaults.get("t_end", 0.0) - defaults.get("settle_time", 0.0))
    if not (isinstance(duration, (int, float)) and duration > 0):
        raise ConfigError(f"sweep spec: 'design.input.duration' = {duration!r} is invalid: allowed > 0 s")
    segments = spec.get("segments", 4)
    if isinstance(segments, bool) or not isinstance(segments, int) or not 1 <= segments <= 100:
        raise ConfigError(f"sweep spec: 'design.input.segments' = {segments!r} is invalid: allowed an integer 1–100")
    draws = spec.get("draws", 1)
    if isinstance(draws, bool) or not isinstance(draws, int) or not 1 <= draws <= 1000:
        raise ConfigError(f"sweep spec: 'design.input.draws' = {draws!r} is invalid: allowed an integer 1–1000")
    return {"parameter": name, "kinds": kinds, "range": (low, high), "duration": float(duration), "segments": segments,
            "draws": draws}


def _rows_with_draws(rows: list[dict[str, Any]], input_spec: dict[str, Any]) -> list[dict[str, Any]]:
    """Each point of the design `draws` times, the schedule kinds taken in turn from the point's own
    drawn kind. Ordered draw by draw (every point's first draw, then every point's second, ...), so
    that a sweep's first pass settles each point once and the later passes start from the cache
    instead of waiting on a worker that is settling the same point."""
    kinds = input_spec["kinds"]
    expanded = []
    for draw in range(input_spec["draws"]):
        for row in rows:
            kind = kinds[(kinds.index(row["input_kind"]) + draw) % len(kinds)]
            expanded.append({**row, "input_kind": kind})
    return expanded


def _design_rows(method: str, design: Mapping[str, Any], dimensions: list[dict[str, Any]],
                 input_spec: dict[str, Any] | None, seed: int) -> list[dict[str, Any]]:
    """The varied values of each case (the input's kind under "input_kind")."""
    if input_spec is not None:
        dimensions = [*dimensions, {"name": "input_kind", "values": input_spec["kinds"]}]
    if method == "grid":
        if "runs" in design:
            raise ConfigError("sweep spec: 'design.runs' is for the random and latin-hypercube designs; a grid "
                              "has the product of its levels")
        axes = [d["values"] if "values" in d else _levels(d) for d in dimensions]
        return [dict(zip([d["name"] for d in dimensions], point)) for point in itertools.product(*axes)]
    runs = design.get("runs")
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise ConfigError(f"sweep spec: empty design: 'design.runs' = {runs!r} is invalid: allowed an integer >= 1")
    rng = np.random.default_rng(seed)
    columns = {}
    for d in dimensions:
        if method == "random":
            unit = rng.random(runs)
        else:  # Latin hypercube: one point in each of `runs` equal strata, strata in random order
            unit = (rng.permutation(runs) + rng.random(runs)) / runs
        if "values" in d:
            columns[d["name"]] = [d["values"][min(int(u * len(d["values"])), len(d["values"]) - 1)] for u in unit]
        else:
            low, high = d["range"]
            values = low + unit * (high - low)
            columns[d["name"]] = ([round(v) for v in values] if d["integer"] else [float(v) for v in values])
    return [{name: column[k] for name, column in columns.items()} for k in range(runs)]


def _levels(dimension: dict[str, Any]) -> list[Any]:
    low, high = dimension["range"]
    points = np.linspace(low, high, dimension["levels"])
    return sorted({round(p) for p in points}) if dimension["integer"] else [float(p) for p in points]
