"""Post-processing of particle states: free-surface profiles, runout, energies, stress invariants,
strain from displacements.

Pure numpy and deterministic. Conventions (see docs): SI units, 2D plane strain in the x–z plane
with z up, positions shaped (N, 2) as (x, z), stresses (N, 2, 2) with tension positive. A 2D
particle's mass is per metre of depth; energies are multiplied by the run's out-of-plane
``width`` to give joules for the real body.

Column-collapse quantities follow chapter 2 of the dissertation: normalised runout
L* = (L − L0)/L0 and normalised final height H* = H_f/H0 (Fig. 2.6), and τ–p yield loci
(Fig. 2.6f). Particles stand for square cells of side ``spacing`` (the initial lattice spacing),
so extents are measured to the cell edge: max z + spacing/2, max x + spacing/2.

Every function validates its inputs and raises ``ValueError`` naming the argument.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = [
    "at_rest",
    "final_height",
    "fit_line",
    "front_position",
    "kinetic_energy",
    "normalised_height",
    "normalised_runout",
    "potential_energy",
    "shear_strain",
    "stress_invariants",
    "surface_profile",
    "vertical_stress_profile",
    "yield_locus",
]


# -- input validation ----------------------------------------------------------------------------
def _finite_array(name: str, value: np.ndarray, shape_text: str) -> np.ndarray:
    """``value`` as a float64 array; raise if it holds non-finite entries."""
    array = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must hold finite values only ({shape_text})")
    return array


def _points(name: str, value: np.ndarray) -> np.ndarray:
    """Validate an (N, 2) array of (x, z) coordinates with N ≥ 1."""
    array = np.asarray(value)
    if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] < 1:
        raise ValueError(f"{name} must have shape (N, 2) with N >= 1, got {array.shape}")
    return _finite_array(name, array, "shape (N, 2)")


def _per_particle(name: str, value: np.ndarray, n: int) -> np.ndarray:
    """Validate an (n,) array of per-particle scalars."""
    array = np.asarray(value)
    if array.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), one value per particle, got {array.shape}")
    return _finite_array(name, array, f"shape ({n},)")


def _stress(name: str, value: np.ndarray) -> np.ndarray:
    """Validate an (N, 2, 2) stress array with N ≥ 1."""
    array = np.asarray(value)
    if array.ndim != 3 or array.shape[1:] != (2, 2) or array.shape[0] < 1:
        raise ValueError(f"{name} must have shape (N, 2, 2) with N >= 1, got {array.shape}")
    return _finite_array(name, array, "shape (N, 2, 2)")


def _positive(name: str, value: float) -> float:
    """Validate a finite number > 0."""
    number = float(value)
    if not np.isfinite(number) or number <= 0.0:
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return number


def _finite(name: str, value: float) -> float:
    """Validate a finite number."""
    number = float(value)
    if not np.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number


def _lattice_edges(values: np.ndarray, spacing: float) -> np.ndarray:
    """Bin edges of width ``spacing`` centred on a lattice starting at ``values.min()``.

    A lattice x_i = x_0 + i·spacing falls exactly on the bin centres, so round-off in the
    particle coordinates cannot move a particle to a neighbouring bin.
    """
    low, high = float(values.min()), float(values.max())
    n_bins = int(np.floor((high - low) / spacing + 0.5)) + 1
    return low - 0.5 * spacing + spacing * np.arange(n_bins + 1)


def _bin_index(values: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin of each value (half-open bins, the last one closed); −1 for values outside the edges."""
    index = np.searchsorted(edges, values, side="right") - 1
    index[values == edges[-1]] = edges.size - 2
    index[(values < edges[0]) | (values > edges[-1])] = -1
    return index


