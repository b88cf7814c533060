// The native step of any MuJoCo robot on the 3D RFT terrain: see terrasph/rft3d_robot.hpp and the
// Python class terrasph.robots.rft3d_terrain.RFT3DCoupling, whose docstring gives the scheme.
#include "terrasph/rft3d_robot.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "backward_euler.hpp"
#include "mujoco_api.hpp"
#include "rft3d_assembly.hpp"
#include "terrasph/rft3d.hpp"

namespace terrasph::rft {

struct Robot3DStepper::Impl {
  MujocoApi api;
  mjModel* m;
  mjData* d;
  std::vector<RobotBody3D> bodies;
  std::vector<VelocityServo> servos;
  double surface, regularisation;
  Coefficients table;
  NewtonSettings newton;
  int nv;
  Submerged sub;
  std::vector<Matrix> jacobians;  // each owner's 6 × nv Jacobian of (v_com, ω) at the step's start
  std::vector<Vector6> wrenches;   // each owner's (F, τ about the centre of mass)
  std::vector<double> commands;
  Vector generalised;
  Matrix stiffness, mass;
  std::vector<mjtNum> linear, angular;
  std::vector<BodyBounds> bounds;  // each body's body_bounds()

  Impl(const std::string& library, std::uintptr_t model, std::uintptr_t data, std::vector<RobotBody3D> bodies_,
       std::vector<VelocityServo> servos_, double surface_, Coefficients table_, double regularisation_,
       NewtonSettings newton_)
      : api(library), m(reinterpret_cast<mjModel*>(model)), d(reinterpret_cast<mjData*>(data)),
        bodies(std::move(bodies_)), servos(std::move(servos_)), surface(surface_), regularisation(regularisation_),
        table(table_), newton(newton_), nv(static_cast<int>(m->nv)), commands(servos.size()), generalised(m->nv),
        stiffness(m->nv, m->nv), mass(m->nv, m->nv), linear(static_cast<std::size_t>(3 * m->nv)),
        angular(static_cast<std::size_t>(3 * m->nv)), bounds(body_bounds(bodies)) {}

  /// The elements below the surface at the current pose (Submerged::fill).
  void submerge() {
    sub.fill(bodies, bounds, d->xpos, d->xmat, d->xipos, surface);
    jacobians.resize(sub.owners.size(), Matrix::Zero(6, nv));
    wrenches.resize(sub.owners.size());
  }

  /// Each owner's Jacobian at its centre of mass (mj_jacBodyCom: rows v_com, then ω).
  void take_jacobians() {
    for (std::size_t i = 0; i < sub.owners.size(); ++i) {
      api.jac_body_com(m, d, linear.data(), angular.data(), bodies[sub.owners[i]].body_id);
      jacobians[i].topRows(3) = Eigen::Map<const Matrix>(linear.data(), 3, nv);
      jacobians[i].bottomRows(3) = Eigen::Map<const Matrix>(angular.data(), 3, nv);
    }
  }

  /// The owners' wrenches at joint velocities `qvel` (each element at v = v_com + ω × r, r its arm;
  /// F = Σ F_e, τ = Σ r × F_e), their generalised force with the servos' (Σ Jᵀ W + servo forces) in
  /// `generalised` and, if asked for, its derivative in q̇ (Σ Jᵀ ∂W/∂ξ J + the servos') in `stiffness`.
  void evaluate(const Vector& qvel, bool jacobian) {
    generalised.setZero();
    if (jacobian) stiffness.setZero();
    add_generalised_load(sub, jacobians, qvel, table, regularisation, jacobian, wrenches, generalised, stiffness);
    for (std::size_t k = 0; k < servos.size(); ++k) {
      const auto [force, slope] = servo_force(servos[k], commands[k], qvel[servos[k].dof]);
      generalised[servos[k].dof] += servos[k].gear * force;
      if (jacobian) stiffness(servos[k].dof, servos[k].dof) += servos[k].gear * slope;
    }
  }

  /// MuJoCo's step from the forward pass just made, with the loads now in xfrc_applied and the
  /// actuators' settings now in the model: under Euler, mj_step's stages after the velocity's
  /// (mj_forwardSkip from mjSTAGE_VEL, mj_checkAcc, mj_Euler: the positions' and velocities' stages
  /// are the start's, computed once); under another integrator, mj_step.
  void integrate() {
    if (m->opt.integrator != mjINT_EULER) {
      api.step(m, d);
      return;
    }
    api.forward_skip(m, d, mjSTAGE_VEL, 0);
    api.check_accelerations(m, d);
    api.euler(m, d);
  }

