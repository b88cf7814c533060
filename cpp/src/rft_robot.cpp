// The native step of a planar robot on the RFT terrain: see terrasph/rft_robot.hpp and the Python
// class terrasph.robots.rft_terrain.RFTCoupling, whose docstring gives the scheme.
#include "terrasph/rft_robot.hpp"

#include <mujoco/mujoco.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "mujoco_api.hpp"

namespace terrasph::rft {

namespace {

using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Vector = Eigen::VectorXd;

/// How often Newton's method from the linearly implicit step tries each step (halving it) before it
/// starts again from q̇*: 3 took the fewest load evaluations per step on the flat, L and reversed C
/// leg-wheels (1: 3.5, 6.0, 4.5; 2: 3.5, 5.9, 4.5; 3: 3.5, 5.6, 4.3; 6: 3.8, 6.0, 4.7; docs/rft.md "Cost").
constexpr int kLinearisedTries = 3;

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

  /// Backward Euler in the loads and servo forces: M (q̇ − q̇*) = dt (G(q̇) − G(q̇_n)) by Newton's
  /// method (RFTCoupling's docstring), G(q̇_n) = `applied` and K_n = ∂G/∂q̇ = `start_stiffness` at
  /// q̇_n = `start_qvel`; the positions moved by dt (q̇ − q̇*). Newton starts from the linearly
  /// implicit step, each step tried kLinearisedTries times; if that does not converge (a kink of the
  /// regularisation between the two), it starts again from q̇* with the settings' halvings.
  void implicit_step(const std::vector<double>& angles, const Vector& applied, const Vector& start_qvel,
                     const Matrix& start_stiffness, double dt) {
    Matrix mass(nv, nv);
    api.full_mass(m, d, mass.data());  // qM is still that of the step's start
    for (int j = 0; j < nv; ++j) mass(j, j) += dt * m->dof_damping[j];
    const Vector explicit_qvel = Eigen::Map<const Vector>(d->qvel, nv);
    const double scale = (mass * explicit_qvel).cwiseAbs().maxCoeff() + dt * applied.cwiseAbs().maxCoeff() + 1e-300;
    auto residual = [&](const Vector& qvel) -> Vector {
      evaluate(angles, qvel);
      return mass * (qvel - explicit_qvel) - dt * (generalised - applied);
    };
    // Newton from `qvel`, each step tried at most `tries` times (halved after each try that does not
    // lower the residual): true if converged; `qvel` and `loads` end at the best iterate
    auto solve = [&](Vector& qvel, int tries) -> bool {
      Vector r = residual(qvel);
      std::vector<BodyLoad> best = loads;
      Matrix best_stiffness = stiffness;
      bool converged = false;
      for (int iteration = 0; iteration < newton.iterations; ++iteration) {
        converged = r.cwiseAbs().maxCoeff() <= newton.tolerance * scale;
        if (converged) break;
        Vector step = Matrix(mass - dt * best_stiffness).partialPivLu().solve(r);
        bool reduced = false;
        Vector trial, r_trial;
        for (int halving = 0; halving < tries; ++halving) {
          trial = qvel - step;
          r_trial = residual(trial);
          if (r_trial.cwiseAbs().maxCoeff() < r.cwiseAbs().maxCoeff()) {
            reduced = true;
            break;
          }
          step *= 0.5;
        }
        if (!reduced) break;  // at a kink of the regularisation no step reduces it: keep the best so far
        qvel = trial;
        r = r_trial;
        best = loads;
        best_stiffness = stiffness;
      }
      loads = best;
      return converged || r.cwiseAbs().maxCoeff() <= newton.tolerance * scale;
    };
    // G linearised at q̇_n: (M − dt K_n)(q̇ − q̇*) = dt K_n (q̇* − q̇_n), the linearly implicit Euler step
    const Matrix linearised = mass - dt * start_stiffness;
    Vector qvel = explicit_qvel + linearised.partialPivLu().solve(dt * start_stiffness * (explicit_qvel - start_qvel));
    if (!solve(qvel, kLinearisedTries)) {
      qvel = explicit_qvel;
      solve(qvel, newton.halvings);
    }
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
