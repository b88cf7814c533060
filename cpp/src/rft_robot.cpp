// The native step of a planar robot on the RFT terrain: see terrasph/rft_robot.hpp and the Python
// class terrasph.robots.rft_terrain.RFTCoupling, whose docstring gives the scheme.
#include "terrasph/rft_robot.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "backward_euler.hpp"
#include "mujoco_api.hpp"

namespace terrasph::rft {

namespace {

double unwrapped(double previous, double wrapped) {
  return previous + std::remainder(wrapped - previous, 2.0 * M_PI);
}

}  // namespace

struct PlanarRobotStepper::Impl {
  MujocoApi api;
  mjModel* m;
  mjData* d;
  std::vector<RobotBody> bodies;
  std::vector<VelocityServo> servos;
  double surface, regularisation;
  Coefficients table;
  NewtonSettings newton;
  int nv;
  std::vector<Matrix> twists;  // each body's ∂(v_x, v_z, ω)/∂q̇ at the step's start (3 × nv)
  std::vector<double> commands;
  std::vector<BodyLoad> loads;
  std::vector<Immersion> immersions;  // each body's immersion at the step's start pose
  Vector generalised;
  Matrix stiffness;
  long evaluations = 0;  // of the loads, since construction

  Impl(const std::string& library, std::uintptr_t model, std::uintptr_t data, std::vector<RobotBody> bodies_,
       std::vector<VelocityServo> servos_, double surface_, Coefficients table_, double regularisation_,
       NewtonSettings newton_)
      : api(library), m(reinterpret_cast<mjModel*>(model)), d(reinterpret_cast<mjData*>(data)),
        bodies(std::move(bodies_)), servos(std::move(servos_)), surface(surface_), regularisation(regularisation_),
        table(table_), newton(newton_), nv(static_cast<int>(m->nv)), twists(bodies.size(), Matrix::Zero(3, m->nv)),
        commands(servos.size()), loads(bodies.size()), immersions(bodies.size()), generalised(m->nv),
        stiffness(m->nv, m->nv) {}

  /// Each body's immersion at the step's start pose (the pose its Newton iterations keep).
  void take_immersions(const std::vector<double>& angles) {
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const int id = bodies[b].body_id;
      const PlanarMotion pose{angles[b], d->xpos[3 * id], d->xpos[3 * id + 2], 0.0, 0.0, 0.0};
      immerse(bodies[b].view(), pose, surface, table, immersions[b]);
    }
  }

  /// Each body's twist Jacobian at its frame origin (mj_jac: rows x, z of the linear part, y of the angular).
  void take_twists() {
    std::vector<mjtNum> linear(static_cast<std::size_t>(3 * nv)), angular(static_cast<std::size_t>(3 * nv));
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const int id = bodies[b].body_id;
      api.jac(m, d, linear.data(), angular.data(), d->xpos + 3 * id, id);
      for (int j = 0; j < nv; ++j) {
        twists[b](0, j) = linear[static_cast<std::size_t>(j)];
        twists[b](1, j) = linear[static_cast<std::size_t>(2 * nv + j)];
        twists[b](2, j) = angular[static_cast<std::size_t>(nv + j)];
      }
    }
  }

  /// The RFT loads at the step's start poses and joint velocities `qvel`, their generalised force
  /// with the servos' (Σ Jᵀ (F, τ) + servo forces) in `generalised` and its derivative in q̇ in `stiffness`.
  void evaluate(const std::vector<double>& angles, const Vector& qvel) {
    ++evaluations;
    generalised.setZero();
    stiffness.setZero();
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const int id = bodies[b].body_id;
      const Eigen::Vector3d twist = twists[b] * qvel;
      const PlanarMotion motion{angles[b], d->xpos[3 * id], d->xpos[3 * id + 2], twist[0], twist[1], twist[2]};
      loads[b] = body_load(immersions[b], motion, table, regularisation, true);
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> jacobian(loads[b].jacobian.data());
      generalised.noalias() += twists[b].transpose() * Eigen::Vector3d(loads[b].fx, loads[b].fz, loads[b].torque);
      stiffness.noalias() += twists[b].transpose() * (jacobian * twists[b]);
    }
    for (std::size_t k = 0; k < servos.size(); ++k) {
      const auto [force, slope] = servo_force(servos[k], commands[k], qvel[servos[k].dof]);
      generalised[servos[k].dof] += servos[k].gear * force;
      stiffness(servos[k].dof, servos[k].dof) += servos[k].gear * slope;
    }
  }

  /// MuJoCo's step with the loads in xfrc_applied (moved to the centre of mass) and each servo a
  /// plain force; the model's servos and the caller's commands put back after it.
  void mujoco_step(const Vector& start, double dt) {
    for (std::size_t b = 0; b < bodies.size(); ++b) {
      const int id = bodies[b].body_id;
      const double ox = d->xpos[3 * id] - d->xipos[3 * id], oz = d->xpos[3 * id + 2] - d->xipos[3 * id + 2];
      mjtNum* applied = d->xfrc_applied + 6 * id;
      std::fill(applied, applied + 6, 0.0);
      applied[0] = loads[b].fx;
      applied[2] = loads[b].fz;
      applied[4] = loads[b].torque + oz * loads[b].fx - ox * loads[b].fz;  // τ_com = τ_ref + ((x_ref − x_com) × F)_y
    }
    std::vector<double> forces(servos.size());
    for (std::size_t k = 0; k < servos.size(); ++k) forces[k] = servo_force(servos[k], commands[k], start[servos[k].dof]).first;
    set_servos(m, d, servos, forces.data(), commands);
    m->opt.timestep = dt;
    api.step(m, d);
    set_servos(m, d, servos, nullptr, commands);
  }

  /// The loads at the step's start poses as backward_euler() evaluates them.
  struct StepLoads {
    Impl& robot;
    const std::vector<double>& angles;
    Vector& generalised;
    Matrix& stiffness;
    std::vector<BodyLoad> best;
    static constexpr bool kCheapJacobian = true;  // the planar law's: taken with every load
    void evaluate(const Vector& qvel, bool /*jacobian*/) { robot.evaluate(angles, qvel); }
    void keep() { best = robot.loads; }
    void restore() { robot.loads = best; }
  };

  /// Backward Euler in the loads and servo forces (backward_euler(); RFTCoupling's docstring) from
  /// G_n = `applied` and K_n = `start_stiffness` at q̇_n = `start_qvel`; the positions moved by dt (q̇ − q̇*).
  void implicit_step(const std::vector<double>& angles, const Vector& applied, const Vector& start_qvel,
                     const Matrix& start_stiffness, double dt) {
    Matrix mass(nv, nv);
    api.full_mass(m, d, mass.data());  // qM is still that of the step's start
    for (int j = 0; j < nv; ++j) mass(j, j) += dt * m->dof_damping[j];
    const Vector explicit_qvel = Eigen::Map<const Vector>(d->qvel, nv);
    StepLoads step_loads{*this, angles, generalised, stiffness, {}};
    const Vector qvel = backward_euler(step_loads, mass, explicit_qvel, applied, start_qvel, &start_stiffness, dt, newton);
    const Vector change = qvel - explicit_qvel;
    api.integrate_positions(m, d->qpos, change.data(), dt);
    Eigen::Map<Vector>(d->qvel, nv) = qvel;
  }
};

