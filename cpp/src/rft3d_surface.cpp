// The surface elements of 3D RFT from solid geoms: see terrasph/rft3d_surface.hpp and
// terrasph.robots.geoms.geom_surface, whose patches these are, in the same order.
#include "terrasph/rft3d_surface.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace terrasph::rft {

namespace {

using Vec3 = std::array<double, 3>;
constexpr double kPi = 3.14159265358979323846;

/// Patches of one geom in its own frame.
struct Patches {
  std::vector<Vec3> point, normal;
  std::vector<double> area;
  void add(const Vec3& p, const Vec3& n, double a) {
    point.push_back(p);
    normal.push_back(n);
    area.push_back(a);
  }
};

/// ceil(x) as a count, at least `least`.
int count_at_least(double x, int least) { return std::max(least, static_cast<int>(std::ceil(x))); }

/// numpy.linspace(low, high, count + 1)[i]: the end point exact.
double grid(double low, double high, int count, int i) {
  return i == count ? high : low + i * ((high - low) / count);
}

/// The sphere of `radius` between heights z_low r and z_high r in bands equal in height, so equal in
/// area (Archimedes), each cut into sectors about `length` long; `shift` moves the points along z.
/// The normals are the points over the radius (before the shift).
void zone(double radius, double z_low, double z_high, double length, double shift, Patches& out) {
  const double arc = radius * (std::acos(z_low) - std::acos(z_high));
  const int bands = count_at_least(arc / length, 1);
  for (int b = 0; b < bands; ++b) {
    const double lo = grid(z_low, z_high, bands, b), hi = grid(z_low, z_high, bands, b + 1);
    const double z = 0.5 * (lo + hi);
    const double ring = std::sqrt(std::max(0.0, 1.0 - z * z));
    const int sectors = count_at_least(2 * kPi * radius * ring / length, 3);
    const double area = 2 * kPi * radius * radius * (hi - lo) / sectors;
    for (int s = 0; s < sectors; ++s) {
      const double phi = 2 * kPi * (s + 0.5) / sectors;
      const Vec3 p{radius * (ring * std::cos(phi)), radius * (ring * std::sin(phi)), radius * z};
      out.add({p[0], p[1], p[2] + shift}, {p[0] / radius, p[1] / radius, p[2] / radius}, area);
    }
  }
}

/// The disc of `radius` at height `z` facing +z (`up`) or −z, in rings about `length` wide, each
/// cut into sectors about `length` long (the sector's point on the circle halving the ring's area).
void disc(double radius, double z, bool up, double length, Patches& out) {
  const int rings = count_at_least(radius / length, 1);
  for (int r = 0; r < rings; ++r) {
    const double lo = grid(0.0, radius, rings, r), hi = grid(0.0, radius, rings, r + 1);
    const double middle = std::sqrt(0.5 * (lo * lo + hi * hi));
    const int sectors = count_at_least(2 * kPi * middle / length, 3);
    const double area = kPi * (hi * hi - lo * lo) / sectors;
    for (int s = 0; s < sectors; ++s) {
      const double phi = 2 * kPi * (s + 0.5) / sectors;
      out.add({middle * std::cos(phi), middle * std::sin(phi), z}, {0.0, 0.0, up ? 1.0 : -1.0}, area);
    }
  }
}

/// The side of a cylinder of `radius` along z over [−half, half]: sectors × rows.
void tube(double radius, double half, double length, Patches& out) {
  const int sectors = count_at_least(2 * kPi * radius / length, 8);
  const int rows = count_at_least(2 * half / length, 1);
  const double area = 2 * kPi * radius * 2 * half / (sectors * rows);
  for (int s = 0; s < sectors; ++s) {
    const double phi = 2 * kPi * (s + 0.5) / sectors;
    const Vec3 n{std::cos(phi), std::sin(phi), 0.0};
    for (int r = 0; r < rows; ++r) out.add({radius * n[0], radius * n[1], -half + 2 * half * (r + 0.5) / rows}, n, area);
  }
}

/// A box's six faces, each a grid of cells about `length` across.
void box(const std::array<double, 3>& size, double length, Patches& out) {
  for (int axis = 0; axis < 3; ++axis) {
    const int u = axis == 0 ? 1 : 0, v = axis == 2 ? 1 : 2;
    const int nu = count_at_least(2 * size[u] / length, 1), nv = count_at_least(2 * size[v] / length, 1);
    const double area = 4 * size[u] * size[v] / (nu * nv);
    for (const double sign : {-1.0, 1.0}) {
      for (int i = 0; i < nu; ++i) {
        for (int j = 0; j < nv; ++j) {
          Vec3 p{}, n{};
          p[u] = size[u] * (2 * (i + 0.5) / nu - 1);
          p[v] = size[v] * (2 * (j + 0.5) / nv - 1);
          p[axis] = sign * size[axis];
          n[axis] = sign;
          out.add(p, n, area);
        }
      }
    }
  }
}

Vec3 minus(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 midpoint(const Vec3& a, const Vec3& b) { return {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])}; }
double norm(const Vec3& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

using Triangle = std::array<Vec3, 3>;

/// A mesh's triangles, each split in four at its edges' middles until its longest edge is at most
/// `length`: centroids, unit normals (counter-clockwise seen from outside) and areas.
void triangles(const GeomSolid& mesh, double length, Patches& out) {
  const auto vertex = [&](int k) {
    const float* p = mesh.vertices + 3 * k;
    return Vec3{static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])};
  };
  std::vector<Triangle> pending, small;
  for (int f = 0; f < mesh.face_count; ++f) {
    const int* face = mesh.faces + 3 * f;
    pending.push_back({vertex(face[0]), vertex(face[1]), vertex(face[2])});
  }
  while (!pending.empty()) {  // each pass: the short ones kept, the long ones split (geoms._triangles)
    std::array<std::vector<Triangle>, 4> children;
    for (const Triangle& t : pending) {
      const double longest = std::max({norm(minus(t[0], t[2])), norm(minus(t[1], t[0])), norm(minus(t[2], t[1]))});
      if (longest <= length) {
        small.push_back(t);
        continue;
      }
      const Vec3 ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
      children[0].push_back({t[0], ab, ca});
      children[1].push_back({ab, t[1], bc});
      children[2].push_back({ca, bc, t[2]});
      children[3].push_back({ab, bc, ca});
    }
    pending.clear();
    for (const auto& group : children) pending.insert(pending.end(), group.begin(), group.end());
  }
  for (const Triangle& t : small) {
    const Vec3 c = cross(minus(t[1], t[0]), minus(t[2], t[0]));
    const double twice = norm(c);
    if (!(twice > 0.0)) continue;
    out.add({(t[0][0] + t[1][0] + t[2][0]) / 3, (t[0][1] + t[1][1] + t[2][1]) / 3, (t[0][2] + t[1][2] + t[2][2]) / 3},
            {c[0] / twice, c[1] / twice, c[2] / twice}, 0.5 * twice);
  }
}

