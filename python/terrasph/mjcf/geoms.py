"""MJCF geoms as terrain bodies: a MuJoCo body's collision geoms become its particle shape.

A planar robot moves in the x–z plane, so what the terrain meets of a geom is its outline seen
along y: the projection of the solid onto the x–z plane (for a geom centred on y = 0 and symmetric
about it, as the planar models' are, the same as its cross-section at y = 0). Every geom type
MuJoCo offers for solids is convex, so that projection is the convex polygon of the support points
p(u) = argmax_{x in geom} u·x over in-plane directions u = (cos φ, 0, sin φ): each type's support
point has a closed form (sphere, capsule, cylinder, ellipsoid, box; a mesh's is its farthest
vertex), so one routine serves them all and gives a box or mesh its exact corners and a round
geom a polygon within r(1 − cos(π/N)) of its curve. The geom's extent across the plane is the
distance between its support points along ±y (a capsule's 2r, a box's 2·size_y).

:func:`shape_from_loops` fills convex loops (one per geom, in the body frame, counter-clockwise
in x–z) with cell-centred particles Δx apart on a lattice aligned with each loop's principal axis
and centred on it — so a part of thickness t gets round(t/Δx) rows, the convention of
:mod:`terrasph.bodies` — merges particles of overlapping loops closer than Δx/2, and gives each the
outward normal of the nearest piece of the union's outer surface (edges inside another loop are
left out). The result is a :class:`terrasph.bodies.BodyShape` whose ``outline`` holds the loops,
the geometry resistive force theory reads too.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import mujoco
import numpy as np

from terrasph.bodies import BodyShape, _merge_indices, nearest_edge_normals
from terrasph.config import ConfigError
from terrasph.mjcf.model import body_name

__all__ = ["CONVERTIBLE", "SUPPORT_DIRECTIONS", "body_shape", "body_surface", "geom_extent_y", "geom_loop",
           "geom_support", "geom_surface", "geom_thickness", "inside_geom", "is_collision_geom", "shape_from_loops"]

#: the geom types that become terrain shapes
CONVERTIBLE = {mujoco.mjtGeom.mjGEOM_SPHERE: "sphere", mujoco.mjtGeom.mjGEOM_CAPSULE: "capsule",
               mujoco.mjtGeom.mjGEOM_CYLINDER: "cylinder", mujoco.mjtGeom.mjGEOM_ELLIPSOID: "ellipsoid",
               mujoco.mjtGeom.mjGEOM_BOX: "box", mujoco.mjtGeom.mjGEOM_MESH: "mesh"}
#: in-plane directions of a round geom's outline polygon: its vertices lie on the curve, at most
#: r(1 − cos(π/N)) = 7.5e-5·r inside it
SUPPORT_DIRECTIONS = 256


def _type_name(kind: int) -> str:
    return mujoco.mjtGeom(kind).name[7:].lower()


def is_collision_geom(model: mujoco.MjModel, geom: int) -> bool:
    """True if the geom takes part in MuJoCo's contacts (contype or conaffinity set)."""
    return bool(model.geom_contype[geom] or model.geom_conaffinity[geom])


