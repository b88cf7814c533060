// Resistive force theory in 3D: the load of a flat granular surface on one surface element of a
// body moving in any direction, from the planar map of terrasph/rft.hpp taken in the vertical plane
// of the element's velocity. The law (planes, blends, regularisation) is documented in the Python
// module terrasph.rft3d, whose element_forces() calls element_force() below.
#pragma once

#include <array>
#include <cstddef>

#include "terrasph/rft.hpp"

namespace terrasph::rft {

using Vec3 = std::array<double, 3>;

/// The 3D RFT force on an element (world frame, N) and, if asked for, its derivative in the
/// element's velocity ∂F/∂v (row-major 3 × 3, N s/m) at fixed pose and depth.
struct ElementLoad {
  Vec3 force{};
  std::array<double, 9> jacobian{};
};

/// The load on an element of unit outward `normal` moving with `velocity` (m/s) at `depth` (m)
/// below the free surface with `area` (m²): terrasph.rft3d's law; 0 above the surface and on a
/// trailing face (n·v ≤ 0). The Jacobian is that of the formula where it is smooth, one-sided (in
/// +v_x, +v_y) where the horizontal velocity is exactly 0.
ElementLoad element_force(const Vec3& normal, const Vec3& velocity, double depth, double area,
                          const Coefficients& table, double regularisation, bool jacobian);

/// A body's elements below the free surface, world frame, borrowed: arms from the body's reference
/// point (its centre of mass), unit outward normals, depths (m), areas (m²).
struct SubmergedElements {
  const Vec3* arm = nullptr;
  const Vec3* normal = nullptr;
  const double* depth = nullptr;
  const double* area = nullptr;
  std::size_t count = 0;
};

/// The body's wrench (F, τ = Σ r × F_e about the reference point; N, N m) and, if asked for, its
/// derivative in the body's (velocity of the reference point, angular velocity), row-major 6 × 6.
struct BodyWrench {
  std::array<double, 6> wrench{};
  std::array<double, 36> jacobian{};
};

/// The load on `elements` of a body moving with `velocity` (m/s) at its reference point and angular
/// velocity `spin` (rad/s): each element at v = velocity + spin × r takes element_force().
BodyWrench body_wrench(const SubmergedElements& elements, const Vec3& velocity, const Vec3& spin,
                       const Coefficients& table, double regularisation, bool jacobian);

/// element_force() on `count` elements: `normal`, `velocity` and `out` (count, 3) row-major,
/// `depth`, `area` (count,).
void element_forces(const double* normal, const double* velocity, const double* depth, const double* area,
                    std::size_t count, const Coefficients& table, double regularisation, double* out);

}  // namespace terrasph::rft