/// The geom's patches in its own frame (geoms.geom_surface before the placement).
Patches own_patches(const GeomSolid& g, double length) {
  Patches out;
  const auto& size = g.size;
  switch (g.kind) {
    case kSphere:
      zone(size[0], -1.0, 1.0, length, 0.0, out);
      break;
    case kCapsule:
      zone(size[0], 0.0, 1.0, length, size[1], out);
      zone(size[0], -1.0, 0.0, length, -size[1], out);
      tube(size[0], size[1], length, out);
      break;
    case kCylinder:
      tube(size[0], size[1], length, out);
      disc(size[0], size[1], true, length, out);
      disc(size[0], -size[1], false, length, out);
      break;
    case kEllipsoid: {  // the unit sphere stretched by S = diag(semi-axes): normal ∝ S⁻¹ n, area × det S |S⁻¹ n|
      Patches unit;
      zone(1.0, -1.0, 1.0, length / std::max({size[0], size[1], size[2]}), 0.0, unit);
      for (std::size_t k = 0; k < unit.area.size(); ++k) {
        const Vec3& u = unit.point[k];
        const Vec3 inverse{u[0] / size[0], u[1] / size[1], u[2] / size[2]};
        const double scale = norm(inverse);
        out.add({u[0] * size[0], u[1] * size[1], u[2] * size[2]},
                {inverse[0] / scale, inverse[1] / scale, inverse[2] / scale},
                unit.area[k] * (size[0] * size[1] * size[2]) * scale);
      }
      break;
    }
    case kBox:
      box(size, length, out);
      break;
    case kMesh:
      triangles(g, length, out);
      break;
    default:
      throw std::invalid_argument("geom kind " + std::to_string(g.kind) + " is not a solid");
  }
  return out;
}

