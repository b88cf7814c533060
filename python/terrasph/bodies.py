"""Rigid-body geometry: robot legs, wheels and hybrid leg-wheels as particles (docs/design.md §3.6).

Every generator returns a :class:`BodyShape` in the body's own frame: the reference point (hip
axle of a leg, centre of a wheel) is at the origin, x forward (the direction the robot travels),
z up, SI units. Particles fill the part's cross-section at cell centres of spacing Δx, the same
convention as :func:`terrasph.geometry.lattice_block`: a part of thickness t gets
``round(t/Δx)`` rows exactly Δx apart, centred on its centre line, so the realised thickness may
differ from the request by up to Δx/2; along the centre line (straight or curved) particles are
spaced by L/round(L/Δx) ≈ Δx, so both ends are hit exactly. Each particle carries the unit outward
normal of the nearest face of the part's outline (out of the body, into the sand); on an exact tie
(the middle row of an odd number of rows) the first face in outline order wins, which is the −x
face of a straight leg and the convex face of a C-leg -- the face that leads at the bottom of a
clockwise (positive) sweep.

Shapes, with the readings of the dissertation (chapter 3, Fig. 1.2, 3.1, 3.3, 3.4, 4.2) used here.
The figures themselves are not in the text; the readings follow from its words:

* ``radius`` R is the distance from the axle to the leg tip along the leg's centre line (hip to
  toe; for a C-leg the chord of the half circle, i.e. its diameter). For the chapter 3 legs
  ("2R = 7.62 cm") the leg length hip-to-toe is 2R = 7.62 cm, so pass ``radius=0.0762``; for
  the chapter 4 leg-wheels ("2R = 8 cm", slip Eq. 4.8 uses Rω) the wheel radius is 4 cm, so pass
  ``radius=0.04``.
* Flat leg: a straight bar from the hip to the tip at (0, −R) (pointing down at angle 0).
* C-leg: a half circle of diameter R (chord hip → toe, vertical at angle 0) whose bulge is on the
  *rear* (−x) side and whose opening faces forward (+x): the letter "C" in a side view with the
  robot moving in +x. Its lower end then points forward like the foot of the L-leg (letter "L"),
  the pairing the dissertation makes (Fig. 3.3 compares the L-leg with the C-leg, Fig. 3.4 the
  reversed L-leg with the reversed C-leg; "the resistive forces experienced by the L shaped legs
  are in between those obtained for the flat leg and C-leg", "the lift forces of reversed L shaped
  legs are in between those obtained with the flat leg and reversed C-leg"). Under clockwise
  rotation from θ = −π/4 the C-leg meets the sand with its convex underside (more lift, "the C-leg
  profile helps increase the net lift significantly"), while the reversed C-leg enters toe first,
  like the backward foot for which "it is easier for the leg to intrude clockwise" (less lift).
* Reversed C-leg: the mirror image x → −x (bulge forward, opening backward).
* L-leg: the flat leg plus a foot at its tip pointing forward (+x), "flat legs with the forward
  and backward foot" (ch. 3 conclusions). The foot/leg ratio ``fl`` is foot length / leg length
  with the leg length R; the foot is measured from the leg's centre line to the toe, so the toe is
  at x = fl·R, and its underside is flush with the leg's tip at z = −R.
* Reversed L-leg: the mirror image (foot pointing backward, −x).
* Wheel: the rim only, an annulus whose outer surface is at R.
* Leg-wheel: n copies of a leg rotated about the axle by 2π/n (Fig. 4.2), spokes only.

Rotation convention (docs/design.md §2): positive angles are clockwise seen with x to the right and z up,
so legs and wheels turn by positive angles when the robot moves in +x. A clockwise quarter turn
takes a leg pointing down (tip at (0, −R)) to point backward (tip at (−R, 0)); over
−π/4 ≤ θ ≤ π/4 the tip sweeps from front-down to back-down and pushes sand backward (thrust +x).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .geometry import convex_hull, wall_layers_needed

__all__ = [
    "SPOKES",
    "BodyShape",
    "c_leg",
    "check_thickness",
    "flat_leg",
    "l_leg",
    "leg_wheel",
    "minimum_thickness",
    "plate",
    "reversed_c_leg",
    "reversed_l_leg",
    "rotation_matrix",
    "wheel",
]


def rotation_matrix(angle: float) -> np.ndarray:
    """2×2 matrix of a *clockwise* rotation by `angle` radians in the x–z plane (z up).

    Applied to column vectors: (x, z) ↦ (x cos θ + z sin θ, −x sin θ + z cos θ).
    """
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, s], [-s, c]])


@dataclass(frozen=True)
class BodyShape:
    """Particles of a rigid body in its own frame (reference point = hip axle / wheel centre at the origin).

    Attributes:
        name: shape name, e.g. ``"c-leg"`` or ``"c-leg-wheel-5"``.
        position: (M, 2) body-frame particle positions (m), cell centres of spacing Δx.
        normal: (M, 2) unit outward normals of the nearest body surface (out of the body, into the
            sand).
        spacing: Δx (m).
        thickness: requested thickness of the part (m); the realised one is round(t/Δx)·Δx.
        width: out-of-plane width (m). Particles carry per-metre-of-depth quantities; forces are
            reported in N for this real width (per-depth force × width), docs/design.md §2.
        radius: R, distance from the axle to the leg tip along the centre line / to the wheel
            rim (m) -- the construction parameter (an L-leg's toe is at √(1 + fl²)·R).
        outline: the body's boundary in its own frame, the one geometry the particles fill and that
            surface models (resistive force theory) read: closed polygons (last vertex not
            repeated), each oriented with the body on its left (outer boundaries counter-clockwise,
            holes clockwise in x–z). Loops may overlap where parts meet (a leg-wheel's spokes at
            the hub); a consumer that needs the outer surface alone drops what lies inside another
            loop. Empty for a shape given as particles only.
    """

    name: str
    position: np.ndarray
    normal: np.ndarray
    spacing: float
    thickness: float
    width: float
    radius: float
    outline: tuple[np.ndarray, ...] = ()

    def __post_init__(self) -> None:
        pos = np.asarray(self.position, dtype=float)
        nrm = np.asarray(self.normal, dtype=float)
        if pos.ndim != 2 or pos.shape[1] != 2 or nrm.shape != pos.shape or len(pos) == 0:
            raise ValueError("position and normal must be equal (M, 2) arrays with M >= 1")
        pos.setflags(write=False)
        nrm.setflags(write=False)
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "normal", nrm)
        loops = tuple(np.array(loop, dtype=float) for loop in self.outline)
        for loop in loops:
            if loop.ndim != 2 or loop.shape[1] != 2 or len(loop) < 3:
                raise ValueError("each outline loop must be an (K, 2) array with K >= 3 vertices")
            loop.setflags(write=False)
        object.__setattr__(self, "outline", loops)

    def __len__(self) -> int:
        return len(self.position)

    def transformed(self, angle: float, origin: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Positions and normals after a rotation by `angle` (radians, positive = clockwise,
        docs/design.md §2) about the reference point, then a translation of the reference point to `origin`."""
        return self.positions_at(angle, origin), self.normal @ rotation_matrix(angle).T

    def positions_at(self, angle: float, origin: tuple[float, float]) -> np.ndarray:
        """The positions of :meth:`transformed` alone."""
        return self.position @ rotation_matrix(angle).T + np.asarray(origin, dtype=float)

    def transformed_outline(self, angle: float, origin: tuple[float, float]) -> tuple[np.ndarray, ...]:
        """The outline loops at the pose of :meth:`transformed` (rotation then translation)."""
        rot = rotation_matrix(angle)
        return tuple(loop @ rot.T + np.asarray(origin, dtype=float) for loop in self.outline)

    def lowest_point(self, angle: float = 0.0, origin: tuple[float, float] | np.ndarray = (0.0, 0.0)) -> float:
        """Lowest z of the body at this pose: min z of its particles minus Δx/2 (the particles are
        cell centres), for sinkage (docs/design.md §3.8). Only the particles on the rim of the shape
        (:attr:`rim`) can be lowest at any pose, so only they are moved: the same value, bit for bit,
        as the minimum over all particles (the same product for each)."""
        rim = self.rim
        return float((rim @ rotation_matrix(angle).T + np.asarray(origin, dtype=float))[:, 1].min()
                     - 0.5 * self.spacing)

    @functools.cached_property
    def rim(self) -> np.ndarray:
        """The particles that may be lowest (or farthest in any direction) at some pose: those within
        :data:`RIM_TOLERANCE` of their convex hull's boundary. A particle deeper inside lies farther than
        that above the lowest one at every pose, more than the rounding of the positions' products, so
        the minimum of any coordinate at a pose is the same over these as over all particles."""
        return self.position[_near_hull(self.position, RIM_TOLERANCE * max(self.spacing, 1e-300))]


#: particles within this many spacings of their convex hull's boundary make a shape's rim
#: (:attr:`BodyShape.rim`): far above the rounding of a rotated position (~1e-16 of the shape's size),
#: far below a spacing, so the rim is the hull's vertices and the particles on its edges
RIM_TOLERANCE = 1e-6


def _near_hull(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices, in order, of the (M, 2) `points` within `tolerance` (m) of their convex hull's boundary
    (of a point inside a convex polygon, its least distance to the lines of the edges)."""
    hull = convex_hull(points)
    if len(hull) < 3:  # all points on a line (or one point): every one is on the boundary
        return np.arange(len(points))
    edge = np.roll(hull, -1, axis=0) - hull
    outward = np.column_stack([edge[:, 1], -edge[:, 0]]) / np.hypot(edge[:, 0], edge[:, 1])[:, None]
    offset = (hull * outward).sum(axis=1)  # each edge's line: outward · x = offset
    distance = np.concatenate([(offset - block @ outward.T).min(axis=1)  # blocks bound the memory
                               for block in np.array_split(points, max(1, len(points) // 512))])
    return np.flatnonzero(distance <= tolerance)


# ---------------------------------------------------------------------------------------------
# validation

def _positive(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r} must be a number > 0") from None
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} = {value!r} must be finite and > 0")
    return v


def _common(radius: float, thickness: float, width: float, spacing: float) -> tuple[float, float, float, float]:
    r = _positive("radius", radius)
    t = _positive("thickness", thickness)
    w = _positive("width", width)
    dx = _positive("spacing", spacing)
    if t >= r:
        raise ValueError(f"thickness = {thickness} must be < radius = {radius}")
    if r < 2 * dx:
        raise ValueError(f"radius = {radius} must be >= 2·spacing = {2 * dx} to be resolved")
    return r, t, w, dx


def minimum_thickness(spacing: float, h_factor: float) -> float:
    """Thinnest part that keeps grains from leaking through (m): thick enough to hold the wall
    layers that fill the kernel support 2h, i.e. ``wall_layers_needed(h_factor)·Δx`` =
    ceil(2·h_factor)·Δx (docs/design.md §3.5–3.6)."""
    dx = _positive("spacing", spacing)
    return wall_layers_needed(h_factor) * dx


def check_thickness(part: BodyShape | float, spacing: float | None = None, h_factor: float = 1.3) -> None:
    """Raise ValueError if a part (a :class:`BodyShape` or a thickness in m) is thinner than
    :func:`minimum_thickness` for this spacing and h_factor; for a BodyShape the spacing defaults
    to its own."""
    if isinstance(part, BodyShape):
        thickness = part.thickness
        spacing = part.spacing if spacing is None else spacing
        what = f"thickness of {part.name!r}"
    else:
        thickness = _positive("thickness", part)
        what = "thickness"
    if spacing is None:
        raise ValueError("spacing is required when a bare thickness is checked")
    minimum = minimum_thickness(spacing, h_factor)
    if thickness < minimum * (1 - 1e-9):
        raise ValueError(
            f"{what} = {thickness:g} m is below the minimum allowed {minimum:g} m "
            f"(= {wall_layers_needed(h_factor)} wall layers × spacing {spacing:g} m for "
            f"h_factor = {h_factor:g}); grains could leak through the part")


# ---------------------------------------------------------------------------------------------
# sampling helpers

def _rows(thickness: float, spacing: float) -> np.ndarray:
    """Offsets of the rows across a part from its centre line, exactly Δx apart."""
    n = max(1, round(thickness / spacing))
    return (np.arange(n) - 0.5 * (n - 1)) * spacing


def _straight(p0: np.ndarray, p1: np.ndarray, offsets: np.ndarray, spacing: float) -> np.ndarray:
    """Rows parallel to the segment p0 → p1 at the given offsets to its left, cell-centred along it."""
    d = p1 - p0
    length = float(np.hypot(*d))
    u = d / length
    left = np.array([-u[1], u[0]])
    n = max(1, round(length / spacing))
    s = (np.arange(n) + 0.5) * length / n
    pts = p0 + s[None, :, None] * u + offsets[:, None, None] * left
    return pts.reshape(-1, 2)


def _arc(centre: np.ndarray, radius: float, start: float, stop: float, offsets: np.ndarray,
         spacing: float) -> np.ndarray:
    """Rows at radii radius + offset, each sampled every ≈Δx of its own arc length (cell-centred)."""
    out = []
    for off in offsets:
        r = radius + off
        n = max(1, round(abs(stop - start) * r / spacing))
        phi = start + (np.arange(n) + 0.5) * (stop - start) / n
        out.append(np.column_stack([centre[0] + r * np.cos(phi), centre[1] + r * np.sin(phi)]))
    return np.concatenate(out)


def _arc_vertices(centre: np.ndarray, radius: float, start: float, stop: float, spacing: float) -> np.ndarray:
    n = max(8, int(math.ceil(abs(stop - start) * radius / (0.125 * spacing))))
    phi = np.linspace(start, stop, n + 1)
    return np.column_stack([centre[0] + radius * np.cos(phi), centre[1] + radius * np.sin(phi)])


def _merge_indices(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices of the points kept when each point closer than `tolerance` to an earlier kept point is
    dropped (grid hashing; the same rule as geometry._merge_close, but returning indices)."""
    kept: list[int] = []
    buckets: dict[tuple[int, int], list[int]] = {}
    cells = np.floor(points / tolerance).astype(np.int64)
    tol2 = tolerance * tolerance
    for index in range(len(points)):
        kx, kz = int(cells[index, 0]), int(cells[index, 1])
        p = points[index]
        clash = False
        for dx in (-1, 0, 1):
            for dz in (-1, 0, 1):
                for other in buckets.get((kx + dx, kz + dz), ()):
                    q = points[other]
                    if (q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2 < tol2:
                        clash = True
                        break
                if clash:
                    break
            if clash:
                break
        if not clash:
            kept.append(index)
            buckets.setdefault((kx, kz), []).append(index)
    return np.asarray(kept, dtype=np.int64)


def _outline_normals(points: np.ndarray, loops: list[np.ndarray], spacing: float) -> np.ndarray:
    """Outward normal of the nearest outline face for each point.

    `loops` are closed polygons (last vertex not repeated) oriented with the body on their left
    (outer boundary counter-clockwise, holes clockwise), so the outward normal of an edge with
    direction e is e rotated clockwise by 90°. Exact ties go to the first edge in loop order.
    """
    a = np.concatenate(loops)
    b = np.concatenate([np.roll(loop, -1, axis=0) for loop in loops])
    return nearest_edge_normals(points, a, b, spacing)


def nearest_edge_normals(points: np.ndarray, a: np.ndarray, b: np.ndarray, spacing: float) -> np.ndarray:
    """Outward normal of the nearest of the edges a_k → b_k (each with the body on its left, so its
    outward normal is its direction turned clockwise by 90°) for each point; exact ties (within
    1e-9·`spacing`) go to the first edge. The edges need not close: :func:`_outline_normals` passes
    whole loops, a union of overlapping parts only the edges on its outer surface."""
    e = b - a
    length = np.hypot(e[:, 0], e[:, 1])
    good = length > 0
    a, e, length = a[good], e[good], length[good]
    outward = np.column_stack([e[:, 1], -e[:, 0]]) / length[:, None]
    result = np.empty_like(points)
    chunk = max(1, 2_000_000 // max(1, len(a)))
    for start in range(0, len(points), chunk):
        p = points[start:start + chunk]
        rel = p[:, None, :] - a[None, :, :]
        t = np.clip((rel * e[None]).sum(-1) / (length ** 2)[None], 0.0, 1.0)
        d = np.hypot(*(rel - t[..., None] * e[None]).transpose(2, 0, 1))
        dmin = d.min(axis=1, keepdims=True)
        first = np.argmax(d <= dmin + 1e-9 * spacing, axis=1)
        result[start:start + chunk] = outward[first]
    return result


def _build(name: str, points: np.ndarray, loops: list[np.ndarray], spacing: float, thickness: float,
           width: float, radius: float) -> BodyShape:
    keep = _merge_indices(points, 0.5 * spacing)
    pts = points[keep]
    return BodyShape(name, pts, _outline_normals(pts, loops, spacing), spacing, thickness, width, radius,
                     tuple(loops))


def _mirrored(shape: BodyShape, name: str) -> BodyShape:
    flip = np.array([-1.0, 1.0])
    # a mirror reverses a loop's orientation: reversing its vertices keeps the body on its left
    return BodyShape(name, shape.position * flip, shape.normal * flip, shape.spacing, shape.thickness,
                     shape.width, shape.radius, tuple((loop * flip)[::-1] for loop in shape.outline))


# ---------------------------------------------------------------------------------------------
# generators

def flat_leg(radius: float, thickness: float, width: float, spacing: float) -> BodyShape:
    """Straight leg from the hip axle (origin) to the tip at (0, −R): it points straight down at angle 0.

    Args:
        radius: R, hip-to-tip length (m).
        thickness: bar thickness (m), < R.
        width: out-of-plane width (m).
        spacing: particle spacing Δx (m), R >= 2Δx.
    """
    r, t, w, dx = _common(radius, thickness, width, spacing)
    offsets = _rows(t, dx)
    h = 0.5 * len(offsets) * dx
    # centre line hip -> tip; its left is +x, so offsets are applied to the left side
    pts = _straight(np.array([0.0, 0.0]), np.array([0.0, -r]), offsets, dx)
    outline = np.array([[-h, 0.0], [-h, -r], [h, -r], [h, 0.0]])
    return _build("flat-leg", pts, [outline], dx, t, w, r)


def plate(length: float, thickness: float, width: float, spacing: float) -> BodyShape:
    """Horizontal plate (intruder) of `length` along x centred on the origin, its reference point.

    ``radius`` of the returned shape is the half length.
    """
    r, t, w, dx = _common(0.5 * length, thickness, width, spacing)
    offsets = _rows(t, dx)
    h = 0.5 * len(offsets) * dx
    # centre line right -> left; its left is −z, so offsets run from below to above
    pts = _straight(np.array([r, 0.0]), np.array([-r, 0.0]), offsets, dx)
    outline = np.array([[-r, -h], [r, -h], [r, h], [-r, h]])
    return _build("plate", pts, [outline], dx, t, w, r)


def c_leg(radius: float, thickness: float, width: float, spacing: float) -> BodyShape:
    """C-leg: half circle of diameter R from the hip (origin) to the toe at (0, −R), bulging backward (−x).

    The centre line is the half circle of radius R/2 about (0, −R/2) through (−R/2, −R/2); the
    concave side opens forward (+x) -- the letter "C" seen with the robot moving in +x (see the
    module docstring for the reading). The lowest point at angle 0 is the outer face under the
    toe, at z = −R − t/2.
    """
    r, t, w, dx = _common(radius, thickness, width, spacing)
    a = 0.5 * r
    offsets = _rows(t, dx)
    h = 0.5 * len(offsets) * dx
    if a - h <= 0:
        raise ValueError(f"thickness = {thickness} must be < radius = {radius} for a C-leg "
                         f"(the half circle has radius R/2 = {a})")
    centre = np.array([0.0, -a])
    pts = _arc(centre, a, 0.5 * math.pi, 1.5 * math.pi, offsets, dx)
    outer = _arc_vertices(centre, a + h, 0.5 * math.pi, 1.5 * math.pi, dx)
    inner = _arc_vertices(centre, a - h, 1.5 * math.pi, 0.5 * math.pi, dx)
    return _build("c-leg", pts, [np.concatenate([outer, inner])], dx, t, w, r)


def reversed_c_leg(radius: float, thickness: float, width: float, spacing: float) -> BodyShape:
    """Reversed C-leg: the mirror image (x → −x) of :func:`c_leg`, bulging forward (+x), opening backward."""
    return _mirrored(c_leg(radius, thickness, width, spacing), "reversed-c-leg")


def l_leg(radius: float, thickness: float, width: float, spacing: float, foot_ratio: float) -> BodyShape:
    """L-leg: the flat leg of length R plus a forward (+x) foot at its tip.

    Args:
        foot_ratio: fl = foot length / leg length, in (0, 1.5]. The foot runs from the leg's centre
            line to the toe at x = fl·R, its underside flush with the leg's tip at z = −R and its
            thickness that of the leg; fl·R must exceed half the thickness.
    """
    r, t, w, dx = _common(radius, thickness, width, spacing)
    try:
        fl = float(foot_ratio)
    except (TypeError, ValueError):
        raise ValueError(f"foot_ratio = {foot_ratio!r} must be a number in (0, 1.5]") from None
    if not (0.0 < fl <= 1.5):
        raise ValueError(f"foot_ratio = {foot_ratio!r} outside the allowed range (0, 1.5]")
    offsets = _rows(t, dx)
    n = len(offsets)
    h = 0.5 * n * dx
    toe = fl * r
    if toe - h < 0.5 * dx:
        raise ValueError(f"foot_ratio = {foot_ratio!r} gives a foot (fl·R = {toe:g} m) that does not reach "
                         f"past the leg's half thickness {h:g} m by Δx/2; the allowed range is "
                         f"({(h + 0.5 * dx) / r:g}, 1.5] here")
    shaft = _straight(np.array([0.0, 0.0]), np.array([0.0, -r]), offsets, dx)
    # foot: rows parallel to x from the shaft's front face to the toe, bottom row at −R + Δx/2
    foot_rows = -r + (np.arange(n) + 0.5) * dx
    nf = max(1, round((toe - h) / dx))
    xs = h + (np.arange(nf) + 0.5) * (toe - h) / nf
    gx, gz = np.meshgrid(xs, foot_rows)
    pts = np.concatenate([shaft, np.column_stack([gx.ravel(), gz.ravel()])])
    top = -r + n * dx
    outline = np.array([[-h, 0.0], [-h, -r], [toe, -r], [toe, top], [h, top], [h, 0.0]])
    return _build("l-leg", pts, [outline], dx, t, w, r)


def reversed_l_leg(radius: float, thickness: float, width: float, spacing: float,
                   foot_ratio: float) -> BodyShape:
    """Reversed L-leg: the mirror image (x → −x) of :func:`l_leg`, foot pointing backward (−x)."""
    return _mirrored(l_leg(radius, thickness, width, spacing, foot_ratio), "reversed-l-leg")


def wheel(radius: float, thickness: float, width: float, spacing: float) -> BodyShape:
    """Plain wheel rim: an annulus centred on the axle with outer surface at R and the given
    thickness (the rim only; no spokes or hub)."""
    r, t, w, dx = _common(radius, thickness, width, spacing)
    offsets = _rows(t, dx)
    h = 0.5 * len(offsets) * dx
    mid = r - h
    centre = np.zeros(2)
    pts = _arc(centre, mid, 0.0, 2 * math.pi, offsets, dx)
    outer = _arc_vertices(centre, r, 0.0, 2 * math.pi, dx)[:-1]
    inner = _arc_vertices(centre, r - 2 * h, 2 * math.pi, 0.0, dx)[:-1]
    return _build("wheel", pts, [outer, inner], dx, t, w, r)


#: names accepted by :func:`leg_wheel` for its spokes
SPOKES: dict[str, Callable[..., BodyShape]] = {
    "flat-leg": flat_leg, "c-leg": c_leg, "reversed-c-leg": reversed_c_leg,
    "l-leg": l_leg, "reversed-l-leg": reversed_l_leg,
}


def leg_wheel(spoke: Callable[..., BodyShape] | str, n_spokes: int, radius: float, thickness: float,
              width: float, spacing: float, **kw: float) -> BodyShape:
    """Hybrid leg-wheel (Fig. 1.2, 4.2): `n_spokes` copies of a leg rotated by 2π/n about the axle.

    Args:
        spoke: a generator (e.g. :func:`c_leg`) or one of the names in :data:`SPOKES`.
        n_spokes: number of legs, >= 1; spoke k is the leg rotated clockwise by 2πk/n.
        kw: extra arguments of the spoke generator (``foot_ratio`` for L-legs).

    Particles of different spokes closer than Δx/2 (near the hub) are merged, the earlier spoke's
    kept; their normals are those of their own spoke, so a few buried hub particles have normals
    that point into a neighbouring spoke rather than into the sand.
    """
    if isinstance(spoke, str):
        if spoke not in SPOKES:
            raise ValueError(f"spoke = {spoke!r} not one of {sorted(SPOKES)}")
        make = SPOKES[spoke]
    elif callable(spoke):
        make = spoke
    else:
        raise ValueError(f"spoke = {spoke!r} must be a generator function or one of {sorted(SPOKES)}")
    if isinstance(n_spokes, bool) or not isinstance(n_spokes, (int, np.integer)) or n_spokes < 1:
        raise ValueError(f"n_spokes = {n_spokes!r} must be an integer >= 1")
    leg = make(radius, thickness, width, spacing, **kw)
    positions: list[np.ndarray] = []
    normals: list[np.ndarray] = []
    loops: list[np.ndarray] = []
    for k in range(int(n_spokes)):
        p, n = leg.transformed(2 * math.pi * k / n_spokes, (0.0, 0.0))
        positions.append(p)
        normals.append(n)
        loops.extend(leg.transformed_outline(2 * math.pi * k / n_spokes, (0.0, 0.0)))
    pts = np.concatenate(positions)
    keep = _merge_indices(pts, 0.5 * leg.spacing)
    return BodyShape(f"{leg.name}-wheel-{int(n_spokes)}", pts[keep], np.concatenate(normals)[keep],
                     leg.spacing, leg.thickness, leg.width, leg.radius, tuple(loops))
