"""Resistive force theory (RFT) in the plane: granular forces on any terrasph body shape in microseconds.

RFT (Li, Zhang & Goldman 2013, Science 339:1408) cuts the body's surface into small elements and
gives each one below the free surface z_s, at depth d = z_s − z, the stress

    σ_x = −s·α_x(β, γ)·d,    σ_z = α_z(β, γ)·d          (Li et al. 2013, Eq. 1; s = sign of v_x)

so an element of length ℓ and width w feels F = σ ℓ w. The angles follow Li et al.'s Fig. 2, written
here in terrasph's frame (x forward, z up) for an element moving with v_x ≥ 0 (one moving backward is
mirrored x → −x, which flips the sign of its F_x: the s above):

* β ∈ [−π/2, π/2], the element's angle from the horizontal, counter-clockwise: its tangent is
  (cos β, sin β), so β > 0 is a plate whose front edge is raised;
* γ ∈ [−π/2, π/2], the direction of its velocity below the horizontal: v ∥ (cos γ, −sin γ), so
  γ = π/2 is straight down (intrusion) and γ = −π/2 straight up (extraction).

Each face of the body is its own element (Li et al. treat the two faces of a thin plate alike): only a
*leading* face, whose outward normal n has n·v > 0, pushes grains and is loaded; a trailing face
leaves a cavity. With these conventions the generic map below has the published properties that the
tests check: a horizontal plate pushed down meets α_z(0, π/2) = 1 (the map's normalisation, so ζ is
that plate's stress per unit depth), pulled up a quarter of it, −0.25; a horizontal drag is resisted
(α_x(β, 0) > 0 for every β) and lifts (α_z(0, 0) = 0.375); vertical intrusion is mirror-symmetric
(α_z even, α_x odd in β at γ = ±π/2).

**The coefficient map** is Li et al.'s discrete Fourier fit (their supplementary Eq. S2, m ∈ {−1, 0, 1},
n ∈ {0, 1}), with α = ζ·α̂:

    α̂_z = A00 + A10 cos 2β + B11 sin(2β + γ) + B01 sin γ + B−11 sin(−2β + γ)
    α̂_x = C11 cos(2β + γ) + C01 cos γ + C−11 cos(−2β + γ) + D10 sin 2β

The *generic* coefficients (their Table S2: A00 = 0.206, A10 = 0.169, B11 = 0.212, B01 = 0.358,
B−11 = 0.055, C11 = −0.124, C01 = 0.253, C−11 = 0.007, D10 = 0.088) fit every dry medium they tested
up to the scale ζ. Li et al. state α and ζ in N/cm³; terrasph works in SI, N/m³ (1 N/cm³ = 10⁶ N/m³).
A coefficient table (:class:`RFTCoefficients`) holds the nine dimensionless coefficients normalised so
that α̂_z(0, π/2) = 1, and ζ in N/m³; the default ζ of the chapter 3 glass beads is the SPH's own
(:data:`GLASS_BEADS_ZETA`). A table fitted to other data (``terrasph rft-calibrate``) is a JSON file
(:func:`save_coefficients`, :func:`load_coefficients`).

**Geometry** (:class:`SurfaceElements`) is read from :attr:`terrasph.bodies.BodyShape.outline` only:
each loop is cut at its corners and resampled into chords of about ``element_length``; where loops
overlap (a leg-wheel's spokes at the hub) the parts of a loop inside another are dropped, so only the
body's outer surface is loaded.

**Carried grains.** A body's *pockets* (the open regions between its outline and its convex hull: a
C-leg's cup, an L-leg's corner, the gaps between spokes) carry the grains in them where their walls lead:
each adds the weight ρ0 g A w of its part below the surface times its walls' leading fraction, ρ0 the
medium's bulk density (:attr:`RFTCoefficients.density`). No local map gives it: the SPH's reversed C-leg
carries the grains of its cup as one body (docs/rft.md, "Carried grains").
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import pathlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from terrasph import _core
from terrasph.bodies import BodyShape
from terrasph.config import ConfigError
from terrasph.geometry import convex_hull
from terrasph.options import OPTION, SHARED
from terrasph.scene import GRAVITY

__all__ = ["COEFFICIENT_NAMES", "GENERIC", "GLASS_BEADS_DENSITY", "GLASS_BEADS_ZETA", "MAX_ORDER", "REGULARISATION_SPEED", "TABLE_FORMAT",
           "TERRAINS", "BodyLoad", "RFTCoefficients", "SurfaceElements", "Term", "body_load", "check_terrain",
           "coefficient_table", "convex_hull", "fit_coefficients", "fourier_basis", "load_coefficients", "map_correlation",
           "parse_term", "save_coefficients", "series_names", "term_name"]

#: the terrains a scene runs on: the SPH bed, or RFT on a flat surface (this module); the choices of
#: the scenes' shared ``terrain`` option (terrasph.options.SHARED)
TERRAINS: tuple[str, ...] = SHARED["terrain"].choices or ()

#: the nine Fourier coefficients of Li et al. 2013 (Eq. S2): the series' terms of order (1, 1)
COEFFICIENT_NAMES = ("A00", "A10", "B11", "B01", "Bm11", "C11", "C01", "Cm11", "D10")

#: the largest multiple m of 2β and n of γ a term may have (cpp/include/terrasph/rft.hpp, kMaxOrder)
MAX_ORDER = 4

#: ζ of the chapter 3 glass beads (N/m³): the SPH's stress per unit depth on a horizontal plate pushed
#: down, k/(L W) = 247.9 N/m / (0.04 m × 0.0254 m) (α = 15.2 ρ0 g; docs/benchmarks.md, plate intrusion)
GLASS_BEADS_ZETA = 2.44e5
#: ρ0 of the chapter 3 glass beads (kg/m³): 2600 kg/m³ grains at packing 0.63
#: (terrasph.scenes.leg_rotation.glass_beads)
GLASS_BEADS_DENSITY = 2600.0 * 0.63

#: the ``format`` entry of a coefficient table file
TABLE_FORMAT = "terrasph-rft-coefficients"

#: a term's letter: (in α̂_z, a sine), and the parity of n it allows (the mirror symmetry of vertical motion)
_LETTERS = {"A": (True, False, 0), "B": (True, True, 1), "C": (False, False, 1), "D": (False, True, 0)}


@dataclass(frozen=True)
class Term:
    """One term of the series: ``value`` × cos or sin(2mβ + nγ) in α̂_z (`vertical`) or α̂_x."""

    vertical: bool
    sine: bool
    m: int
    n: int


def parse_term(name: str) -> Term:
    """The term of a coefficient's name: a letter A (α̂_z, cos), B (α̂_z, sin), C (α̂_x, cos) or D (α̂_x,
    sin), then m (``m1`` for −1) and n, e.g. ``Bm11`` = sin(−2β + γ) in α̂_z (Li et al.'s naming).
    ConfigError for a name that is not one, an order above :data:`MAX_ORDER`, or a term the map's
    symmetry forbids (A and D need even n, B and C odd n; for n = 0, m ≥ 0, and D00 vanishes)."""
    letter, rest = name[:1], name[1:]
    negative = rest.startswith("m")
    digits = rest[1:] if negative else rest
    if letter not in _LETTERS or len(digits) != 2 or not digits.isdigit():
        raise ConfigError(f"RFT coefficient {name!r} is not a term's name: allowed A, B, C or D, then m (m1 for "
                          f"-1) and n, each 0…{MAX_ORDER} (e.g. A00, Bm11)")
    vertical, sine, parity = _LETTERS[letter]
    m, n = (-1 if negative else 1) * int(digits[0]), int(digits[1])
    if abs(m) > MAX_ORDER or n > MAX_ORDER or n % 2 != parity or (n == 0 and (m < 0 or (sine and m == 0))) \
            or (negative and m == 0):
        raise ConfigError(f"RFT coefficient {name!r} is not a term of the map's series: allowed orders up to "
                          f"{MAX_ORDER}, n {'even' if parity == 0 else 'odd'} for {letter}, m ≥ 0 when n = 0")
    return Term(vertical, sine, m, n)


def term_name(term: Term) -> str:
    """The name :func:`parse_term` reads."""
    letter = {(True, False): "A", (True, True): "B", (False, False): "C", (False, True): "D"}[(term.vertical, term.sine)]
    return f"{letter}{'m' if term.m < 0 else ''}{abs(term.m)}{term.n}"


def series_names(order_beta: int, order_gamma: int) -> tuple[str, ...]:
    """Every term allowed up to m = ±`order_beta`, n = `order_gamma`; (1, 1) is Li et al.'s nine."""
    names = []
    for n in range(order_gamma + 1):
        for m in range(0 if n == 0 else -order_beta, order_beta + 1):
            for letter, (_, sine, parity) in _LETTERS.items():
                if n % 2 == parity and not (n == 0 and sine and m == 0):
                    names.append(f"{letter}{'m' if m < 0 else ''}{abs(m)}{n}")
    return tuple(names)


@dataclass(frozen=True)
class RFTCoefficients:
    """An RFT coefficient map: α = ζ·α̂(β, γ) with α̂ the Fourier series of the module docstring.

    `coefficients` maps each term's name (:func:`parse_term`) to its dimensionless value, normalised
    so that α̂_z(0, π/2) = 1 (a horizontal plate pushed straight down); `zeta` ζ is that plate's
    stress per unit depth in N/m³.
    """

    coefficients: dict[str, float]
    zeta: float = GLASS_BEADS_ZETA
    source: str = ""
    #: the medium's bulk density ρ0 (kg/m³): the grains a body carries in its pockets weigh ρ0 g per m³
    density: float = GLASS_BEADS_DENSITY

    def __post_init__(self) -> None:
        if not isinstance(self.coefficients, dict) or not self.coefficients:
            raise ConfigError("RFT coefficients: allowed a non-empty mapping of term names to numbers")
        for name, value in self.coefficients.items():
            parse_term(name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"RFT coefficient '{name}' = {value!r} is invalid: allowed a finite number")
        if isinstance(self.zeta, bool) or not isinstance(self.zeta, (int, float)) or not math.isfinite(self.zeta):
            raise ConfigError(f"RFT coefficient 'zeta' = {self.zeta!r} is invalid: allowed a finite number")
        if not self.zeta > 0:
            raise ConfigError(f"RFT coefficient 'zeta' = {self.zeta!r} is invalid: allowed > 0 (N/m³)")
        if (isinstance(self.density, bool) or not isinstance(self.density, (int, float))
                or not (math.isfinite(self.density) and self.density >= 0)):
            raise ConfigError(f"RFT coefficient 'density' = {self.density!r} is invalid: allowed a finite number "
                              ">= 0 (kg/m³)")

    @property
    def names(self) -> tuple[str, ...]:
        """The terms' names, in the table's order."""
        return tuple(self.coefficients)

    @property
    def vector(self) -> np.ndarray:
        """The coefficients in :attr:`names` order."""
        return np.array([float(v) for v in self.coefficients.values()])

    @property
    def terms(self) -> list[tuple[bool, bool, int, int, float]]:
        """(vertical, sine, m, n, value) of each term, as the compiled core reads them."""
        out = []
        for name, value in self.coefficients.items():
            term = parse_term(name)
            out.append((term.vertical, term.sine, term.m, term.n, float(value)))
        return out

    @property
    def unit_weight(self) -> float:
        """ρ0 g (N/m³), the weight per volume of the grains a body's pockets carry."""
        return self.density * GRAVITY

    def with_zeta(self, zeta: float) -> RFTCoefficients:
        """The same map with another scale ζ (N/m³)."""
        return dataclasses.replace(self, coefficients=dict(self.coefficients), zeta=zeta)

    def alpha(self, beta: np.ndarray | float, gamma: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """(α_x, α_z) in N/m³ at the angles of the module docstring (β, γ in [−π/2, π/2])."""
        basis_x, basis_z = fourier_basis(beta, gamma, self.names)
        return self.zeta * (basis_x @ self.vector), self.zeta * (basis_z @ self.vector)


def _alpha_hat(table: RFTCoefficients, cos2b: np.ndarray, sin2b: np.ndarray, cosg: np.ndarray,
               sing: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """α̂_x and α̂_z of `table` from the trigonometric values of 2β and γ (for the 3D law,
    terrasph.terrain.rft3d; the loads of the planar law: cpp/src/rft.cpp)."""
    beta, gamma = 0.5 * np.arctan2(sin2b, cos2b), np.arctan2(sing, cosg)
    basis_x, basis_z = fourier_basis(beta, gamma, table.names)
    return basis_x @ table.vector, basis_z @ table.vector


def fourier_basis(beta: np.ndarray | float, gamma: np.ndarray | float,
                  names: tuple[str, ...] = COEFFICIENT_NAMES) -> tuple[np.ndarray, np.ndarray]:
    """The terms multiplying each coefficient of `names` in α̂_x and α̂_z: two (..., len(names))
    arrays, so α̂ = basis @ coefficients (the series is linear in them, so a least-squares fit is
    linear)."""
    b, g = np.broadcast_arrays(np.asarray(beta, dtype=float), np.asarray(gamma, dtype=float))
    basis_x, basis_z = np.zeros((*b.shape, len(names))), np.zeros((*b.shape, len(names)))
    for k, name in enumerate(names):
        term = parse_term(name)
        argument = 2 * term.m * b + term.n * g
        (basis_z if term.vertical else basis_x)[..., k] = np.sin(argument) if term.sine else np.cos(argument)
    return basis_x, basis_z


#: Li, Zhang & Goldman 2013 (Science 339:1408), supplementary Table S2: the generic coefficients,
#: here with the chapter 3 glass beads' ζ (GLASS_BEADS_ZETA)
GENERIC = RFTCoefficients(dict(zip(COEFFICIENT_NAMES, (0.206, 0.169, 0.212, 0.358, 0.055, -0.124, 0.253, 0.007, 0.088))),
                          source="Li, Zhang & Goldman 2013, Science 339:1408, Table S2 (generic)")


# ---------------------------------------------------------------------------------------------
# coefficient tables

def save_coefficients(table: RFTCoefficients, path: str | os.PathLike[str], **extra: Any) -> pathlib.Path:
    """Writes `table` as JSON (with its units; `extra` entries, e.g. the fit's quality, are kept)."""
    out = pathlib.Path(path)
    document = {"format": TABLE_FORMAT, "version": 1,
                "units": {"zeta": "N/m^3", "density": "kg/m^3", "coefficients": "1 (alpha / zeta)"},
                "zeta": table.zeta, "density": table.density, "coefficients": dict(table.coefficients),
                "source": table.source, **extra}
    out.write_text(json.dumps(document, indent=2) + "\n")
    return out


def load_coefficients(path: str | os.PathLike[str]) -> RFTCoefficients:
    """Reads a table written by :func:`save_coefficients`; ConfigError naming what is wrong."""
    try:
        document = json.loads(pathlib.Path(path).read_text())
    except OSError as error:
        raise ConfigError(f"RFT coefficient table '{path}' cannot be read: {error.strerror}") from None
    except json.JSONDecodeError as error:
        raise ConfigError(f"RFT coefficient table '{path}' is not JSON: {error.msg} (line {error.lineno})") from None
    if not isinstance(document, dict) or document.get("format") != TABLE_FORMAT:
        raise ConfigError(f"RFT coefficient table '{path}' is malformed: allowed a JSON object with "
                          f"\"format\": \"{TABLE_FORMAT}\"")
    coefficients = document.get("coefficients")
    if not isinstance(coefficients, dict) or not coefficients or "zeta" not in document:
        raise ConfigError(f"RFT coefficient table '{path}' is malformed: allowed \"zeta\" (N/m^3) and "
                          "\"coefficients\", a mapping of term names (e.g. A00, Bm11) to numbers")
    try:
        return RFTCoefficients(dict(coefficients), zeta=document["zeta"], source=str(document.get("source", path)),
                               density=document.get("density", GLASS_BEADS_DENSITY))
    except ConfigError as error:
        raise ConfigError(f"RFT coefficient table '{path}': {error}") from None


def check_terrain(config: Any, sph_only: tuple[str, ...], rft_only: tuple[str, ...] = ()) -> None:
    """Checks a scene configuration's `terrain` (one of the choices its field declares, by default
    :data:`TERRAINS`) and, on RFT, its coefficient map and that none of its
    `sph_only` fields (the bed's material, depth, numerics, fidelity: settings the RFT terrain has no
    use for) differs from its default, and on the SPH that none of its `rft_only` fields does;
    ConfigError in one line naming the parameter otherwise, so a setting is never ignored without a
    word."""
    field = next((f for f in dataclasses.fields(config) if f.name == "terrain"), None)
    declared = field.metadata.get(OPTION) if field is not None else None
    allowed = declared.choices if declared is not None and declared.choices else TERRAINS  # the scene's own choices
    if config.terrain not in allowed:
        raise ConfigError(f"parameter 'terrain' = {config.terrain!r} is invalid: allowed one of {', '.join(allowed)}")
    if config.terrain == "rft":
        coefficient_table(config.rft_table)  # an unknown name or a malformed file, before any work
    unused = sph_only if config.terrain == "rft" else rft_only
    for item in dataclasses.fields(config):
        if item.name not in unused:
            continue
        default = item.default if item.default_factory is dataclasses.MISSING else item.default_factory()
        value = getattr(config, item.name)
        if value == default:
            continue
        if config.terrain == "rft":
            raise ConfigError(f"parameter '{item.name}' = {value!r} is invalid on the RFT terrain: allowed only its "
                              f"default {default!r} there (it sets the SPH bed; RFT's sand is its coefficient map, "
                              "rft_table)")
        raise ConfigError(f"parameter '{item.name}' = {value!r} is invalid on the SPH terrain: allowed only its "
                          f"default {default!r} there (it sets the RFT terrain: add terrain 'rft')")


def coefficient_table(name: str | RFTCoefficients, zeta: float | None = None) -> RFTCoefficients:
    """A coefficient map by name: ``"generic"`` (:data:`GENERIC`) or the path of a JSON table; an
    optional `zeta` (N/m³) replaces its scale. ConfigError for an unknown name."""
    if isinstance(name, RFTCoefficients):
        table = name
    elif name == "generic":
        table = GENERIC
    elif isinstance(name, (str, os.PathLike)) and pathlib.Path(name).suffix == ".json":
        table = load_coefficients(name)
    else:
        raise ConfigError(f"parameter 'rft_table' = {name!r} is invalid: allowed 'generic' or the path of a "
                          "JSON coefficient table (terrasph rft-calibrate)")
    if zeta is None:
        return table
    if isinstance(zeta, bool) or not isinstance(zeta, (int, float)) or not (math.isfinite(zeta) and zeta > 0):
        raise ConfigError(f"parameter 'rft_zeta' = {zeta!r} is invalid: allowed a finite number > 0 (N/m³)")
    return table.with_zeta(float(zeta))


# ---------------------------------------------------------------------------------------------
# geometry

#: a loop's direction changing by more than this (rad) at a vertex makes the vertex a corner, kept
#: exactly when the loop is resampled
_CORNER_ANGLE = math.radians(20.0)


def _winding(points: np.ndarray, loops: tuple[np.ndarray, ...]) -> np.ndarray:
    """Sum over `loops` of each point's winding number (counter-clockwise +1; Sunday's crossing rule):
    > 0 inside the body the loops bound (outer loops counter-clockwise, holes clockwise)."""
    total = np.zeros(len(points), dtype=np.int64)
    px, pz = points[:, 0:1], points[:, 1:2]
    for loop in loops:
        a, b = loop, np.roll(loop, -1, axis=0)
        left = (b[:, 0] - a[:, 0]) * (pz - a[:, 1]) - (px - a[:, 0]) * (b[:, 1] - a[:, 1])
        up = (a[:, 1] <= pz) & (b[:, 1] > pz) & (left > 0)
        down = (a[:, 1] > pz) & (b[:, 1] <= pz) & (left < 0)
        total += up.sum(axis=1) - down.sum(axis=1)
    return total


def _resampled(loop: np.ndarray, length: float) -> np.ndarray:
    """The closed `loop` as chords of about `length`: cut at its corners, each run between two corners
    divided into equal arc-length parts (vertices returned in loop order, last not repeated)."""
    edges = np.roll(loop, -1, axis=0) - loop
    heading = np.arctan2(edges[:, 1], edges[:, 0])
    turn = np.abs(np.remainder(heading - np.roll(heading, 1) + math.pi, 2 * math.pi) - math.pi)
    corners = np.flatnonzero(turn > _CORNER_ANGLE)
    if len(corners) == 0:
        corners = np.array([0])
    out = []
    n = len(loop)
    for k, start in enumerate(corners):
        steps = (corners[(k + 1) % len(corners)] - start) % n or n
        run = loop[(start + np.arange(steps + 1)) % n]
        arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(run, axis=0).T))]
        parts = max(1, math.ceil(arc[-1] / length - 1e-9))
        s = np.linspace(0.0, arc[-1], parts + 1)[:-1]
        out.append(np.column_stack([np.interp(s, arc, run[:, 0]), np.interp(s, arc, run[:, 1])]))
    return np.concatenate(out)