def geom_support(model: mujoco.MjModel, geom: int, centre: np.ndarray, rotation: np.ndarray,
                 directions: np.ndarray) -> np.ndarray:
    """Support points (K, 3) of geom `geom` placed at `centre` with 3×3 `rotation` (its axes as
    columns, in any frame) for unit `directions` (K, 3) of that frame: the point of the solid
    farthest along each direction. ConfigError for a type that is not a solid of finite size."""
    kind = int(model.geom_type[geom])
    size = model.geom_size[geom]
    local = directions @ rotation  # the directions in the geom's own axes
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        point = size[0] * local
    elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:  # segment ±h along z, swept by a sphere of radius r
        point = size[0] * local
        point[:, 2] += np.where(local[:, 2] >= 0, size[1], -size[1])
    elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:  # the farther end disc's rim point toward the direction
        across = np.hypot(local[:, 0], local[:, 1])
        scale = np.divide(size[0], across, out=np.zeros_like(across), where=across > 1e-12)
        point = np.column_stack([local[:, 0] * scale, local[:, 1] * scale,
                                 np.where(local[:, 2] >= 0, size[1], -size[1])])
    elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:  # x = S² u / sqrt(uᵀ S² u) with S = diag(semi-axes)
        stretched = local * size[:3] ** 2
        point = stretched / np.sqrt(np.sum(stretched * local, axis=1))[:, None]
    elif kind == mujoco.mjtGeom.mjGEOM_BOX:
        point = np.sign(local) * size[:3]
    elif kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[geom])
        start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        vertices = np.asarray(model.mesh_vert[start:start + count], dtype=float)
        point = vertices[np.argmax(local @ vertices.T, axis=1)]
    else:
        raise _not_convertible(model, geom)
    return centre + point @ rotation.T


def _not_convertible(model: mujoco.MjModel, geom: int) -> ConfigError:
    """The error for a collision geom of a type that cannot become a terrain body (a plane, height
    field, SDF), naming it and the allowed types."""
    name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"#{geom}"
    return ConfigError(f"geom '{name}' is a {_type_name(int(model.geom_type[geom]))}, which cannot become a terrain "
                       f"body: allowed {', '.join(CONVERTIBLE.values())} (switch its contacts off, "
                       "contype=conaffinity=0, or leave its body out of the coupled bodies)")


def _in_body_frame(model: mujoco.MjModel, geom: int) -> tuple[np.ndarray, np.ndarray]:
    """The geom's centre and rotation matrix in its body's frame."""
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, model.geom_quat[geom])
    return np.array(model.geom_pos[geom], dtype=float), rotation.reshape(3, 3)


def geom_loop(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """The geom's outline in the x–z plane of its body frame: the convex polygon (K, 2) of its
    support points, counter-clockwise (body on the left), consecutive repeats dropped."""
    phi = 2 * math.pi * np.arange(SUPPORT_DIRECTIONS) / SUPPORT_DIRECTIONS
    directions = np.column_stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)])
    points = geom_support(model, geom, *_in_body_frame(model, geom), directions)[:, [0, 2]]
    scale = float(np.ptp(points, axis=0).max())
    distinct = np.hypot(*(points - np.roll(points, 1, axis=0)).T) > 1e-9 * max(scale, 1e-12)
    loop = points[distinct]
    if len(loop) < 3:
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"#{geom}"
        raise ConfigError(f"geom '{name}' has no area in the x–z plane (it is edge-on); it cannot become a "
                          "terrain body")
    return loop


def geom_extent_y(model: mujoco.MjModel, geom: int) -> tuple[float, float]:
    """The geom's lowest and highest y in its body frame (m): its extent across the plane."""
    along_y = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    low, high = geom_support(model, geom, *_in_body_frame(model, geom), along_y)[:, 1]
    return float(low), float(high)


def geom_thickness(model: mujoco.MjModel, geom: int) -> float:
    """The geom's least width in the x–z plane (m): the minimum over in-plane directions n of
    h(n) + h(−n), h its exact support function, found by a golden-section search about the best of
    its outline's edge normals (the outline polygon alone, inscribed in a round geom, would be up to
    2r(1 − cos(π/N)) too thin, and a capsule's width grows to first order off its normal)."""
    pose = _in_body_frame(model, geom)

    def width(angle: float) -> float:
        n = np.array([[math.cos(angle), 0.0, math.sin(angle)]])
        return float((geom_support(model, geom, *pose, n) - geom_support(model, geom, *pose, -n))[0] @ n[0])

    loop = geom_loop(model, geom)
    edges = np.roll(loop, -1, axis=0) - loop
    angles = np.arctan2(-edges[:, 0], edges[:, 1])  # each edge's outward normal (e_z, −e_x)
    best = float(angles[np.argmin([width(a) for a in angles])])
    low, high = best - 4 * math.pi / SUPPORT_DIRECTIONS, best + 4 * math.pi / SUPPORT_DIRECTIONS
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    while high - low > 1e-10:
        a, b = high - ratio * (high - low), low + ratio * (high - low)
        if width(a) < width(b):
            high = b
        else:
            low = a
    return min(width(0.5 * (low + high)), width(best))


