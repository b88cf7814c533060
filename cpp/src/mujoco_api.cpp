// The MuJoCo functions of the native robot steppers: see mujoco_api.hpp.
#include "mujoco_api.hpp"

#include <dlfcn.h>

#include <stdexcept>

namespace terrasph::rft {

namespace {

template <typename Function>
void find(void* handle, const char* name, Function& out) {
  out = reinterpret_cast<Function>(dlsym(handle, name));
  if (out == nullptr) throw std::runtime_error(std::string("the MuJoCo library has no ") + name);
}

}  // namespace

MujocoApi::MujocoApi(const std::string& library) {
  void* handle = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NOLOAD);
  if (handle == nullptr) handle = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) throw std::runtime_error("cannot open the MuJoCo library '" + library + "'");
  const auto version = reinterpret_cast<decltype(&mj_version)>(dlsym(handle, "mj_version"));
  if (version == nullptr || version() != mjVERSION_HEADER)
    throw std::runtime_error("the MuJoCo library '" + library + "' is version " +
                             std::to_string(version ? version() : -1) + ", terrasph's core was built with " +
                             std::to_string(mjVERSION_HEADER) + ": rebuild terrasph against the installed mujoco");
  find(handle, "mj_step", step);
  find(handle, "mj_forward", forward);
  find(handle, "mj_jac", jac);
  find(handle, "mj_jacBodyCom", jac_body_com);
  find(handle, "mj_fullM", full_mass);
  find(handle, "mj_integratePos", integrate_positions);
  find(handle, "mj_kinematics", kinematics);
  find(handle, "mj_comPos", com_positions);
  find(handle, "mj_comVel", com_velocities);
  find(handle, "mj_forwardSkip", forward_skip);
  find(handle, "mj_Euler", euler);
  find(handle, "mj_checkPos", check_positions);
  find(handle, "mj_checkVel", check_velocities);
  find(handle, "mj_checkAcc", check_accelerations);
}

}  // namespace terrasph::rft
