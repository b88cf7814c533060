// The surface elements of 3D resistive force theory from a body's solid geoms: the C++ form of
// terrasph.robots.geoms.body_surface (which documents the patches: equal-area bands and sectors
// on spheres, rings on discs, a grid on a box's faces and a cylinder's side, a mesh's triangles
// split until short enough), for the MuJoCo plugin (cpp/plugin/rft_plugin.cpp), which builds a
// model's elements when MuJoCo creates its mjData. No MuJoCo types: the caller describes each geom.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace terrasph::rft {

/// A solid geom in its body's frame: MuJoCo's kind (mjtGeom: sphere 2, capsule 3, ellipsoid 4,
/// cylinder 5, box 6, mesh 7), `size` (MuJoCo's geom_size), centre `position` and `rotation`
/// (row-major 3 × 3, the geom's axes as columns); a mesh's vertices (its frame, (count, 3)) and
/// counter-clockwise triangles ((faces, 3) vertex indices), borrowed.
struct GeomSolid {
  int kind = 0;
  std::array<double, 3> size{}, position{};
  std::array<double, 9> rotation{};
  const float* vertices = nullptr;
  int vertex_count = 0;
  const int* faces = nullptr;
  int face_count = 0;
};

/// The geom kinds body_surface() reads (MuJoCo's mjtGeom numbers).
enum GeomKind : int { kSphere = 2, kCapsule = 3, kEllipsoid = 4, kCylinder = 5, kBox = 6, kMesh = 7 };

/// True if body_surface() can read a geom of MuJoCo kind `kind`.
bool is_solid_kind(int kind);

/// Elements in the body's frame: centres and unit outward normals (count, 3) row-major, areas (count,).
struct SurfacePatches {
  std::vector<double> centre, normal, area;
  std::size_t size() const { return area.size(); }
};

/// The outer surface of the union of `geoms` as patches about `length` (m) across: each geom's
/// surface (areas summing to its surface area; a mesh: its triangles), without the patches just
/// outside which lies another of the geoms. Throws std::invalid_argument for a kind not solid.
SurfacePatches body_surface(const std::vector<GeomSolid>& geoms, double length);

}  // namespace terrasph::rft