def _principal_axis(loop: np.ndarray) -> np.ndarray:
    """Unit direction of the polygon's longest principal axis (second moments of its vertices; x for
    a polygon as long as it is wide, such as a disc's)."""
    centred = loop - loop.mean(axis=0)
    values, vectors = np.linalg.eigh(centred.T @ centred)
    if values[1] - values[0] <= 1e-6 * values[1]:
        return np.array([1.0, 0.0])
    return vectors[:, 1]


def _inside(points: np.ndarray, loop: np.ndarray, tolerance: float) -> np.ndarray:
    """Points inside (or within `tolerance` outside) the convex counter-clockwise `loop`."""
    edges = np.roll(loop, -1, axis=0) - loop
    length = np.hypot(edges[:, 0], edges[:, 1])
    rel = points[:, None, :] - loop[None, :, :]
    # signed distance to the left of each edge: positive inside a counter-clockwise loop
    left = (edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0]) / length[None, :]
    return np.all(left >= -tolerance, axis=1)


def _lattice(loop: np.ndarray, spacing: float) -> np.ndarray:
    """Cell centres Δx apart inside `loop`, on a lattice along its principal axis centred on the
    loop's extent: an extent t across gets round(t/Δx) rows (at least one)."""
    u = _principal_axis(loop)
    v = np.array([-u[1], u[0]])
    along, across = loop @ u, loop @ v
    axes = []
    for coordinate in (along, across):
        low, high = float(coordinate.min()), float(coordinate.max())
        n = max(1, round((high - low) / spacing))
        axes.append(0.5 * (low + high) + (np.arange(n) - 0.5 * (n - 1)) * spacing)
    a, b = np.meshgrid(*axes, indexing="ij")
    points = a.reshape(-1, 1) * u + b.reshape(-1, 1) * v
    return points[_inside(points, loop, 1e-9 * spacing)]


def _min_width(loop: np.ndarray) -> float:
    """The convex polygon's least width: the smallest extent over its edges' normal directions."""
    edges = np.roll(loop, -1, axis=0) - loop
    normals = np.column_stack([edges[:, 1], -edges[:, 0]]) / np.hypot(edges[:, 0], edges[:, 1])[:, None]
    extents = loop @ normals.T
    return float((extents.max(axis=0) - extents.min(axis=0)).min())


