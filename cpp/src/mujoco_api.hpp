// What the native robot steppers (rft_robot.cpp, rft3d_robot.cpp) share: the MuJoCo functions they
// call, looked up by name in the library the `mujoco` Python package loaded (so the core does not
// link MuJoCo), and the torque-limited velocity servo's force.
#pragma once

#include <mujoco/mujoco.h>

#include <string>
#include <utility>
#include <vector>

#include "terrasph/rft_robot.hpp"

namespace terrasph::rft {

/// The MuJoCo functions the steppers call (signatures from the headers the core was built with).
struct MujocoApi {
  decltype(&mj_step) step = nullptr;
  decltype(&mj_forward) forward = nullptr;
  decltype(&mj_jac) jac = nullptr;
  decltype(&mj_jacBodyCom) jac_body_com = nullptr;
  decltype(&mj_fullM) full_mass = nullptr;
  decltype(&mj_integratePos) integrate_positions = nullptr;
  decltype(&mj_kinematics) kinematics = nullptr;
  decltype(&mj_comPos) com_positions = nullptr;
  decltype(&mj_comVel) com_velocities = nullptr;
  decltype(&mj_forwardSkip) forward_skip = nullptr;
  decltype(&mj_Euler) euler = nullptr;
  decltype(&mj_checkPos) check_positions = nullptr;
  decltype(&mj_checkVel) check_velocities = nullptr;
  decltype(&mj_checkAcc) check_accelerations = nullptr;

  /// Opens `library` (the path of the MuJoCo shared library); throws std::runtime_error if it is not
  /// MuJoCo of the headers' version or lacks a function.
  explicit MujocoApi(const std::string& library);
};

/// How many times MuJoCo has met a state it could not integrate (bad qacc, qpos or qvel) and reset
/// `d` (terrasph.robots.coupling.divergences).
inline int divergence_count(const mjData* d) {
  return d->warning[mjWARN_BADQACC].number + d->warning[mjWARN_BADQPOS].number + d->warning[mjWARN_BADQVEL].number;
}

/// The servo's force kv (command − gear q̇) held within its limits at the joint's velocity
/// `joint_velocity`, and its derivative in it (−kv gear within the limits, 0 at them).
inline std::pair<double, double> servo_force(const VelocityServo& servo, double command, double joint_velocity) {
  const double raw = servo.kv * (command - servo.gear * joint_velocity);
  if (raw <= servo.lower) return {servo.lower, 0.0};
  if (raw >= servo.upper) return {servo.upper, 0.0};
  return {raw, -servo.kv * servo.gear};
}

/// Sets each servo's actuator to a plain force (gain 1, no velocity bias) of `forces[k]` for the next
/// step, or (`forces` null) back to the model's servo with `commands[k]`.
inline void set_servos(mjModel* m, mjData* d, const std::vector<VelocityServo>& servos, const double* forces,
                       const std::vector<double>& commands) {
  for (std::size_t k = 0; k < servos.size(); ++k) {
    const int a = servos[k].actuator;
    m->actuator_gainprm[a * mjNGAIN] = forces ? 1.0 : servos[k].kv;
    m->actuator_biasprm[a * mjNBIAS + 2] = forces ? 0.0 : -servos[k].kv;
    d->ctrl[a] = forces ? forces[k] : commands[k];
  }
}

}  // namespace terrasph::rft