  /// The wrenches at the step's start pose as backward_euler() evaluates them.
  struct StepLoads {
    Impl& robot;
    Vector& generalised;
    Matrix& stiffness;
    std::vector<Vector6> best;
    static constexpr bool kCheapJacobian = false;  // the 3D law's costs several loads
    void evaluate(const Vector& qvel, bool jacobian) { robot.evaluate(qvel, jacobian); }
    void keep() { best = robot.wrenches; }
    void restore() { robot.wrenches = best; }
  };
};

Robot3DStepper::Robot3DStepper(const std::string& library, std::uintptr_t model, std::uintptr_t data,
                               std::vector<RobotBody3D> bodies, std::vector<VelocityServo> servos, double surface,
                               Coefficients table, double time_step, double regularisation, NewtonSettings newton)
    : impl_(std::make_unique<Impl>(library, model, data, std::move(bodies), std::move(servos), surface, table,
                                   regularisation, newton)),
      dt_(time_step),
      sums_(6 * impl_->bodies.size(), 0.0) {}

Robot3DStepper::~Robot3DStepper() = default;

int Robot3DStepper::step() {
  Impl& s = *impl_;
  mjModel* m = s.m;
  mjData* d = s.d;
  m->opt.timestep = dt_;  // MuJoCo's step is the implicit correction's dt
  if (m->opt.integrator == mjINT_EULER) {  // mj_step's checks before its forward pass (integrate())
    s.api.check_positions(m, d);
    s.api.check_velocities(m, d);
  }
  s.api.forward(m, d);  // the start pose's frames, Jacobians and mass matrix
  s.submerge();
  std::fill(d->xfrc_applied, d->xfrc_applied + 6 * m->nbody, 0.0);
  if (s.sub.owners.empty()) {  // nothing in the sand: MuJoCo's step alone
    s.integrate();
  } else {
    implicit_step();
  }
  s.api.kinematics(m, d);  // mj_step leaves the derived quantities at the step's start
  s.api.com_positions(m, d);
  s.api.com_velocities(m, d);
  ++steps_;
  return divergence_count(impl_->d);
}

void Robot3DStepper::implicit_step() {
  Impl& s = *impl_;
  mjModel* m = s.m;
  mjData* d = s.d;
  s.take_jacobians();
  s.api.full_mass(m, d, s.mass.data());
  const Vector start = Eigen::Map<const Vector>(d->qvel, s.nv);
  for (std::size_t k = 0; k < s.servos.size(); ++k) s.commands[k] = d->ctrl[s.servos[k].actuator];
  s.evaluate(start, false);  // W_n and G_n at t_n
  const Vector applied = s.generalised;
  for (std::size_t i = 0; i < s.sub.owners.size(); ++i)  // xfrc_applied: force and torque at the centre of mass
    std::copy(s.wrenches[i].data(), s.wrenches[i].data() + 6, d->xfrc_applied + 6 * s.bodies[s.sub.owners[i]].body_id);
  // each torque-limited velocity servo as a plain force, its force at t_n (the Newton step corrects it)
  std::vector<double> forces(s.servos.size());
  for (std::size_t k = 0; k < s.servos.size(); ++k)
    forces[k] = servo_force(s.servos[k], s.commands[k], start[s.servos[k].dof]).first;
  set_servos(m, d, s.servos, forces.data(), s.commands);
  s.integrate();
  set_servos(m, d, s.servos, nullptr, s.commands);
  const Vector explicit_qvel = Eigen::Map<const Vector>(d->qvel, s.nv);
  Impl::StepLoads loads{s, s.generalised, s.stiffness, {}};
  const Vector qvel = backward_euler(loads, s.mass, explicit_qvel, applied, start, nullptr, dt_, s.newton);
  const Vector change = qvel - explicit_qvel;
  s.api.integrate_positions(m, d->qpos, change.data(), dt_);  // q moves by dt (q̇ − q̇*)
  Eigen::Map<Vector>(d->qvel, s.nv) = qvel;
  std::fill(d->xfrc_applied, d->xfrc_applied + 6 * m->nbody, 0.0);
  for (std::size_t i = 0; i < s.sub.owners.size(); ++i)
    for (std::size_t c = 0; c < 6; ++c) sums_[6 * s.sub.owners[i] + c] += s.wrenches[i][static_cast<Eigen::Index>(c)] * dt_;
}

int Robot3DStepper::steps(long count) {
  for (long k = 0; k < count; ++k) step();
  return divergence_count(impl_->d);
}

}  // namespace terrasph::rft
