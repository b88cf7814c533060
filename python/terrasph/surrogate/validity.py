"""The validity range of a surrogate trained on leg-wheel runs: what its training runs covered.

One definition, used when a model is trained (:func:`training_validity`, stored under the key
``"validity"`` of the model file's metadata, docs/lstm_format.md) and before a prediction
(:meth:`Validity.violations`, :meth:`Validity.check`). A run is inside the range when

* every input feature stays within its [min, max] over the training runs (a series such as the
  commanded ω(t) over all its steps, a fixed parameter such as the load at its value);
* its morphology is one of the training runs' morphologies;
* its driven phase is no longer than the longest training run's (the model never saw later times);
* every condition the training runs shared (:data:`CONDITION_FIELDS`: the geometry, resolution,
  fidelity, bed and motor) has the training value, and a condition the runs varied without
  taking it as an input lies within their range (a number) or among their values (anything else).

What a run does not say is not checked: a CSV or .npy of inputs carries only the features, the
morphology (its one-hot columns) and its length.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from terrasph.config import ConfigError
from terrasph.surrogate.dataset import Run, common_time_step

__all__ = ["CONDITION_FIELDS", "MORPHOLOGY_PREFIX", "PHASE_FEATURES", "Validity", "run_conditions", "training_validity"]

#: the leg-wheel configuration fields that set a run's physics besides the model's inputs (the load,
#: the commanded ω(t), the morphology): geometry, resolution, fidelity, the bed, the motor and the pause
CONDITION_FIELDS = ("legs", "leg_length", "thickness", "width", "foot_ratio", "spacing", "bed_width", "bed_depth",
                    "start_x", "settle_time", "fidelity", "numerics", "terrain", "rft_table", "wheel_density",
                    "motor_gain", "motor_torque", "mu1_deg", "mu2_deg", "water_content")
#: input columns that are one-hot indicators of the morphology (terrasph.surrogate.robot_dataset)
MORPHOLOGY_PREFIX = "wheel:"
#: the legs' commanded phase, sin and cos of legs·θ with θ = ∫ω_cmd dt (terrasph.surrogate.robot_dataset.
#: commanded_phase): derived from omega_cmd, whose range is checked, so they have no range of their own
PHASE_FEATURES = ("leg_phase_sin", "leg_phase_cos")
_RTOL = 1e-9  # values equal to a bound up to rounding are inside


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _close(a: Any, b: Any) -> bool:
    if _is_number(a) and _is_number(b):
        return math.isclose(a, b, rel_tol=_RTOL, abs_tol=_RTOL)
    return a == b


def _fmt(value: Any) -> str:
    return f"{value:.6g}" if _is_number(value) else repr(value)


@dataclass(frozen=True)
class Validity:
    """What a model's training runs covered (module docstring).

    Attributes:
        dt: sampling interval of the model's time steps (s).
        duration: longest driven phase of the training runs (s).
        ranges: name → (min, max): each input feature (series over all steps) and each numeric
            condition the training runs varied without taking it as an input.
        morphologies: the training runs' morphologies (empty for a model without them).
        fixed: condition → the value all training runs shared.
        choices: condition → the values of a non-numeric condition the training runs varied.
        runs: number of training runs.
        held_out_error: measured error on held-out runs (split → target → {"rmse", "nrmse"}, and
            "runs": split → count); filled by the study that measured it, empty otherwise.
    """

    dt: float
    duration: float
    ranges: dict[str, tuple[float, float]]
    morphologies: tuple[str, ...] = ()
    fixed: dict[str, Any] = field(default_factory=dict)
    choices: dict[str, list[Any]] = field(default_factory=dict)
    runs: int = 0
    held_out_error: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """The JSON object stored as ``metadata["validity"]``."""
        return {"dt": self.dt, "duration": self.duration,
                "ranges": {name: [float(lo), float(hi)] for name, (lo, hi) in self.ranges.items()},
                "morphologies": list(self.morphologies), "fixed": dict(self.fixed),
                "choices": {name: list(values) for name, values in self.choices.items()},
                "runs": self.runs, "held_out_error": dict(self.held_out_error)}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Validity:
        """Inverse of :meth:`to_json`; ValueError naming the entry for a malformed object."""
        try:
            return cls(dt=float(data["dt"]), duration=float(data["duration"]),
                       ranges={str(k): (float(v[0]), float(v[1])) for k, v in data["ranges"].items()},
                       morphologies=tuple(data.get("morphologies", ())), fixed=dict(data.get("fixed", {})),
                       choices={str(k): list(v) for k, v in data.get("choices", {}).items()},
                       runs=int(data.get("runs", 0)), held_out_error=dict(data.get("held_out_error", {})))
        except (KeyError, TypeError, ValueError, IndexError, AttributeError) as error:
            raise ValueError(f"model metadata: 'validity' is malformed ({type(error).__name__}: {error})") from None

    @classmethod
    def from_metadata(cls, metadata: Mapping[str, Any]) -> Validity | None:
        """The validity stored in a model file's metadata, or None for a model trained without one."""
        return cls.from_json(metadata["validity"]) if "validity" in metadata else None

    def violations(self, conditions: Mapping[str, Any]) -> list[str]:
        """One message per way the run described by `conditions` (:func:`run_conditions`) leaves
        the range; empty inside it."""
        out = []
        for name, (lo, hi) in self.ranges.items():
            if name not in conditions:
                continue
            value = conditions[name]
            low, high = (value, value) if _is_number(value) else value
            tol = _RTOL * max(abs(lo), abs(hi), 1.0)
            if low < lo - tol or high > hi + tol:
                shown = _fmt(low if low < lo - tol else high)
                what = f"parameter '{name}' = {shown} is" if _is_number(value) else f"input '{name}' reaches {shown},"
                out.append(f"{what} outside the model's validity range [{_fmt(lo)}, {_fmt(hi)}]")
        morphology = conditions.get("wheel")
        if self.morphologies and morphology is not None and morphology not in self.morphologies:
            out.append(f"parameter 'wheel' = {morphology!r} is outside the model's morphologies "
                       f"{', '.join(self.morphologies)}")
        duration = conditions.get("duration")
        if duration is not None and duration > self.duration + 0.5 * self.dt:
            out.append(f"the driven phase of {_fmt(duration)} s is longer than the model's "
                       f"{_fmt(self.duration)} s (its longest training run)")
        for name, value in self.fixed.items():
            if name in conditions and not _close(conditions[name], value):
                out.append(f"parameter '{name}' = {_fmt(conditions[name])} differs from the model's "
                           f"{_fmt(value)} (all its training runs)")
        for name, values in self.choices.items():
            if name in conditions and not any(_close(conditions[name], v) for v in values):
                out.append(f"parameter '{name}' = {_fmt(conditions[name])} is not one of the model's "
                           f"{', '.join(map(_fmt, values))}")
        return out

    def check(self, conditions: Mapping[str, Any], run: str = "the run") -> None:
        """Raise ConfigError (one line, every violation) if `conditions` leave the range."""
        found = self.violations(conditions)
        if found:
            raise ConfigError(f"{run}: {'; '.join(found)} (--extrapolate predicts anyway)")


