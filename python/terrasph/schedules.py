"""Commanded inputs as time series: piecewise-linear schedules u(t) given by knots (t_i, u_i).

A schedule holds u_0 before its first knot and its last value after its last knot, and is linear
between consecutive knots; two knots at the same time make a step (u jumps to the later knot's
value at that time). Constant inputs, steps, ramps and random piecewise inputs are all such
knot lists (:func:`constant`, :func:`step`, :func:`ramp`, :func:`random_piecewise`); a sequence
model learns little from constant inputs, so sweeps draw the varied kinds.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from terrasph.config import ConfigError

__all__ = ["KINDS", "check_knots", "constant", "draw", "evaluate", "ramp", "random_piecewise", "step"]

Knots = tuple[tuple[float, float], ...]

#: the kinds of schedule :func:`draw` makes
KINDS = ("constant", "step", "ramp", "random")


def check_knots(name: str, knots: Sequence[Sequence[float]], lower: float = -math.inf,
                upper: float = math.inf) -> Knots:
    """`knots` as a tuple of (t, u) pairs; ConfigError naming parameter `name` unless the times are
    finite, ≥ 0 and non-decreasing and the values finite and within [`lower`, `upper`]."""
    try:
        pairs = tuple((float(t), float(u)) for t, u in knots)
    except (TypeError, ValueError):
        raise ConfigError(f"parameter '{name}' = {knots!r} is invalid: allowed a list of (time, value) pairs") from None
    times = [t for t, _ in pairs]
    if not all(math.isfinite(t) and t >= 0 for t in times) or any(b < a for a, b in itertools.pairwise(times)):
        raise ConfigError(f"parameter '{name}': times {times} are invalid: allowed finite, >= 0, non-decreasing")
    for _, value in pairs:
        if not (math.isfinite(value) and lower <= value <= upper):
            raise ConfigError(f"parameter '{name}': value {value!r} is invalid: allowed in [{lower}, {upper}]")
    return pairs


def evaluate(knots: Knots, time: np.ndarray | float) -> np.ndarray:
    """u(`time`) of the schedule (module docstring); `knots` must be non-empty."""
    t = np.asarray(time, dtype=float)
    times = np.array([k[0] for k in knots])
    values = np.array([k[1] for k in knots])
    # i: the last knot at or before t (after a step, the later of two knots at the same time)
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(knots) - 1)
    j = np.minimum(i + 1, len(knots) - 1)
    span = times[j] - times[i]
    with np.errstate(divide="ignore", invalid="ignore"):
        fraction = np.where(span > 0, np.clip((t - times[i]) / span, 0.0, 1.0), 0.0)
    result = np.where(t < times[0], values[0], values[i] + fraction * (values[j] - values[i]))
    return result


def constant(value: float) -> Knots:
    """u(t) = `value`."""
    return ((0.0, value),)


def step(before: float, after: float, at: float) -> Knots:
    """u = `before` until `at`, then `after`."""
    return ((0.0, before), (at, before), (at, after))


def ramp(start: float, end: float, t_start: float, t_end: float) -> Knots:
    """u = `start` until `t_start`, linear to `end` at `t_end`, then `end`."""
    return ((0.0, start), (t_start, start), (t_end, end))


def random_piecewise(rng: np.random.Generator, duration: float, lower: float, upper: float,
                     segments: int) -> Knots:
    """`segments` segments of random lengths over [0, `duration`], each a hold at a random level in
    [`lower`, `upper`] entered by a step or by a ramp over a random part of the segment."""
    bounds = np.sort(rng.uniform(0.0, duration, segments - 1)) if segments > 1 else np.array([])
    starts = np.concatenate([[0.0], bounds])
    levels = rng.uniform(lower, upper, segments)
    knots: list[tuple[float, float]] = [(0.0, float(levels[0]))]
    for k in range(1, segments):
        t, length = float(starts[k]), float(np.append(starts, duration)[k + 1] - starts[k])
        if rng.random() < 0.5:
            knots += [(t, knots[-1][1]), (t, float(levels[k]))]
        else:
            knots += [(t, knots[-1][1]), (t + float(rng.uniform(0.2, 0.8)) * length, float(levels[k]))]
    return tuple(knots)


def draw(kind: str, rng: np.random.Generator, duration: float, lower: float, upper: float,
         segments: int = 4) -> Knots:
    """A schedule of `kind` (one of KINDS) over [0, `duration`] with values in [`lower`, `upper`],
    its levels and times drawn from `rng`."""
    if kind == "constant":
        return constant(float(rng.uniform(lower, upper)))
    if kind == "step":
        a, b = rng.uniform(lower, upper, 2)
        return step(float(a), float(b), float(rng.uniform(0.2, 0.8)) * duration)
    if kind == "ramp":
        a, b = rng.uniform(lower, upper, 2)
        t0, t1 = np.sort(rng.uniform(0.0, duration, 2))
        return ramp(float(a), float(b), float(t0), float(t1))
    if kind == "random":
        return random_piecewise(rng, duration, lower, upper, segments)
    raise ConfigError(f"schedule kind {kind!r} is invalid: allowed one of {', '.join(KINDS)}")