PlanarRobotStepper::PlanarRobotStepper(const std::string& library, std::uintptr_t model, std::uintptr_t data,
                                       std::vector<RobotBody> bodies, std::vector<VelocityServo> servos,
                                       double surface, Coefficients table, double time_step,
                                       double regularisation, NewtonSettings newton)
    : impl_(std::make_unique<Impl>(library, model, data, std::move(bodies), std::move(servos), surface, table,
                                   regularisation, newton)),
      dt_(time_step) {
  const Impl& impl = *impl_;
  for (const RobotBody& body : impl.bodies) {
    const mjtNum* rotation = impl.d->xmat + 9 * body.body_id;  // row-major: [0] = R_xx, [2] = R_xz
    angles_.push_back(std::atan2(rotation[2], rotation[0]));
  }
  sums_.assign(3 * impl.bodies.size(), 0.0);
}

PlanarRobotStepper::~PlanarRobotStepper() = default;

long PlanarRobotStepper::load_evaluations() const { return impl_->evaluations; }

int PlanarRobotStepper::step() {
  Impl& s = *impl_;
  s.take_twists();
  s.take_immersions(angles_);
  const Vector start = Eigen::Map<const Vector>(s.d->qvel, s.nv);
  for (std::size_t k = 0; k < s.servos.size(); ++k) s.commands[k] = s.d->ctrl[s.servos[k].actuator];
  s.evaluate(angles_, start);
  const Vector applied = s.generalised;
  const bool stiff = s.stiffness.cwiseAbs().maxCoeff() > 0.0;
  const Matrix start_stiffness = s.stiffness;
  s.mujoco_step(start, dt_);
  if (stiff) s.implicit_step(angles_, applied, start, start_stiffness, dt_);
  for (std::size_t b = 0; b < s.bodies.size(); ++b) {
    sums_[3 * b] += s.loads[b].fx * dt_;
    sums_[3 * b + 1] += s.loads[b].fz * dt_;
    sums_[3 * b + 2] += s.loads[b].torque * dt_;
  }
  s.api.kinematics(s.m, s.d);  // mj_step leaves the derived quantities at the step's start
  s.api.com_positions(s.m, s.d);
  s.api.com_velocities(s.m, s.d);
  for (std::size_t b = 0; b < s.bodies.size(); ++b) {
    const mjtNum* rotation = s.d->xmat + 9 * s.bodies[b].body_id;
    angles_[b] = unwrapped(angles_[b], std::atan2(rotation[2], rotation[0]));
  }
  ++steps_;
  return divergence_count(impl_->d);
}

int PlanarRobotStepper::steps(long count) {
  for (long k = 0; k < count; ++k) step();
  return divergence_count(impl_->d);
}

}  // namespace terrasph::rft
