"""Robot metrics (docs/design.md §3.8): slip (dissertation Eq. 4.8), the bed's undisturbed free surface
and sinkage below it."""

from __future__ import annotations

import numpy as np

__all__ = ["free_surface", "sinkage", "slip"]


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
    v = np.asarray(forward_speed, dtype=float)
    rolling = radius * np.asarray(omega, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        spinning = 1.0 - v / rolling
        skidding = rolling / v - 1.0
        result = np.where(v < rolling, spinning, skidding)
    return np.where((v == 0) & (rolling == 0), np.nan, result)


def sinkage(lowest_z: np.ndarray | float, surface_level: float) -> np.ndarray:
    """Depth (m) of a body's lowest point below the undisturbed free surface z = `surface_level`
    (measured on the settled bed); negative while the body is above it."""
    return surface_level - np.asarray(lowest_z, dtype=float)


def free_surface(grains: np.ndarray, spacing: float, disturbed: list[tuple[float, float]],
                 margin: float) -> float:
    """Height (m) of the bed's undisturbed free surface: the grains (N × 2, x and z in m, on the
    lattice of `spacing` Δx) are binned into columns Δx wide, each column's surface is the top of
    its highest grain's cell (z + Δx/2), and the median is taken over the columns whose centre lies
    farther than `margin` from every `disturbed` interval [x_lo, x_hi] (the robot's parts). The
    median ignores a few grains thrown up above the bed. NaN if no column is left."""
    column = np.floor(grains[:, 0] / spacing).astype(np.int64)
    first = column.min()
    tops = np.full(column.max() - first + 1, -np.inf)
    np.maximum.at(tops, column - first, grains[:, 1] + 0.5 * spacing)
    centres = (np.arange(len(tops)) + first + 0.5) * spacing
    keep = np.isfinite(tops)
    for low, high in disturbed:
        keep &= (centres < low - margin) | (centres > high + margin)
    return float(np.median(tops[keep])) if keep.any() else float("nan")