def _outer_edges(loops: Sequence[np.ndarray], spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The loops' edges cut into pieces no longer than Δx/4, without the pieces whose middle lies
    inside another loop: the union's outer surface, as edges a → b with the body on their left."""
    starts, ends = [], []
    for k, loop in enumerate(loops):
        for a, b in zip(loop, np.roll(loop, -1, axis=0)):
            pieces = max(1, math.ceil(float(np.hypot(*(b - a))) / (0.25 * spacing)))
            t = np.arange(pieces + 1)[:, None] / pieces
            nodes = a + t * (b - a)
            middle = 0.5 * (nodes[:-1] + nodes[1:])
            outside = np.ones(pieces, bool)
            for j, other in enumerate(loops):
                if j != k:
                    outside &= ~_inside(middle, other, -1e-9 * spacing)
            starts.append(nodes[:-1][outside])
            ends.append(nodes[1:][outside])
    return np.concatenate(starts), np.concatenate(ends)


def shape_from_loops(name: str, loops: Sequence[np.ndarray], spacing: float, width: float,
                     thickness: float | None = None) -> BodyShape:
    """A body made of the union of convex counter-clockwise `loops` (x–z, body frame, m): particles
    Δx apart filling each loop (module docstring), merged where loops overlap, with the outward
    normal of the union's nearest outer edge. Its ``thickness`` (the thinnest part, checked against
    :func:`terrasph.bodies.minimum_thickness` when the scene is validated) is `thickness` if given,
    else the least width of any loop; its ``radius`` the farthest outline point from the body
    origin, its ``outline`` the loops."""
    loops = [np.asarray(loop, dtype=float) for loop in loops]
    if not loops:
        raise ConfigError(f"body '{name}' has no geometry to fill")
    points = np.concatenate([_lattice(loop, spacing) for loop in loops])
    if len(points) == 0:
        raise ConfigError(f"body '{name}' is thinner than the spacing {spacing:g} m everywhere; no particle fits")
    points = points[_merge_indices(points, 0.5 * spacing)]
    normals = nearest_edge_normals(points, *_outer_edges(loops, spacing), spacing)
    thickness = min(_min_width(loop) for loop in loops) if thickness is None else thickness
    radius = max(float(np.hypot(loop[:, 0], loop[:, 1]).max()) for loop in loops)
    return BodyShape(name, points, normals, spacing, thickness, width, radius, tuple(loops))


def body_shape(model: mujoco.MjModel, body: int, spacing: float, width: float | None = None) -> BodyShape:
    """The particle shape of MuJoCo body `body`, in its frame, from its collision geoms (the union of
    their outlines in x–z); `width` (m) defaults to the geoms' extent across the plane."""
    name = body_name(model, body)
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body and is_collision_geom(model, g)]
    if not geoms:
        raise ConfigError(f"body '{name}' has no collision geom to meet the terrain with")
    loops = [geom_loop(model, g) for g in geoms]
    if width is None:
        extents = np.array([geom_extent_y(model, g) for g in geoms])
        width = float(extents[:, 1].max() - extents[:, 0].min())
    return shape_from_loops(name, loops, spacing, width, min(geom_thickness(model, g) for g in geoms))


# ---------------------------------------------------------------------------------------------
# the geoms' surfaces in 3D: the elements of 3D resistive force theory (terrasph.terrain.rft3d)

