"""Robot metrics (docs/design.md §3.8): slip (dissertation Eq. 4.8) and sinkage below the bed's free
surface (terrasph.terrain.sph_coupling.free_surface on the SPH)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["sinkage", "slip"]


def slip(forward_speed: np.ndarray | float, omega: np.ndarray | float, radius: float) -> np.ndarray:
    """Slip of a wheel of `radius` R (m) turning clockwise at `omega` (rad/s) while its axle moves at
    `forward_speed` v_x (m/s), Eq. 4.8:

        s = 1 − v_x/(Rω)   if v_x < Rω   (spinning: s > 0; s = 1 when the axle stands still)
        s = Rω/v_x − 1     if v_x ≥ Rω   (skidding: s < 0)

    s lies in [−1, 1] when v_x ≥ 0 and Rω ≥ 0 (a wheel sliding forward without turning has s = −1);
    it is NaN where both are 0. Eq. 4.8 is meant for a wheel driven forward: when v_x and Rω have
    opposite signs (an axle pushed back while the wheel turns forward) it gives |s| > 1, unbounded
    as Rω → 0. For a leg-wheel, R is the radius of the circle through its leg tips (the shape's
    ``radius``).
    """
    if isinstance(forward_speed, (float, int, np.floating, np.integer)) and \
            isinstance(omega, (float, int, np.floating, np.integer)):
        return np.float64(_slip_of_numbers(float(forward_speed), radius * float(omega)))
    v = np.asarray(forward_speed, dtype=float)
    rolling = radius * np.asarray(omega, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        spinning = 1.0 - v / rolling
        skidding = rolling / v - 1.0
        result = np.where(v < rolling, spinning, skidding)
    return np.where((v == 0) & (rolling == 0), np.nan, result)


def _slip_of_numbers(v: float, rolling: float) -> float:
    """Eq. 4.8 (:func:`slip`) of one forward speed `v` and rolling speed `rolling` = Rω, in Python's
    floats (a robot's sample, 20 times faster than through arrays), with numpy's IEEE division: x/±0
    is ±inf, 0/0 and NaN/0 are NaN."""
    if v == 0 and rolling == 0:
        return math.nan
    if v < rolling:
        return 1.0 - _divide(v, rolling)
    return _divide(rolling, v) - 1.0


def _divide(numerator: float, denominator: float) -> float:
    """numerator / denominator as IEEE 754 (and numpy) divides: by ±0, ±inf or NaN rather than an error."""
    if denominator != 0:
        return numerator / denominator
    if numerator == 0 or math.isnan(numerator):
        return math.nan
    return math.copysign(math.inf, numerator) * math.copysign(1.0, denominator)


def sinkage(lowest_z: np.ndarray | float, surface_level: float) -> np.ndarray:
    """Depth (m) of a body's lowest point below the undisturbed free surface z = `surface_level`
    (measured on the settled bed); negative while the body is above it."""
    if isinstance(lowest_z, (float, int, np.floating, np.integer)):  # a sample's: the same difference, unboxed
        return np.float64(surface_level - float(lowest_z))
    return surface_level - np.asarray(lowest_z, dtype=float)