#: a pocket's cells merge this many × this many squares of the element length, at the centroid and with
#: the area of the squares' centres that lie in the pocket: the carried weight's cost is its cell count
#: (docs/rft.md, "Carried grains")
POCKET_CELL_MERGE = 2


def _connected(mask: np.ndarray) -> np.ndarray:
    """Labels 0, 1, … of the 4-connected regions of a 2D boolean `mask`, −1 outside it."""
    labels = np.full(mask.shape, -1, dtype=np.int32)
    count = 0
    for start in zip(*np.nonzero(mask)):
        if labels[start] >= 0:
            continue
        labels[start] = count
        stack = [start]
        while stack:
            i, j = stack.pop()
            for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
                if 0 <= a < mask.shape[0] and 0 <= b < mask.shape[1] and mask[a, b] and labels[a, b] < 0:
                    labels[a, b] = count
                    stack.append((a, b))
        count += 1
    return labels


def _pockets(loops: tuple[np.ndarray, ...], centre: np.ndarray, normal: np.ndarray,
             cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The body's pockets, the regions between its outline and its convex hull (a C-leg's cup, the
    corner of an L-leg, the gaps between a leg-wheel's spokes), as square cells of side `cell` whose
    centres lie in the hull and outside the body, grouped into 4-connected pockets; each element whose
    point half a cell outside lies in a pocket's cell is that pocket's wall. Returns (wall_pocket,
    cell_centre, cell_area, cell_pocket) of :class:`SurfaceElements`."""
    hull = convex_hull(np.concatenate(loops))
    low, high = hull.min(axis=0), hull.max(axis=0)
    counts = np.maximum(1, np.ceil((high - low) / cell).astype(int))
    xs = low[0] + (np.arange(counts[0]) + 0.5) * (high[0] - low[0]) / counts[0]
    zs = low[1] + (np.arange(counts[1]) + 0.5) * (high[1] - low[1]) / counts[1]
    grid = np.stack(np.meshgrid(xs, zs, indexing="ij"), axis=-1).reshape(-1, 2)
    in_hull = _winding(grid, (hull,)) > 0
    outside_body = np.zeros(len(grid), dtype=bool)  # asked of the cells in the hull only: the others are no pocket
    outside_body[in_hull] = _winding(grid[in_hull], loops) <= 0
    in_hull = in_hull.reshape(counts)
    labels = _connected(in_hull & outside_body.reshape(counts))
    # a region the body encloses (a rim's hole) holds no grains: a pocket opens onto the hull's outside
    outside = np.pad(~in_hull, 1, constant_values=True)
    opening = outside[2:, 1:-1] | outside[:-2, 1:-1] | outside[1:-1, 2:] | outside[1:-1, :-2]
    open_pockets = np.unique(labels[opening & (labels >= 0)])
    labels = np.where(np.isin(labels, open_pockets), np.searchsorted(open_pockets, labels), -1).astype(np.int32)
    size = (high - low) / counts
    probe = np.floor((centre + 0.5 * size * normal - low) / size).astype(int)
    within = np.all((probe >= 0) & (probe < counts), axis=1)
    wall = np.full(len(centre), -1, dtype=np.int32)
    wall[within] = labels[probe[within, 0], probe[within, 1]]
    flat = labels.ravel()
    keep = flat >= 0
    block = np.stack(np.meshgrid(np.arange(counts[0]), np.arange(counts[1]), indexing="ij"), axis=-1).reshape(-1, 2)
    block = block[keep] // POCKET_CELL_MERGE
    key = np.column_stack([flat[keep], block])
    groups, cell = np.unique(key, axis=0, return_inverse=True)
    members = np.bincount(cell.ravel(), minlength=len(groups))
    centroid = np.column_stack([np.bincount(cell.ravel(), weights=grid[keep][:, k]) for k in (0, 1)]) / members[:, None]
    return wall, centroid, members * float(size[0] * size[1]), groups[:, 0].astype(np.int32)


@dataclass(frozen=True)
class SurfaceElements:
    """The outer surface of a body shape as RFT elements in its own frame.

    Attributes:
        centre: (E, 2) element midpoints (m).
        normal: (E, 2) unit outward normals (into the sand).
        length: (E,) element lengths (m).
        width: out-of-plane width (m) the loads are computed for.
    """

    centre: np.ndarray
    normal: np.ndarray
    length: np.ndarray
    width: float
    #: (E,) the pocket each element faces (its wall), −1 for none (:func:`_pockets`)
    wall_pocket: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=np.int32))
    #: (C, 2) centres (m) and (C,) areas (m²) of the cells filling the pockets, and each cell's pocket
    cell_centre: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2)))
    cell_area: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    cell_pocket: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=np.int32))

    def __post_init__(self) -> None:
        if len(self.wall_pocket) != len(self.length):  # built without pockets
            object.__setattr__(self, "wall_pocket", np.full(len(self.length), -1, dtype=np.int32))

    @property
    def pockets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(wall_pocket, cell_centre, cell_area, cell_pocket), as the compiled core reads them."""
        return self.wall_pocket, self.cell_centre, self.cell_area, self.cell_pocket

    @classmethod
    def from_shape(cls, shape: BodyShape, element_length: float | None = None,
                   width: float | None = None) -> SurfaceElements:
        """Elements of about `element_length` (m; default R/40 of the shape) from ``shape.outline``;
        ConfigError if the shape has no outline or a bad length."""
        if not shape.outline:
            raise ConfigError(f"shape {shape.name!r} has no outline: RFT reads the body's outline "
                              "(terrasph.bodies.BodyShape.outline)")
        length = shape.radius / 40.0 if element_length is None else element_length
        if isinstance(length, bool) or not isinstance(length, (int, float)) or not (0 < length <= shape.radius):
            raise ConfigError(f"parameter 'element_length' = {element_length!r} is invalid: allowed (0, "
                              f"{shape.radius:g}] m (at most the shape's radius)")
        width = shape.width if width is None else width
        if not (isinstance(width, (int, float)) and math.isfinite(width) and width > 0):
            raise ConfigError(f"parameter 'width' = {width!r} is invalid: allowed a finite number > 0 (m)")
        loops = tuple(_resampled(loop, length) for loop in shape.outline)
        centres, normals, lengths = [], [], []
        for a in loops:
            e = np.roll(a, -1, axis=0) - a
            ell = np.hypot(e[:, 0], e[:, 1])
            keep = ell > 0
            centres.append((a + 0.5 * e)[keep])
            normals.append((np.column_stack([e[:, 1], -e[:, 0]]) / np.where(ell > 0, ell, 1.0)[:, None])[keep])
            lengths.append(ell[keep])
        centre, normal, ell = np.concatenate(centres), np.concatenate(normals), np.concatenate(lengths)
        # a face just outside which lies body (another loop's inside) is internal: drop it
        probe = centre + 1e-4 * length * normal
        outer = _winding(probe, loops) <= 0
        if not outer.any():
            raise ConfigError(f"shape {shape.name!r} has no outer surface (every outline face lies inside another loop)")
        centre, normal, ell = centre[outer], normal[outer], ell[outer]
        return cls(centre, normal, ell, float(width), *_pockets(loops, centre, normal, length))

    def __len__(self) -> int:
        return len(self.length)


#: Speed (m/s) below which a leading face's load fades linearly to zero with its normal speed n·v: the
#: one regularisation of the rate-independent map, so that the load is continuous in the velocity
#: (a face turning from leading to trailing, a body coming to rest) and a robot's step can treat it
#: implicitly (terrasph.terrain.rft_coupling). 0.1 mm/s is far below the speeds of the scenes (cm/s); a body
#: resting on the sand creeps at most this fast.
REGULARISATION_SPEED = 1e-4


@dataclass(frozen=True)
class BodyLoad:
    """The RFT load on a body: `force` (F_x, F_z) N, clockwise `torque` N·m about its origin and, if
    asked for, `jacobian` ∂(F_x, F_z, τ)/∂(v_x, v_z, ω) (3 × 3, SI units) at fixed pose."""

    force: np.ndarray
    torque: float
    jacobian: np.ndarray | None = None


def body_load(elements: SurfaceElements, angle: float, origin: tuple[float, float] | np.ndarray,
              velocity: np.ndarray, omega: float, surface: float, table: RFTCoefficients, *,
              regularisation: float = REGULARISATION_SPEED, jacobian: bool = False) -> BodyLoad:
    """RFT load on a body at pose (`angle` clockwise, `origin`) moving with `velocity` (v_x, v_z) m/s at
    its origin and spinning at `omega` rad/s clockwise, for a flat free surface at z = `surface`
    (computed by the compiled core, cpp/src/rft.cpp, which the robot's native step also calls).

    Each element below the surface with outward normal n and velocity v (v + ω (r_z, −r_x) at arm r)
    takes σ ℓ w with σ of the module docstring, times min(1, n·v / `regularisation`) for n·v > 0 (0
    for a trailing face; `regularisation` = 0: the bare map); each pocket adds the weight of the grains
    it carries (the module docstring; ``table.density`` 0: none). The torque is Σ (r × F)_y = r_z F_x −
    r_x F_z (terrasph.mjcf.model's convention). With `jacobian`, also the load's derivative in the
    body's velocity: through γ (∂γ/∂v = s (v_z, −v_x)/|v|², γ = atan2(−v_z, s v_x)) and through the
    regularisation (∂/∂v (n·v/v_ε) = n/v_ε).
    """
    fx, fz, torque, derivative = _core.rft_body_load(
        elements.centre, elements.normal, elements.length, elements.width, elements.pockets, float(angle),
        float(origin[0]), float(origin[1]), float(velocity[0]), float(velocity[1]), float(omega), float(surface),
        table.terms, table.zeta, table.unit_weight, float(regularisation), bool(jacobian))
    return BodyLoad(np.array([fx, fz]), torque, np.reshape(derivative, (3, 3)) if jacobian else None)


# ---------------------------------------------------------------------------------------------
# calibration

#: the (β, γ) grid on which two maps are compared (:func:`map_correlation`): 31 × 31 over [−π/2, π/2]²
_COMPARISON_GRID = np.meshgrid(np.linspace(-math.pi / 2, math.pi / 2, 31), np.linspace(-math.pi / 2, math.pi / 2, 31))


def fit_coefficients(beta: np.ndarray, gamma: np.ndarray, alpha_x: np.ndarray, alpha_z: np.ndarray,
                     source: str = "", names: tuple[str, ...] = COEFFICIENT_NAMES) -> tuple[RFTCoefficients, dict[str, float]]:
    """Least-squares fit of the coefficients `names` (default Li et al.'s nine; :func:`series_names`
    for a higher order) to measured stresses per unit depth α_x, α_z (N/m³) at attack angles β and
    directions γ (rad, the module docstring's convention), both components in one linear system
    (:func:`fourier_basis`); returned normalised (α̂_z(0, π/2) = 1, ζ the fitted map's value there)
    with the fit's quality: ``rms_residual`` over ``rms_measured`` (N/m³), the ``points`` used and
    ``rms_loo``, the rms error of each point predicted by the fit to the others (leave-one-out, the
    measure that chooses the order). ConfigError with fewer points than 2·len(names)/2 or an
    unusable fit."""
    beta, gamma, alpha_x, alpha_z = (np.asarray(v, dtype=float).ravel() for v in (beta, gamma, alpha_x, alpha_z))
    if not len(beta) == len(gamma) == len(alpha_x) == len(alpha_z) or 2 * len(beta) <= len(names):
        raise ConfigError(f"an RFT fit of {len(names)} coefficients needs more than {len(names) // 2} measured "
                          f"(β, γ, α_x, α_z) points of equal count; got {len(beta)}")
    basis_x, basis_z = fourier_basis(beta, gamma, names)
    matrix = np.vstack([basis_x, basis_z])
    measured = np.concatenate([alpha_x, alpha_z])
    raw, *_ = np.linalg.lstsq(matrix, measured, rcond=None)
    zeta = float(fourier_basis(0.0, math.pi / 2, names)[1] @ raw)
    if not (math.isfinite(zeta) and zeta > 0):
        raise ConfigError(f"the fitted map pushes a horizontal plate going down upward (ζ = {zeta:g} N/m³): "
                          "the points do not determine it")
    residual = matrix @ raw - measured
    # leave one point (both its components) out: the residual of a linear least-squares fit's
    # prediction is r_i / (1 − h_ii) for one row; for the point's two rows, (I − H_pp)⁻¹ r_p
    hat = matrix @ np.linalg.pinv(matrix)
    count = len(beta)
    held_out = []
    for k in range(count):
        rows = [k, k + count]
        block = np.eye(2) - hat[np.ix_(rows, rows)]
        held_out.extend(np.linalg.solve(block, residual[rows]) if abs(np.linalg.det(block)) > 1e-12
                        else [np.nan, np.nan])
    quality = {"rms_residual": float(np.sqrt(np.mean(residual ** 2))), "rms_measured": float(np.sqrt(np.mean(measured ** 2))),
               "rms_loo": float(np.sqrt(np.nanmean(np.square(held_out)))), "points": int(count)}
    return RFTCoefficients(dict(zip(names, (raw / zeta).tolist())), zeta=zeta, source=source), quality


def map_correlation(first: RFTCoefficients, second: RFTCoefficients) -> dict[str, float]:
    """Shape correlation of two maps: Pearson's r of α̂_x and of α̂_z (each map divided by its ζ) over a
    31 × 31 grid of [−π/2, π/2]² in (β, γ), and the ratio of their scales ζ."""
    beta, gamma = _COMPARISON_GRID
    ax1, az1 = first.with_zeta(1.0).alpha(beta, gamma)
    ax2, az2 = second.with_zeta(1.0).alpha(beta, gamma)
    return {"r_x": float(np.corrcoef(ax1.ravel(), ax2.ravel())[0, 1]),
            "r_z": float(np.corrcoef(az1.ravel(), az2.ravel())[0, 1]), "zeta_ratio": first.zeta / second.zeta}