def run_conditions(run: Run, features: Sequence[str], config: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """What :meth:`Validity.violations` checks of `run`: each input feature's value (a fixed
    parameter) or (min, max) (a series), the morphology, the driven phase's duration and, given
    the run's leg-wheel `config` (all its fields), its :data:`CONDITION_FIELDS`."""
    conditions: dict[str, Any] = {"duration": float(run.time[-1] - run.time[0])}
    indicators = [name for name in features if name.startswith(MORPHOLOGY_PREFIX)]
    for name in features:
        if name in indicators or name in PHASE_FEATURES:
            continue
        if name in run.series:
            values = run.series[name]
            conditions[name] = (float(values.min()), float(values.max()))
        else:
            conditions[name] = float(run.column(name)[0])
    if config is not None:
        conditions["wheel"] = config["wheel"]
        conditions.update({name: config[name] for name in CONDITION_FIELDS if name in config})
    elif indicators:
        conditions["wheel"] = _one_hot_morphology(run, indicators)
    return conditions


def _one_hot_morphology(run: Run, indicators: Sequence[str]) -> str:
    """The morphology whose indicator column is 1 at every step (the others 0)."""
    columns = run.matrix(indicators)
    on = [name for name, column in zip(indicators, columns.T) if np.all(column == 1.0)]
    if len(on) != 1 or not np.all((columns == 0.0) | (columns == 1.0)) or not np.all(columns.sum(axis=1) == 1.0):
        raise ConfigError(f"{run.name}: the morphology columns {', '.join(indicators)} must be one-hot "
                          "(one of them 1 and the others 0 at every step)")
    return on[0].removeprefix(MORPHOLOGY_PREFIX)


def training_validity(runs: Sequence[Run], features: Sequence[str],
                      configs: Sequence[Mapping[str, Any]]) -> Validity:
    """The validity of a model trained on `runs` (the training split) with the inputs `features`;
    `configs` are the runs' leg-wheel configurations (all fields), in the same order."""
    if not runs or len(runs) != len(configs):
        raise ValueError(f"training_validity needs one configuration per run, got {len(runs)} runs and "
                         f"{len(configs)} configurations")
    each = [run_conditions(run, features, config) for run, config in zip(runs, configs)]
    ranges: dict[str, tuple[float, float]] = {}
    fixed: dict[str, Any] = {}
    choices: dict[str, list[Any]] = {}
    for name in [f for f in features if not f.startswith(MORPHOLOGY_PREFIX)] + list(CONDITION_FIELDS):
        values = [c[name] for c in each if name in c]
        if not values:
            continue
        if name in features or (all(_is_number(v) for v in values) and len(set(values)) > 1):
            lows = [v if _is_number(v) else v[0] for v in values]
            highs = [v if _is_number(v) else v[1] for v in values]
            ranges[name] = (float(min(lows)), float(max(highs)))
        elif all(_close(v, values[0]) for v in values):
            fixed[name] = values[0]
        else:
            choices[name] = [v for k, v in enumerate(values) if all(not _close(v, w) for w in values[:k])]
    return Validity(dt=common_time_step(runs), duration=max(c["duration"] for c in each), ranges=ranges,
                    morphologies=tuple(sorted({c["wheel"] for c in each})), fixed=fixed, choices=choices,
                    runs=len(runs))
