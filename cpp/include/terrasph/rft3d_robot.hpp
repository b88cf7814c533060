// Any MuJoCo robot on the flat 3D RFT terrain, stepped in native code: the implicit step of the
// Python class terrasph.robots.rft3d_terrain.RFT3DCoupling (which documents it) without a Python
// round trip per step. MuJoCo is called as by PlanarRobotStepper (terrasph/rft_robot.hpp): the
// functions of the library the `mujoco` package loaded, on the caller's own mjModel and mjData.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "terrasph/rft.hpp"
#include "terrasph/rft_robot.hpp"

namespace terrasph::rft {

/// A body that meets the terrain: MuJoCo body id and its 3D RFT elements in its own frame
/// (`centre` m and unit outward `normal`, (count, 3) row-major; `area` (count,) m²).
struct RobotBody3D {
  int body_id = 0;
  std::vector<double> centre, normal, area;
};

class Robot3DStepper {
 public:
  /// `library`: the path of the MuJoCo shared library already loaded; `model`, `data`: the addresses
  /// of the robot's mjModel and mjData (kept alive by the caller); the free surface at z = `surface`
  /// (m). Throws std::runtime_error if the library is not MuJoCo of the headers' version.
  Robot3DStepper(const std::string& library, std::uintptr_t model, std::uintptr_t data,
                 std::vector<RobotBody3D> bodies, std::vector<VelocityServo> servos, double surface,
                 Coefficients table, double time_step, double regularisation, NewtonSettings newton);
  ~Robot3DStepper();
  Robot3DStepper(const Robot3DStepper&) = delete;
  Robot3DStepper& operator=(const Robot3DStepper&) = delete;

  /// One step of `time_step`, MuJoCo's frames and body velocities (mj_kinematics, mj_comPos,
  /// mj_comVel) then brought to the state reached.
  /// Returns MuJoCo's count of the states it could not integrate and reset, so far.
  int step();
  /// Steps `count` times; returns step()'s count.
  int steps(long count);

  /// Each body's wrench integrated over time since cleared: (F, τ about the centre of mass) × s,
  /// world frame, six per body.
  std::vector<double>& load_sums() { return sums_; }
  long step_count() const { return steps_; }
  void set_step_count(long count) { steps_ = count; }
  double time_step() const { return dt_; }

 private:
  /// The step with elements in the sand: MuJoCo's step with the wrenches, then the Newton correction.
  void implicit_step();

  struct Impl;
  std::unique_ptr<Impl> impl_;
  double dt_;
  std::vector<double> sums_;
  long steps_ = 0;
};

}  // namespace terrasph::rft
