// The implicit correction the native RFT robot steppers (rft_robot.cpp, rft3d_robot.cpp) share:
// backward Euler in the terrain's loads and the servos' forces, solved by Newton's method.
#pragma once

#include <Eigen/Dense>

#include "terrasph/rft_robot.hpp"

namespace terrasph::rft {

using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Vector = Eigen::VectorXd;

/// How often Newton's method from the linearly implicit step tries each step (halving it) before it
/// starts again from q̇*: 3 took the fewest load evaluations per step on the flat, L and reversed C
/// leg-wheels (1: 3.5, 6.0, 4.5; 2: 3.5, 5.9, 4.5; 3: 3.5, 5.6, 4.3; 6: 3.8, 6.0, 4.7; docs/rft.md "Cost").
constexpr int kLinearisedTries = 3;

/// The end velocities q̇ of a step that is backward Euler in the generalised loads G(q̇) (the terrain's
/// and the servos', at the step's start pose): M (q̇ − q̇*) = dt (G(q̇) − G_n), q̇* MuJoCo's explicit
/// velocities (G_n = `applied` in them), by Newton's method with the Jacobian K = ∂G/∂q̇. Each step is
/// halved while it does not lower the residual's largest component; the iterations stop when that is
/// at most `newton.tolerance` × the step's scale (the momentum M q̇* or the impulse dt G_n, whichever
/// is larger), or where no halving lowers it (a kink of the regularised load: the best iterate is
/// kept). `loads`: `evaluate(q̇, jacobian)` sets `generalised` (G), if asked for `stiffness` (K), and
/// the loads behind them; `keep()` saves those loads as the best so far, `restore()` puts the saved
/// ones back (done before returning, so they are the loads at the q̇ returned).
///
/// Where K is cheap beside G (the planar law; `Loads::kCheapJacobian`), every evaluation takes it and
/// Newton starts from the linearly implicit step, G linearised at q̇_n = `start_qvel` with K_n =
/// `*start_stiffness`: (M − dt K_n)(q̇ − q̇*) = dt K_n (q̇* − q̇_n), each step tried kLinearisedTries
/// times, and only if that does not converge (a kink between the two) from q̇* with the settings'
/// halvings; the evaluation at q̇* goes (the planar leg-wheels: 4.4–7.2 → 3.5–5.6 per step). Where K
/// costs much more (the 3D law), the trials are evaluated without it, an accepted one again with it
/// before the next step, and Newton starts from q̇* (`start_stiffness` null): the 3D rover stepped at
/// 0.85× with the linearised start (docs/rft.md "Cost").
template <class Loads>
Vector backward_euler(Loads& loads, const Matrix& mass, const Vector& explicit_qvel, const Vector& applied,
                      const Vector& start_qvel, const Matrix* start_stiffness, double dt, const NewtonSettings& newton) {
  const double scale = (mass * explicit_qvel).cwiseAbs().maxCoeff() + dt * applied.cwiseAbs().maxCoeff() + 1e-300;
  constexpr bool lazy = !Loads::kCheapJacobian;
  auto residual = [&](const Vector& qvel, bool jacobian) -> Vector {
    loads.evaluate(qvel, jacobian);
    return mass * (qvel - explicit_qvel) - dt * (loads.generalised - applied);
  };
  auto converged = [&](const Vector& r) { return r.cwiseAbs().maxCoeff() <= newton.tolerance * scale; };
  // Newton from `qvel`, each step tried at most `tries` times: true if converged; `qvel` ends at the best iterate
  auto solve = [&](Vector& qvel, int tries) -> bool {
    Vector r = residual(qvel, true);
    loads.keep();
    Matrix stiffness = loads.stiffness;  // at the best iterate
    bool stiffness_current = true;
    for (int iteration = 0; iteration < newton.iterations && !converged(r); ++iteration) {
      if (!stiffness_current) {
        loads.evaluate(qvel, true);
        stiffness = loads.stiffness;
      }
      Vector step = Matrix(mass - dt * stiffness).partialPivLu().solve(r);
      bool reduced = false;
      Vector trial, r_trial;
      for (int halving = 0; halving < tries && !reduced; ++halving) {
        trial = qvel - step;
        r_trial = residual(trial, !lazy);
        reduced = r_trial.cwiseAbs().maxCoeff() < r.cwiseAbs().maxCoeff();
        step *= 0.5;
      }
      if (!reduced) break;  // at a kink of the regularisation no step reduces it: keep the best so far
      qvel = trial;
      r = r_trial;
      loads.keep();
      stiffness_current = !lazy;
      if (stiffness_current) stiffness = loads.stiffness;
    }
    loads.restore();
    return converged(r);
  };
  if (start_stiffness != nullptr) {
    const Matrix& k_n = *start_stiffness;
    Vector qvel = explicit_qvel + Matrix(mass - dt * k_n).partialPivLu().solve(dt * k_n * (explicit_qvel - start_qvel));
    if (solve(qvel, kLinearisedTries)) return qvel;
  }
  Vector qvel = explicit_qvel;
  solve(qvel, newton.halvings);
  return qvel;
}

}  // namespace terrasph::rft
