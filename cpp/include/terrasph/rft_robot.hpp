// A planar MuJoCo robot on the RFT terrain, stepped in native code: the implicit step of the Python
// class terrasph.robots.rft_terrain.RFTCoupling (which documents it) without a Python round trip per
// step. MuJoCo's functions are those of the library the `mujoco` Python package loaded (looked up
// by name in it, so the core does not link MuJoCo); its structures are those of the headers the
// core was built with, and the constructor refuses a library of another version.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "terrasph/rft.hpp"

namespace terrasph::rft {

/// A body of the robot that meets the terrain: MuJoCo body id, its surface elements (own frame;
/// `centre`, `normal` (count, 2) row-major, `length` (count,), m) and its pockets (PocketsView).
struct RobotBody {
  int body_id = 0;
  std::vector<double> centre, normal, length;
  double width = 0.0;
  std::vector<int> wall_pocket, cell_pocket;
  std::vector<double> cell_centre, cell_area;
  int pockets = 0;
  ElementsView view() const {
    return {centre.data(), normal.data(), length.data(), length.size(), width,
            {wall_pocket.data(), cell_centre.data(), cell_area.data(), cell_pocket.data(), cell_area.size(), pockets}};
  }
};

/// A torque-limited velocity servo (MJCF <velocity> with a forcerange): force kv (command − gear q̇)
/// on joint DOF `dof`, held within [lower, upper].
struct VelocityServo {
  int actuator = 0, dof = 0;
  double kv = 0.0, gear = 1.0, lower = 0.0, upper = 0.0;
};

/// Newton's method of the implicit step: at most `iterations`, each step halved at most `halvings`
/// times while it does not reduce the residual, stopping at `tolerance` × the step's momentum scale.
struct NewtonSettings {
  int iterations = 20, halvings = 6;
  double tolerance = 1e-8;
};

class PlanarRobotStepper {
 public:
  /// `library`: the path of the MuJoCo shared library already loaded; `model`, `data`: the addresses
  /// of the robot's mjModel and mjData (kept alive by the caller). Throws std::runtime_error if the
  /// library is not MuJoCo of the headers' version.
  PlanarRobotStepper(const std::string& library, std::uintptr_t model, std::uintptr_t data,
                     std::vector<RobotBody> bodies, std::vector<VelocityServo> servos, double surface,
                     Coefficients table, double time_step, double regularisation, NewtonSettings newton);
  ~PlanarRobotStepper();
  PlanarRobotStepper(const PlanarRobotStepper&) = delete;
  PlanarRobotStepper& operator=(const PlanarRobotStepper&) = delete;

  /// One step of `time_step`.
  /// Returns MuJoCo's count of the states it could not integrate and reset, so far.
  int step();
  /// Steps `count` times; returns step()'s count.
  int steps(long count);

  /// Each body's clockwise angle (rad), continuous over turns.
  std::vector<double>& angles() { return angles_; }
  /// Each body's load integrated over time since it was last cleared: (F_x, F_z, τ) × s per body.
  std::vector<double>& load_sums() { return sums_; }
  long step_count() const { return steps_; }
  /// How many times the steps evaluated the loads (and their Jacobian), since construction.
  long load_evaluations() const;
  void set_step_count(long count) { steps_ = count; }
  double time_step() const { return dt_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double dt_;
  std::vector<double> angles_, sums_;
  long steps_ = 0;
};

}  // namespace terrasph::rft