# -- geometry of a deposit ---------------------------------------------------------------------
def surface_profile(
    position: np.ndarray,
    spacing: float,
    x_edges: np.ndarray | None = None,
    *,
    floor: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Free-surface height h(x) of a particle set.

    Particles are binned in x with bins of width ``spacing`` centred on a lattice through the
    left-most particle (or with the given ``x_edges``; particles outside them are ignored). The
    height in a bin is max z + spacing/2 − ``floor`` (each particle stands for a cell of side
    ``spacing``); empty bins have height 0.

    Returns
    -------
    (centres, heights):
        Bin centres (m) and heights above ``floor`` (m), each shaped (n_bins,).
    """
    points = _points("position", position)
    spacing = _positive("spacing", spacing)
    floor = _finite("floor", floor)
    if x_edges is None:
        edges = _lattice_edges(points[:, 0], spacing)
    else:
        edges = np.asarray(x_edges, dtype=float)
        if edges.ndim != 1 or edges.size < 2 or not np.all(np.isfinite(edges)) or np.any(np.diff(edges) <= 0):
            raise ValueError(f"x_edges must be a 1-D, finite, strictly increasing array of >= 2 edges, got {edges!r}")
    index = _bin_index(points[:, 0], edges)
    inside = index >= 0
    top = np.full(edges.size - 1, -np.inf)
    np.maximum.at(top, index[inside], points[inside, 1])
    heights = np.where(np.isfinite(top), top + 0.5 * spacing - floor, 0.0)
    return 0.5 * (edges[:-1] + edges[1:]), heights


def front_position(
    position: np.ndarray,
    spacing: float,
    *,
    min_particles: int = 1,
    floor: float = 0.0,
    detach_gap: float | None = None,
) -> float:
    """Runout front (m): the right edge of the connected deposit.

    Definition, chosen so that single grains thrown ahead do not define the runout:

    1. Particles lying wholly below the floor (z + spacing/2 < ``floor``; leaked grains) are ignored.
    2. The rest are sorted by x and split into clusters wherever the centres of consecutive
       particles are more than ``detach_gap`` (default 2·spacing, i.e. one empty column is
       tolerated) apart along x.
    3. The main body is the cluster with the most particles (the left-most one on ties); clusters
       beyond a gap are detached and ignored.
    4. Within the main body, x-columns of width ``spacing`` holding fewer than ``min_particles``
       particles do not count (with ``min_particles=1``, every particle counts). The front is the
       largest x of a particle in a counted column, plus spacing/2.
    """
    points = _points("position", position)
    spacing = _positive("spacing", spacing)
    floor = _finite("floor", floor)
    gap = 2.0 * spacing if detach_gap is None else _positive("detach_gap", detach_gap)
    if int(min_particles) != min_particles or min_particles < 1:
        raise ValueError(f"min_particles must be an integer >= 1, got {min_particles!r}")
    x = np.sort(points[points[:, 1] + 0.5 * spacing >= floor, 0])
    if x.size == 0:
        raise ValueError(f"position holds no particle above floor={floor} (z + spacing/2 >= floor)")
    round_off = 1e-9 * spacing  # lattice neighbours exactly detach_gap apart stay connected
    starts = np.concatenate(([0], np.flatnonzero(np.diff(x) > gap + round_off) + 1))
    sizes = np.diff(np.concatenate((starts, [x.size])))
    main = int(np.argmax(sizes))
    body = x[starts[main] : starts[main] + sizes[main]]
    column = _bin_index(body, _lattice_edges(body, spacing))
    counted = np.bincount(column)[column] >= min_particles
    if not np.any(counted):
        raise ValueError(
            f"min_particles={min_particles} exceeds the fullest column of the main body "
            f"({int(np.bincount(column).max())} particles)"
        )
    return float(body[counted].max() + 0.5 * spacing)


def normalised_runout(front: float, origin: float, initial_length: float) -> float:
    """Normalised runout L* = (L − L0)/L0 with L = front − origin (Fig. 2.6b–d).

    ``origin`` is the x of the wall the column leaned on, ``initial_length`` the column width L0.
    """
    front = _finite("front", front)
    origin = _finite("origin", origin)
    initial_length = _positive("initial_length", initial_length)
    return (front - origin - initial_length) / initial_length


def final_height(position: np.ndarray, spacing: float, *, floor: float = 0.0) -> float:
    """Deposit height H_f (m): max z + spacing/2 − ``floor``."""
    points = _points("position", position)
    spacing = _positive("spacing", spacing)
    floor = _finite("floor", floor)
    return float(points[:, 1].max() + 0.5 * spacing - floor)


def normalised_height(final_height: float, initial_height: float) -> float:
    """Normalised final height H* = H_f/H0 (Fig. 2.6e)."""
    final_height = _finite("final_height", final_height)
    return final_height / _positive("initial_height", initial_height)


# -- energies ------------------------------------------------------------------------------------
def kinetic_energy(mass: np.ndarray, velocity: np.ndarray, width: float = 1.0) -> float:
    """Kinetic energy ½ Σ m |v|² × width (J); ``mass`` (N,) per metre of depth (kg/m), ``velocity`` (N, 2) m/s."""
    v = _points("velocity", velocity)
    m = _per_particle("mass", mass, v.shape[0])
    if np.any(m < 0):
        raise ValueError("mass must be >= 0 for every particle")
    return float(0.5 * np.sum(m * np.einsum("ij,ij->i", v, v)) * _positive("width", width))


def potential_energy(
    mass: np.ndarray, position: np.ndarray, gravity: float = 9.81, width: float = 1.0
) -> float:
    """Gravitational potential energy Σ m g z × width (J), relative to z = 0; ``gravity`` is |g| in m/s²."""
    points = _points("position", position)
    m = _per_particle("mass", mass, points.shape[0])
    if np.any(m < 0):
        raise ValueError("mass must be >= 0 for every particle")
    return float(np.sum(m * points[:, 1]) * _positive("gravity", gravity) * _positive("width", width))


def at_rest(kinetic_energy: float, potential_drop_scale: float, tolerance: float = 1e-4) -> bool:
    """Whether a collapse has come to rest: kinetic_energy ≤ tolerance × potential_drop_scale.

    The criterion is relative, so it does not depend on the resolution or the width. A natural
    ``potential_drop_scale`` is the potential energy released by the collapse so far (initial
    minus current), or for a column m_total·g·H0/2; both in the same units as ``kinetic_energy``.
    """
    energy = _finite("kinetic_energy", kinetic_energy)
    if energy < 0:
        raise ValueError(f"kinetic_energy must be >= 0, got {kinetic_energy!r}")
    scale = _positive("potential_drop_scale", potential_drop_scale)
    tolerance = float(tolerance)
    if not 0.0 < tolerance < 1.0:
        raise ValueError(f"tolerance must lie in (0, 1), got {tolerance!r}")
    return energy <= tolerance * scale


# -- stresses ------------------------------------------------------------------------------------
def stress_invariants(stress: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In-plane pressure and shear magnitude of (N, 2, 2) Cauchy stresses (Pa, tension positive).

    p = −tr(σ)/2 is the mean in-plane pressure (positive in compression), and τ = √(½ s:s) with
    s = σ − ½ tr(σ) I the 2D deviator. For a symmetric σ, τ = √(((σ_xx − σ_zz)/2)² + σ_xz²), the
    radius of Mohr's circle, i.e. the largest shear stress in the x–z plane. The out-of-plane
    stress of plane strain is not included.
    """
    sigma = _stress("stress", stress)
    trace = sigma[:, 0, 0] + sigma[:, 1, 1]
    deviator = sigma - 0.5 * trace[:, None, None] * np.eye(2)
    tau = np.sqrt(0.5 * np.einsum("nij,nij->n", deviator, deviator))
    return -0.5 * trace, tau


def yield_locus(stress: np.ndarray, pressure_bins: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """τ–p yield locus (Fig. 2.6f): the largest shear stress along pressure isobars.

    The range of p over all particles is split into ``pressure_bins`` equal bins; each non-empty
    bin contributes one point, (p, τ) of its particle with the largest τ (so data lying on
    τ = μp + c give points exactly on that line). Empty bins are dropped.

    Returns
    -------
    (p, tau):
        Pressures and shear stresses (Pa) of the locus points, sorted by p.
    """
    p, tau = stress_invariants(stress)
    if int(pressure_bins) != pressure_bins or pressure_bins < 1:
        raise ValueError(f"pressure_bins must be an integer >= 1, got {pressure_bins!r}")
    edges = np.linspace(p.min(), p.max(), int(pressure_bins) + 1)
    index = np.minimum(np.searchsorted(edges, p, side="right") - 1, int(pressure_bins) - 1)
    order = np.lexsort((-tau, index))
    first = order[np.concatenate(([True], np.diff(index[order]) != 0))]
    return p[first], tau[first]


def fit_line(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Least-squares line y ≈ slope·x + intercept; returns (slope, intercept, R²).

    R² = 1 − SS_res/SS_tot; it is 1 when y is constant and fitted exactly.
    """
    xs = np.asarray(x)
    if xs.ndim != 1 or xs.size < 2:
        raise ValueError(f"x must be 1-D with >= 2 values, got shape {xs.shape}")
    xs = _finite_array("x", xs, "1-D")
    ys = np.asarray(y)
    if ys.shape != xs.shape:
        raise ValueError(f"y must have the same shape as x {xs.shape}, got {ys.shape}")
    ys = _finite_array("y", ys, "1-D")
    if np.ptp(xs) == 0:
        raise ValueError("x must not be constant: a line through a single x is undefined")
    slope, intercept = np.polyfit(xs, ys, 1)
    residual = float(np.sum((ys - (slope * xs + intercept)) ** 2))
    total = float(np.sum((ys - ys.mean()) ** 2))
    r_squared = 1.0 - residual / total if total > 0 else 1.0
    return float(slope), float(intercept), float(r_squared)


def vertical_stress_profile(
    position: np.ndarray,
    stress: np.ndarray,
    spacing: float,
    x_range: tuple[float, float],
) -> tuple[np.ndarray, np.ndarray]:
    """Vertical stress σ_v = −σ_zz (Pa, positive in compression) averaged over horizontal layers.

    Particles with x_range[0] ≤ x ≤ x_range[1] are binned in z with layers of thickness
    ``spacing`` centred on a lattice through the lowest of them; empty layers are dropped.
    At rest under gravity σ_v should grow linearly with depth (ρ g (H − z)); check with
    :func:`fit_line`.

    Returns
    -------
    (z, sigma_v):
        Layer centres (m) and mean −σ_zz (Pa), sorted by z.
    """
    points = _points("position", position)
    sigma = _stress("stress", stress)
    if sigma.shape[0] != points.shape[0]:
        raise ValueError(
            f"stress must have one (2, 2) tensor per particle: shape ({points.shape[0]}, 2, 2), got {sigma.shape}"
        )
    spacing = _positive("spacing", spacing)
    bounds = np.asarray(x_range, dtype=float)
    if bounds.shape != (2,) or not np.all(np.isfinite(bounds)) or bounds[0] >= bounds[1]:
        raise ValueError(f"x_range must be (x_min, x_max) with finite x_min < x_max, got {x_range!r}")
    inside = (points[:, 0] >= bounds[0]) & (points[:, 0] <= bounds[1])
    if not np.any(inside):
        raise ValueError(f"x_range {tuple(bounds)} contains no particle")
    z = points[inside, 1]
    edges = _lattice_edges(z, spacing)
    layer = _bin_index(z, edges)
    counts = np.bincount(layer, minlength=edges.size - 1)
    sums = np.bincount(layer, weights=-sigma[inside, 1, 1], minlength=edges.size - 1)
    filled = counts > 0
    centres = 0.5 * (edges[:-1] + edges[1:])
    return centres[filled], sums[filled] / counts[filled]


def vertical_stress_scatter(
    position: np.ndarray,
    stress: np.ndarray,
    spacing: float,
    x_range: tuple[float, float],
) -> float:
    """Particle-to-particle scatter of σ_zz at fixed depth (Pa): the standard deviation of σ_zz
    within each horizontal layer of :func:`vertical_stress_profile`, averaged over the layers."""
    points = _points("position", position)
    sigma = _stress("stress", stress)
    bounds = np.asarray(x_range, dtype=float)
    inside = (points[:, 0] >= bounds[0]) & (points[:, 0] <= bounds[1])
    if not np.any(inside):
        raise ValueError(f"x_range {tuple(bounds)} contains no particle")
    z = points[inside, 1]
    layer = _bin_index(z, _lattice_edges(z, _positive("spacing", spacing)))
    sigma_zz = sigma[inside, 1, 1]
    return float(np.mean([sigma_zz[layer == k].std() for k in np.unique(layer)]))


#: grains closer than this many spacings belong to one deposit (neighbours on the lattice are 1 Δx
#: apart, diagonal ones √2 Δx; a grain farther from every other one is detached)
DEPOSIT_LINK_SPACINGS = 1.5


def connected_deposit(position: np.ndarray, spacing: float, link: float = DEPOSIT_LINK_SPACINGS) -> np.ndarray:
    """Which particles (bool mask) belong to the main deposit: the largest set of particles each
    closer than `link`·spacing to another of the set (the lowest-x set on ties). Grains thrown
    ahead or left behind, alone or in clumps, are not part of it."""
    points = _points("position", position)
    radius = _positive("link", link) * _positive("spacing", spacing)
    i, j = _pairs_within(points, radius)
    label = np.arange(len(points))
    while True:  # each particle takes the smallest label among its neighbours until none changes
        lowest = label.copy()
        np.minimum.at(lowest, i, label[j])
        lowest = lowest[lowest]  # pointer jumping: labels of labels, so chains settle in few rounds
        if np.array_equal(lowest, label):
            break
        label = lowest
    sizes = np.bincount(label, minlength=len(points))
    return label == int(np.argmax(sizes))


def deposit_front(position: np.ndarray, spacing: float, min_thickness: float, *, floor: float = 0.0,
                  bed_height: Callable[[np.ndarray], np.ndarray] | None = None) -> float:
    """Front of a deposit: going right from the leftmost occupied bin of the connected deposit's
    surface profile (:func:`connected_deposit`, bins one spacing wide), the right edge of the last
    bin at least `min_thickness` (m) thick before the first two consecutive bins thinner than it.

    The thickness is measured above `floor`, or above the bed surface z = bed_height(x) of a curved
    bed at each bin's centre. Unlike :func:`front_position`, a thin tail beyond the front does not
    count, so the front is where the deposit is resolved; a dip of one bin (a gap between the few
    grains of a thin deposit's top) does not cut it short, and detached grains do not count at
    all. It is known to within one bin, ±spacing.
    """
    if not min_thickness > 0:
        raise ValueError(f"min_thickness must be > 0, got {min_thickness!r}")
    points = _points("position", position)
    centres, heights = surface_profile(points[connected_deposit(points, spacing)], spacing, floor=floor)
    if bed_height is not None:
        heights = np.where(heights > 0, heights - np.asarray(bed_height(centres), float), 0.0)
    occupied = np.flatnonzero(heights > 0)
    if len(occupied) == 0:
        raise ValueError("position holds no particle above the floor")
    thick = np.append(heights[occupied[0]:] >= min_thickness, [False, False])
    if not thick[0]:
        return float(centres[occupied[0]] - 0.5 * spacing)
    end = int(np.flatnonzero(~thick[:-1] & ~thick[1:])[0])  # the first of two thin bins in a row
    return float(centres[occupied[0] + end - 1] + 0.5 * spacing)


# -- strain from displacements -------------------------------------------------------------------
def _pairs_within(points: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """All ordered pairs (i, j), i ≠ j, closer than `radius`, from a cell grid of side `radius`
    (each point meets the points of its own and the 8 adjacent cells)."""
    cells = np.floor((points - points.min(axis=0)) / radius).astype(np.int64)
    rows = int(cells[:, 1].max()) + 3
    key = (cells[:, 0] + 1) * rows + (cells[:, 1] + 1)  # padded by one cell on each side
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    firsts, seconds = [], []
    for dx in (-1, 0, 1):
        for dz in (-1, 0, 1):
            target = key + dx * rows + dz
            start = np.searchsorted(sorted_key, target, side="left")
            count = np.searchsorted(sorted_key, target, side="right") - start
            i = np.repeat(np.arange(len(points)), count)
            offsets = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
            j = order[np.repeat(start, count) + offsets]
            firsts.append(i)
            seconds.append(j)
    i, j = np.concatenate(firsts), np.concatenate(seconds)
    near = (i != j) & (np.sum((points[i] - points[j]) ** 2, axis=1) < radius * radius)
    return i[near], j[near]


def shear_strain(reference: np.ndarray, current: np.ndarray, radius: float) -> np.ndarray:
    """Von Mises shear strain η of each particle (dimensionless) between two frames matched by id.

    The deformation gradient F_i is the least-squares affine map of the vectors to the neighbours
    within `radius` of the reference frame (Falk & Langer 1998), E = ½(FᵀF − I) the Green–Lagrange
    strain, and η = √(E_xz² + (E_xx² + E_zz² + (E_xx − E_zz)²)/6) the von Mises invariant of
    Shimizu, Ogata & Li (2007) with the out-of-plane strain zero (plane strain). A rigid motion gives
    0; a simple shear x' = x + γz has E_xx = 0, E_xz = γ/2, E_zz = γ²/2, so η = √(γ²/4 + γ⁴/12).
    A particle with fewer than two neighbours that are not on one line gets NaN.
    """
    x0 = _points("reference", reference)
    x1 = _points("current", current)
    if x1.shape != x0.shape:
        raise ValueError(f"current must have the shape of reference {x0.shape}, got {x1.shape}")
    r = _positive("radius", radius)
    i, j = _pairs_within(x0, r)
    d0, d1 = x0[j] - x0[i], x1[j] - x1[i]
    n = len(x0)
    # F = (Σ d1 d0ᵀ)(Σ d0 d0ᵀ)⁻¹ over each particle's pairs
    moment = np.zeros((n, 2, 2))
    cross = np.zeros((n, 2, 2))
    np.add.at(moment, i, d0[:, :, None] * d0[:, None, :])
    np.add.at(cross, i, d1[:, :, None] * d0[:, None, :])
    determinant = np.linalg.det(moment)
    solvable = np.abs(determinant) > 1e-12 * np.maximum(np.einsum("nii->n", moment) ** 2, np.finfo(float).tiny)
    inverse = np.zeros_like(moment)
    inverse[solvable] = np.linalg.inv(moment[solvable])
    gradient = cross @ inverse
    strain = 0.5 * (np.transpose(gradient, (0, 2, 1)) @ gradient - np.eye(2))
    exx, exz, ezz = strain[:, 0, 0], strain[:, 0, 1], strain[:, 1, 1]
    eta = np.sqrt(exz**2 + (exx**2 + ezz**2 + (exx - ezz) ** 2) / 6.0)
    return np.where(solvable, eta, np.nan)
