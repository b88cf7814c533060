"""Prescribed rigid-body motion: a schedule of pieces with constant velocity and spin (docs/design.md §3.6).

A :class:`Motion` starts when its body is added to a simulation (t = 0 of the schedule) and
holds the body still after its last piece. Within a piece the reference point moves at a
constant velocity and the body spins at a constant rate about it, so the pose is known in closed
form and body particles follow it exactly, whatever the time step. Spins are clockwise-positive
in the x–z plane (docs/design.md §2): a leg of a robot moving in +x sweeps with ω > 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from terrasph.config import ConfigError

__all__ = ["Hold", "Motion", "Move", "Rotate", "hold_then_rotate"]


def _check_duration(name: str, duration: float, allow_infinite: bool) -> None:
    ok = isinstance(duration, (int, float)) and not isinstance(duration, bool) and duration > 0 \
        and not math.isnan(duration) and (allow_infinite or math.isfinite(duration))
    if not ok:
        allowed = "> 0 s (inf allowed for the last piece)" if allow_infinite else "a finite number > 0 s"
        raise ConfigError(f"parameter '{name}' = {duration!r} is invalid: allowed {allowed}")


def _check_finite(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)):
        raise ConfigError(f"parameter '{name}' = {value!r} is invalid: allowed a finite number")


@dataclass(frozen=True)
class Hold:
    """Stay at rest for `duration` seconds."""

    duration: float

    def row(self) -> tuple[float, float, float, float]:
        return (float(self.duration), 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Rotate:
    """Spin about the (fixed) reference point at `omega` rad/s, clockwise-positive, for `duration` s."""

    duration: float
    omega: float

    def row(self) -> tuple[float, float, float, float]:
        return (float(self.duration), 0.0, 0.0, float(self.omega))


@dataclass(frozen=True)
class Move:
    """Translate the reference point at `velocity` (vx, vz) m/s, spinning at `omega` rad/s, for `duration` s."""

    duration: float
    velocity: tuple[float, float]
    omega: float = 0.0

    def row(self) -> tuple[float, float, float, float]:
        vx, vz = self.velocity
        return (float(self.duration), float(vx), float(vz), float(self.omega))


Piece = Hold | Rotate | Move


@dataclass(frozen=True)
class Motion:
    """A schedule of pieces run one after another; the body holds still after the last one."""

    pieces: tuple[Piece, ...] = ()

    def __post_init__(self) -> None:
        pieces = tuple(self.pieces)
        object.__setattr__(self, "pieces", pieces)
        for k, piece in enumerate(pieces):
            if not isinstance(piece, (Hold, Rotate, Move)):
                raise ConfigError(f"motion piece {k} is a {type(piece).__name__}; allowed Hold, Rotate or Move")
            _check_duration(f"motion[{k}].duration", piece.duration, allow_infinite=k == len(pieces) - 1)
            if isinstance(piece, (Rotate, Move)):
                _check_finite(f"motion[{k}].omega", piece.omega)
            if isinstance(piece, Move):
                if len(piece.velocity) != 2:
                    raise ConfigError(f"parameter 'motion[{k}].velocity' must be (vx, vz)")
                for c, v in zip("xz", piece.velocity):
                    _check_finite(f"motion[{k}].velocity.{c}", v)

    @property
    def duration(self) -> float:
        """Total length of the schedule (s); inf if the last piece never ends."""
        return sum(p.duration for p in self.pieces)

    def rows(self) -> list[tuple[float, float, float, float]]:
        """Rows (duration, vx, vz, ω) for the core."""
        return [p.row() for p in self.pieces]

    def angle_at(self, t: float, start_angle: float = 0.0) -> float:
        """Clockwise angle (rad) after `t` seconds of the schedule."""
        angle, begin = start_angle, 0.0
        for p in self.pieces:
            elapsed = min(max(t - begin, 0.0), p.duration)
            angle += elapsed * getattr(p, "omega", 0.0)
            begin += p.duration
        return angle


def hold_then_rotate(hold: float, omega: float, sweep: float) -> Motion:
    """Rest for `hold` s, then rotate clockwise at `omega` rad/s through `sweep` rad (then rest).

    With ``hold = 0`` the rotation starts at once.
    """
    _check_finite("omega", omega)
    if not omega > 0:
        raise ConfigError(f"parameter 'omega' = {omega!r} is invalid: allowed > 0 rad/s (clockwise)")
    if not (isinstance(sweep, (int, float)) and sweep > 0 and math.isfinite(sweep)):
        raise ConfigError(f"parameter 'sweep' = {sweep!r} is invalid: allowed a finite angle > 0 rad")
    if hold != 0:
        _check_duration("hold", hold, allow_infinite=False)
    pieces: list[Piece] = [Hold(hold)] if hold > 0 else []
    pieces.append(Rotate(sweep / omega, omega))
    return Motion(tuple(pieces))
