// What the native 3D RFT stepper (rft3d_robot.cpp) and the MuJoCo plugin (cpp/plugin/rft_plugin.cpp)
// share between the element law (terrasph/rft3d.hpp) and the implicit step (backward_euler.hpp):
// the elements below the free surface at a pose, and the generalised load of the bodies that own
// them at given joint velocities, with its derivative.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <map>
#include <vector>

#include "backward_euler.hpp"
#include "terrasph/rft3d.hpp"
#include "terrasph/rft3d_robot.hpp"

namespace terrasph::rft {

using Matrix3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
using Matrix6 = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

/// A spatial cluster of a body's elements: the centre (body frame, m) and radius (m) of a sphere
/// that holds their centres, and their indices in ascending order.
struct ElementCluster {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0.0;
  std::vector<std::size_t> elements;
};

/// What Submerged::fill() reads of a body's extent: its farthest element centre from its origin (m,
/// whatever the rotation) and its elements in clusters, so that the elements of a cluster wholly
/// above the surface are skipped without being turned to the pose.
struct BodyBounds {
  double reach = 0.0;
  std::vector<ElementCluster> clusters;
};

/// Clusters per body side: the body's elements are binned in cubes of side reach / this (the Ant's
/// ankle: 8 cm cubes, a few of its 314 elements' clusters reach into the sand when it stands).
constexpr double kClustersPerReach = 8.0;

/// Each body's BodyBounds: its elements binned in cubes of side reach / kClustersPerReach (body frame).
inline std::vector<BodyBounds> body_bounds(const std::vector<RobotBody3D>& bodies) {
  std::vector<BodyBounds> bounds;
  for (const RobotBody3D& body : bodies) {
    BodyBounds b;
    const std::size_t count = body.area.size();
    for (std::size_t e = 0; e < count; ++e)
      b.reach = std::max(b.reach, Eigen::Map<const Eigen::Vector3d>(&body.centre[3 * e]).norm());
    const double side = b.reach > 0.0 ? b.reach / kClustersPerReach : 1.0;
    std::map<std::array<long, 3>, std::size_t> cell_of;  // cube → cluster
    for (std::size_t e = 0; e < count; ++e) {
      std::array<long, 3> cell{};
      for (std::size_t i = 0; i < 3; ++i) cell[i] = std::lround(std::floor(body.centre[3 * e + i] / side));
      const auto [at, added] = cell_of.emplace(cell, b.clusters.size());
      if (added) b.clusters.emplace_back();
      b.clusters[at->second].elements.push_back(e);
    }
    for (ElementCluster& cluster : b.clusters) {
      for (const std::size_t e : cluster.elements) cluster.centre += Eigen::Map<const Eigen::Vector3d>(&body.centre[3 * e]);
      cluster.centre /= static_cast<double>(cluster.elements.size());
      for (const std::size_t e : cluster.elements)
        cluster.radius =
            std::max(cluster.radius, (Eigen::Map<const Eigen::Vector3d>(&body.centre[3 * e]) - cluster.centre).norm());
    }
    bounds.push_back(std::move(b));
  }
  return bounds;
}

/// The elements below the free surface at one pose, body by body (world frame).
struct Submerged {
  std::vector<std::size_t> owners;  // index into the coupled bodies
  std::vector<std::size_t> first;   // the owner's elements are [first[i], first[i + 1])
  std::vector<Vec3> arm;            // from the owner's centre of mass
  std::vector<Vec3> normal;
  std::vector<double> depth, area;
  std::vector<std::size_t> candidates;  // fill()'s scratch: a body's elements in clusters that may reach the sand

  /// True if every point within `radius` of height `z` lies above the surface (with a margin for rounding).
  static bool above(double z, double radius, double surface) { return z - radius * (1.0 + 1e-9) - 1e-12 > surface; }

  /// Fills the set for `bodies` whose frames are MuJoCo's `xpos`, `xmat` (body axes as columns) and
  /// centres of mass `xipos` (indexed by body id), under the surface at z = `surface`: centre
  /// c = x_b + R c_b, depth z_s − c_z, arm c − x_com, normal R n_b; each body's elements in their
  /// order. `bounds` is each body's body_bounds(): a body whose origin lies higher above the surface
  /// than its reach, or a cluster whose sphere does, has no element below it and is skipped without
  /// turning its elements (a margin for the rounding of R c: the same set as turning them all).
  void fill(const std::vector<RobotBody3D>& bodies, const std::vector<BodyBounds>& bounds, const double* xpos,
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
      if (above(origin[2], bounds[k].reach, surface)) continue;
      candidates.clear();
      for (const ElementCluster& cluster : bounds[k].clusters)
        if (!above(origin[2] + rotation.row(2).dot(cluster.centre), cluster.radius, surface))
          candidates.insert(candidates.end(), cluster.elements.begin(), cluster.elements.end());
      std::sort(candidates.begin(), candidates.end());  // the body's order: its sums' order
      const std::size_t before = arm.size();
      for (const std::size_t e : candidates) {
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