/// R a + c, R row-major.
Vec3 place(const std::array<double, 9>& r, const Vec3& a, const Vec3& c) {
  return {c[0] + r[0] * a[0] + r[1] * a[1] + r[2] * a[2], c[1] + r[3] * a[0] + r[4] * a[1] + r[5] * a[2],
          c[2] + r[6] * a[0] + r[7] * a[1] + r[8] * a[2]};
}

/// Whether `p` (body frame) lies strictly inside the solid (a mesh taken as convex: MuJoCo's
/// collision hull of it); geoms.inside_geom.
bool inside(const GeomSolid& g, const Vec3& p) {
  const Vec3 d = minus(p, g.position);
  const auto& r = g.rotation;  // local = Rᵀ (p − c)
  const Vec3 q{r[0] * d[0] + r[3] * d[1] + r[6] * d[2], r[1] * d[0] + r[4] * d[1] + r[7] * d[2],
               r[2] * d[0] + r[5] * d[1] + r[8] * d[2]};
  const auto& s = g.size;
  switch (g.kind) {
    case kSphere:
      return norm(q) < s[0];
    case kCapsule: {
      const double axis = std::clamp(q[2], -s[1], s[1]);
      return std::hypot(std::hypot(q[0], q[1]), q[2] - axis) < s[0];
    }
    case kCylinder:
      return std::hypot(q[0], q[1]) < s[0] && std::abs(q[2]) < s[1];
    case kEllipsoid:
      return (q[0] / s[0]) * (q[0] / s[0]) + (q[1] / s[1]) * (q[1] / s[1]) + (q[2] / s[2]) * (q[2] / s[2]) < 1.0;
    case kBox:
      return std::abs(q[0]) < s[0] && std::abs(q[1]) < s[1] && std::abs(q[2]) < s[2];
    case kMesh:
      for (int f = 0; f < g.face_count; ++f) {
        const int* face = g.faces + 3 * f;
        Vec3 v[3];
        for (int k = 0; k < 3; ++k)
          for (int i = 0; i < 3; ++i) v[k][i] = static_cast<double>(g.vertices[3 * face[k] + i]);
        const Vec3 n = cross(minus(v[1], v[0]), minus(v[2], v[0]));
        const Vec3 a = minus(q, v[0]);
        if (!(a[0] * n[0] + a[1] * n[1] + a[2] * n[2] < 0.0)) return false;
      }
      return true;
    default:
      return false;
  }
}

}  // namespace

bool is_solid_kind(int kind) { return kind >= kSphere && kind <= kMesh; }

SurfacePatches body_surface(const std::vector<GeomSolid>& geoms, double length) {
  SurfacePatches out;
  for (std::size_t k = 0; k < geoms.size(); ++k) {
    const GeomSolid& g = geoms[k];
    const Patches own = own_patches(g, length);
    for (std::size_t e = 0; e < own.area.size(); ++e) {
      const Vec3 centre = place(g.rotation, own.point[e], g.position);
      const Vec3 normal = place(g.rotation, own.normal[e], {0.0, 0.0, 0.0});
      const double step = 1e-3 * length;  // a probe just outside the patch: is it inside another geom?
      const Vec3 probe{centre[0] + step * normal[0], centre[1] + step * normal[1], centre[2] + step * normal[2]};
      bool outer = true;
      for (std::size_t j = 0; j < geoms.size() && outer; ++j) outer = j == k || !inside(geoms[j], probe);
      if (!outer) continue;
      out.centre.insert(out.centre.end(), centre.begin(), centre.end());
      out.normal.insert(out.normal.end(), normal.begin(), normal.end());
      out.area.push_back(own.area[e]);
    }
  }
  return out;
}

}  // namespace terrasph::rft