def _zone(radius: float, z_low: float, z_high: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Patches of the sphere of `radius` between heights z_low·r and z_high·r (−1 ≤ z_low < z_high ≤ 1):
    bands equal in height, so equal in area (Archimedes), each cut into equal sectors about `length`
    long; each patch's point on the sphere (at its band's mean height and its sector's middle) and
    area. The points over the radius are the outward normals."""
    arc = radius * (math.acos(z_low) - math.acos(z_high))
    bands = max(1, math.ceil(arc / length))
    edges = np.linspace(z_low, z_high, bands + 1)
    points, areas = [], []
    for lo, hi in itertools.pairwise(edges):
        z = 0.5 * (lo + hi)
        ring = math.sqrt(max(0.0, 1.0 - z * z))
        sectors = max(3, math.ceil(2 * math.pi * radius * ring / length))
        phi = 2 * math.pi * (np.arange(sectors) + 0.5) / sectors
        points.append(radius * np.column_stack([ring * np.cos(phi), ring * np.sin(phi), np.full(sectors, z)]))
        areas.append(np.full(sectors, 2 * math.pi * radius * radius * (hi - lo) / sectors))
    return np.concatenate(points), np.concatenate(areas)


def _disc(radius: float, z: float, up: bool, length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The disc of `radius` at height `z` facing +z (`up`) or −z, as rings about `length` wide cut
    into sectors about `length` long: points, normals and areas."""
    rings = max(1, math.ceil(radius / length))
    edges = np.linspace(0.0, radius, rings + 1)
    points, areas = [], []
    for lo, hi in itertools.pairwise(edges):
        middle = math.sqrt(0.5 * (lo * lo + hi * hi))  # halves the ring's area
        sectors = max(3, math.ceil(2 * math.pi * middle / length))
        phi = 2 * math.pi * (np.arange(sectors) + 0.5) / sectors
        points.append(np.column_stack([middle * np.cos(phi), middle * np.sin(phi), np.full(sectors, z)]))
        areas.append(np.full(sectors, math.pi * (hi * hi - lo * lo) / sectors))
    point = np.concatenate(points)
    normal = np.zeros_like(point)
    normal[:, 2] = 1.0 if up else -1.0
    return point, normal, np.concatenate(areas)


def _tube(radius: float, half: float, length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The side of a cylinder of `radius` along z over [−half, half]: points, normals and areas."""
    sectors = max(8, math.ceil(2 * math.pi * radius / length))
    rows = max(1, math.ceil(2 * half / length))
    phi = 2 * math.pi * (np.arange(sectors) + 0.5) / sectors
    z = -half + 2 * half * (np.arange(rows) + 0.5) / rows
    p, h = np.meshgrid(phi, z, indexing="ij")
    normal = np.column_stack([np.cos(p.ravel()), np.sin(p.ravel()), np.zeros(p.size)])
    point = radius * normal + np.column_stack([np.zeros(p.size), np.zeros(p.size), h.ravel()])
    return point, normal, np.full(p.size, 2 * math.pi * radius * 2 * half / p.size)


def _triangles(vertices: np.ndarray, faces: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A triangle mesh (counter-clockwise faces seen from outside) with every triangle split in four
    at its edges' middles until its longest edge is at most `length`: centroids, normals, areas."""
    tri = vertices[faces]  # (F, 3 corners, 3)
    done = []
    while len(tri):
        longest = np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2), axis=1)
        small = longest <= length
        done.append(tri[small])
        big = tri[~small]
        a, b, c = big[:, 0], big[:, 1], big[:, 2]
        ab, bc, ca = 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)
        tri = np.concatenate([np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    tri = np.concatenate(done)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    twice = np.linalg.norm(cross, axis=1)
    keep = twice > 0
    return tri[keep].mean(axis=1), cross[keep] / twice[keep, None], 0.5 * twice[keep]


def _mesh(model: mujoco.MjModel, geom: int) -> tuple[np.ndarray, np.ndarray]:
    """The vertices and faces of a mesh geom, in the geom's frame."""
    mesh = int(model.geom_dataid[geom])
    start, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
    first, faces = int(model.mesh_faceadr[mesh]), int(model.mesh_facenum[mesh])
    return (np.asarray(model.mesh_vert[start:start + count], dtype=float),
            np.asarray(model.mesh_face[first:first + faces], dtype=int))


def geom_surface(model: mujoco.MjModel, geom: int, length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The geom's surface as patches about `length` (m) across, in its body's frame: centres (K, 3) on
    the surface, unit outward normals (K, 3) and areas (K,) summing to the geom's surface area (a
    sphere, capsule, cylinder, ellipsoid or box exactly; a mesh is its triangles, split until
    each is at most `length` long). ConfigError for a plane, height field or SDF (naming it)."""
    kind = int(model.geom_type[geom])
    size = np.asarray(model.geom_size[geom], dtype=float)
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        point, area = _zone(size[0], -1.0, 1.0, length)
        normal = point / size[0]
    elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        r, h = size[0], size[1]
        top, top_area = _zone(r, 0.0, 1.0, length)
        bottom, bottom_area = _zone(r, -1.0, 0.0, length)
        side = _tube(r, h, length)
        point = np.concatenate([top + [0, 0, h], bottom - [0, 0, h], side[0]])
        normal = np.concatenate([top / r, bottom / r, side[1]])
        area = np.concatenate([top_area, bottom_area, side[2]])
    elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        parts = [_tube(size[0], size[1], length), _disc(size[0], size[1], True, length),
                 _disc(size[0], -size[1], False, length)]
        point, normal, area = (np.concatenate(column) for column in zip(*parts))
    elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:  # the unit sphere stretched by S = diag(semi-axes)
        unit, unit_area = _zone(1.0, -1.0, 1.0, length / float(size[:3].max()))
        point = unit * size[:3]
        inverse = unit / size[:3]  # S⁻¹ n: the stretched normal and the area's scale det(S)·|S⁻¹ n|
        scale = np.linalg.norm(inverse, axis=1)
        normal, area = inverse / scale[:, None], unit_area * float(np.prod(size[:3])) * scale
    elif kind == mujoco.mjtGeom.mjGEOM_BOX:
        parts = []
        for axis in range(3):
            u, v = [k for k in range(3) if k != axis]
            nu, nv = (max(1, math.ceil(2 * size[k] / length)) for k in (u, v))
            a, b = np.meshgrid(size[u] * (2 * (np.arange(nu) + 0.5) / nu - 1),
                               size[v] * (2 * (np.arange(nv) + 0.5) / nv - 1), indexing="ij")
            for sign in (-1.0, 1.0):
                point = np.zeros((a.size, 3))
                point[:, u], point[:, v], point[:, axis] = a.ravel(), b.ravel(), sign * size[axis]
                normal = np.zeros_like(point)
                normal[:, axis] = sign
                parts.append((point, normal, np.full(a.size, 4 * size[u] * size[v] / a.size)))
        point, normal, area = (np.concatenate(column) for column in zip(*parts))
    elif kind == mujoco.mjtGeom.mjGEOM_MESH:
        point, normal, area = _triangles(*_mesh(model, geom), length)
    else:
        raise _not_convertible(model, geom)
    centre, rotation = _in_body_frame(model, geom)
    return centre + point @ rotation.T, normal @ rotation.T, area


def inside_geom(model: mujoco.MjModel, geom: int, points: np.ndarray) -> np.ndarray:
    """Which `points` (K, 3, in the geom's body frame) lie strictly inside the solid geom (a mesh
    taken as convex, MuJoCo's collision hull of it)."""
    centre, rotation = _in_body_frame(model, geom)
    local = (points - centre) @ rotation
    kind = int(model.geom_type[geom])
    size = np.asarray(model.geom_size[geom], dtype=float)
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return np.linalg.norm(local, axis=1) < size[0]
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        axis = np.clip(local[:, 2], -size[1], size[1])
        return np.hypot(np.hypot(local[:, 0], local[:, 1]), local[:, 2] - axis) < size[0]
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return (np.hypot(local[:, 0], local[:, 1]) < size[0]) & (np.abs(local[:, 2]) < size[1])
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return np.sum((local / size[:3]) ** 2, axis=1) < 1.0
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return np.all(np.abs(local) < size[:3], axis=1)
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        vertices, faces = _mesh(model, geom)
        tri = vertices[faces]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        return np.all(np.einsum("kfi,fi->kf", local[:, None, :] - tri[None, :, 0], normal) < 0, axis=1)
    raise _not_convertible(model, geom)


def body_surface(model: mujoco.MjModel, body: int, length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The outer surface of MuJoCo body `body`'s collision geoms (the same geoms as
    :func:`body_shape`'s) in its frame: patches about `length` (m) across (:func:`geom_surface`),
    without those just outside which lies another of its geoms (the union's inside); centres,
    outward normals, areas."""
    name = body_name(model, body)
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body and is_collision_geom(model, g)]
    if not geoms:
        raise ConfigError(f"body '{name}' has no collision geom to meet the terrain with")
    parts = [geom_surface(model, g, length) for g in geoms]
    kept = []
    for k, (point, normal, _) in enumerate(parts):
        probe = point + 1e-3 * length * normal
        outer = np.ones(len(point), bool)
        for j, other in enumerate(geoms):
            if j != k:
                outer &= ~inside_geom(model, other, probe)
        kept.append(outer)
    return tuple(np.concatenate([part[i][keep] for part, keep in zip(parts, kept)]) for i in range(3))  # type: ignore[return-value]
