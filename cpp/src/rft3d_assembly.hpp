// What the native 3D RFT stepper (rft3d_robot.cpp) and the MuJoCo plugin (cpp/plugin/rft_plugin.cpp)
// share between the element law (terrasph/rft3d.hpp) and the implicit step (backward_euler.hpp):
// the elements below the free surface at a pose, and the generalised load of the bodies that own
// them at given joint velocities, with its derivative.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cstddef>
#include <vector>

#include "backward_euler.hpp"
#include "terrasph/rft3d.hpp"
#include "terrasph/rft3d_robot.hpp"

namespace terrasph::rft {

using Matrix3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
using Matrix6 = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

/// Each body's farthest element centre from its origin (m), whatever the rotation.
inline std::vector<double> body_reach(const std::vector<RobotBody3D>& bodies) {
  std::vector<double> reach;
  for (const RobotBody3D& body : bodies) {
    double farthest = 0.0;
    for (std::size_t e = 0; e < body.area.size(); ++e)
      farthest = std::max(farthest, Eigen::Map<const Eigen::Vector3d>(&body.centre[3 * e]).norm());
    reach.push_back(farthest);
  }
  return reach;
}

/// The elements below the free surface at one pose, body by body (world frame).
struct Submerged {
  std::vector<std::size_t> owners;  // index into the coupled bodies
  std::vector<std::size_t> first;   // the owner's elements are [first[i], first[i + 1])
  std::vector<Vec3> arm;            // from the owner's centre of mass
  std::vector<Vec3> normal;
  std::vector<double> depth, area;

  /// Fills the set for `bodies` whose frames are MuJoCo's `xpos`, `xmat` (body axes as columns) and
  /// centres of mass `xipos` (indexed by body id), under the surface at z = `surface`: centre
  /// c = x_b + R c_b, depth z_s − c_z, arm c − x_com, normal R n_b. `reach` is each body's
  /// `body_reach`: a body whose origin lies higher above the surface has no element below it.
  void fill(const std::vector<RobotBody3D>& bodies, const std::vector<double>& reach, const double* xpos,
            const double* xmat, const double* xipos, double surface) {
    owners.clear();
    first.assign(1, 0);
    arm.clear();
    normal.clear();
    depth.clear();
    area.clear();
    for (std::size_t k = 0; k < bodies.size(); ++k) {
      const RobotBody3D& body = bodies[k];
      const int id = body.body_id;
      const Eigen::Map<const Matrix3> rotation(xmat + 9 * id);
      const Eigen::Map<const Eigen::Vector3d> origin(xpos + 3 * id), com(xipos + 3 * id);
      // skipped without turning its elements, same result (a margin for the rounding of R c)
      if (origin[2] - reach[k] * (1.0 + 1e-9) - 1e-12 > surface) continue;
      const std::size_t before = arm.size();
      for (std::size_t e = 0; e < body.area.size(); ++e) {
        const Eigen::Vector3d centre = origin + rotation * Eigen::Map<const Eigen::Vector3d>(&body.centre[3 * e]);
        const double below = surface - centre[2];
        if (!(below > 0.0)) continue;
        const Eigen::Vector3d n = rotation * Eigen::Map<const Eigen::Vector3d>(&body.normal[3 * e]);
        const Eigen::Vector3d r = centre - com;
        arm.push_back({r[0], r[1], r[2]});
        normal.push_back({n[0], n[1], n[2]});
        depth.push_back(below);
        area.push_back(body.area[e]);
      }
      if (arm.size() > before) {
        owners.push_back(k);
        first.push_back(arm.size());
      }
    }
  }

  /// Owner `i`'s elements, borrowed.
  SubmergedElements elements(std::size_t i) const {
    return {&arm[first[i]], &normal[first[i]], &depth[first[i]], &area[first[i]], first[i + 1] - first[i]};
  }
};

/// The owners' wrenches (F, τ about the centre of mass) at joint velocities `qvel`, each owner moving
/// with (v_com, ω) = J_i q̇ (`jacobians[i]`, 6 × nv, rows v_com then ω) into `wrenches`; their
/// generalised load Σ Jᵀ W added to `generalised` and, if asked for, its derivative in q̇,
/// Σ Jᵀ ∂W/∂ξ J, added to `stiffness`.
inline void add_generalised_load(const Submerged& sub, const std::vector<Matrix>& jacobians, const Vector& qvel,
                                 const Coefficients& table, double regularisation, bool jacobian,
                                 std::vector<Vector6>& wrenches, Vector& generalised, Matrix& stiffness) {
  for (std::size_t i = 0; i < sub.owners.size(); ++i) {
    const Vector6 twist = jacobians[i] * qvel;
    const BodyWrench load = body_wrench(sub.elements(i), {twist[0], twist[1], twist[2]},
                                        {twist[3], twist[4], twist[5]}, table, regularisation, jacobian);
    Vector6& wrench = wrenches[i];
    wrench = Eigen::Map<const Vector6>(load.wrench.data());
    const Eigen::Map<const Matrix6> slope(load.jacobian.data());
    generalised.noalias() += jacobians[i].transpose() * wrench;
    if (jacobian) stiffness.noalias() += jacobians[i].transpose() * (slope * jacobians[i]);
  }
}

}  // namespace terrasph::rft
