// Simulation<D>: time stepping: the rates of a state (the passes in order), the stable step
// bound, advance() with its scheduled wall removals, and the kick–drift–kick step.
#include "terrasph/simulation.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "terrasph/errors.hpp"
#include "terrasph/parallel.hpp"

namespace terrasph {

// `dt` advances the constitutive model's state (0: evaluate only).
template <int D> void Simulation<D>::compute_rates(double dt) {
  PhaseTimes& t = counters_.phase_seconds;
  double clock = omp_get_wtime();
  auto lap = [&clock](double& phase) {
    const double now = omp_get_wtime();
    phase += now - clock;
    clock = now;
  };
  update_neighbours_if_needed();
  lap(t.neighbours);
  for_each_particle(granular_.size(), [&](Index i) { granular_.volume[i] = granular_.mass[i] / granular_.density[i]; });
  wall_velocity_pass();
  lap(t.wall_velocity);
  (this->*stress_pass_)(dt);
  lap(t.velocity_gradient_and_stress);
  (this->*wall_stress_pass_)();
  lap(t.wall_stress);
  (this->*force_pass_)(dt);
  if (keeps_pair_forces()) accumulate_loads(dt);
  lap(t.forces);
}

template <int D> double Simulation<D>::stable_time_step() const {
  const double h = kernel_.h;
  // mass scaling f: the grains' inertia is f times their mass, so every wave √(stiffness/inertia) is √f slower
  double dt = h / (signal_speed_ / std::sqrt(params_.numerics.mass_scaling) + counters_.max_speed);
  if (counters_.max_acceleration > 0.0) dt = std::min(dt, std::sqrt(h / counters_.max_acceleration));
  return params_.numerics.cfl * dt;
}

template <int D> std::int64_t Simulation<D>::advance(double t_end, std::int64_t max_steps) {
  check_health();  // the state may have been edited since the last step; catch it before it spreads
  apply_due_removals();
  std::int64_t taken = 0;
  const double fixed = params_.numerics.fixed_dt;
  while (taken < max_steps && counters_.time < t_end * (1.0 - 1e-14)) {
    // the step lands on the next scheduled removal, as on t_end
    const double target = pending_removals_.empty() ? t_end : std::min(t_end, pending_removals_.front().time);
    const double bound = stable_time_step();
    if (fixed > 0.0 && fixed > bound)
      throw InstabilityError("fixed time step numerics.fixed_dt = " + format_number(fixed) +
                                 " s exceeds the stable bound " + format_number(bound) + " s",
                             counters_.step, counters_.time, -1);
    double dt = fixed > 0.0 ? fixed : bound;
    if (counters_.time + dt > target) dt = target - counters_.time;
    step(dt);
    ++taken;
    apply_due_removals();
  }
  return taken;
}

// Removes the wall groups whose time has come (within the landing tolerance of advance()).
template <int D> void Simulation<D>::apply_due_removals() {
  while (!pending_removals_.empty() && counters_.time >= pending_removals_.front().time * (1.0 - 1e-14)) {
    const std::int32_t group = pending_removals_.front().group;
    pending_removals_.erase(pending_removals_.begin());
    remove_wall_group(group);
  }
}

template <int D> void Simulation<D>::schedule_wall_removal(std::int32_t group, double time) {
  if (!std::isfinite(time)) throw parameter_error("wall removal time", time, "a finite time (s)");
  const WallRemoval removal{time, group};
  const auto later = std::upper_bound(pending_removals_.begin(), pending_removals_.end(), removal,
                                      [](const WallRemoval& a, const WallRemoval& b) { return a.time < b.time; });
  pending_removals_.insert(later, removal);
}

template <int D> void Simulation<D>::step(double dt) {
  const double start = omp_get_wtime();
  const Index n = granular_.size();
  const bool xsph = params_.numerics.xsph > 0.0;
  const bool kick_density = !params_.numerics.symplectic_density;  // else the ∇v pass advances it
  const double half = 0.5 * dt;
  if (frozen_) update_frozen();
  for_each_particle(n, [&](Index i) {  // kick, then drift (Eq. 2.49 for the drift velocity)
    if (frozen(i)) return;
    auto v = row_vec<D>(granular_.velocity, i);
    v += half * row_vec<D>(granular_.acceleration, i);
    if (kick_density) granular_.density[i] = advanced_density(granular_.density[i], granular_.density_rate[i], half);
    Vec<D> drift = v;
    if (xsph) drift += row_vec<D>(*xsph_correction_, i);
    row_vec<D>(granular_.position, i) += dt * drift;
  }, active_chunk());
  if (!bodies_.empty()) move_bodies(counters_.time + dt);
  const double before_rates = omp_get_wtime();
  compute_rates(dt);
  const double after_rates = omp_get_wtime();
  const double freeze_speed2 = params_.numerics.freeze_speed * params_.numerics.freeze_speed;
  const std::int32_t settle = params_.numerics.freeze_steps;
  const double active_radius = params_.numerics.active_radius;
  const std::optional<BodyProximity<D>> bodies_near =
      active_radius > 0.0 ? std::optional<BodyProximity<D>>(body_proximity(active_radius)) : std::nullopt;
  const double max_v2 = max_over_particles(n, 0.0, [&](Index i) {  // closing kick
    auto v = row_vec<D>(granular_.velocity, i);
    if (frozen(i)) return v.squaredNorm();
    v += half * row_vec<D>(granular_.acceleration, i);
    if (kick_density) granular_.density[i] = advanced_density(granular_.density[i], granular_.density_rate[i], half);
    const double v2 = v.squaredNorm();
    if (quiet_steps_) {  // quiet: slow, and then far from every body (active radius) or, without
                         // one, not gaining freeze_speed within freeze_steps steps
      bool quiet = v2 < freeze_speed2;
      if (quiet && bodies_near) {
        quiet = !bodies_near->near(row_vec<D>(granular_.position, i));
      } else if (quiet) {
        const double gain = settle * dt * row_vec<D>(granular_.acceleration, i).norm();
        quiet = gain * gain < freeze_speed2;
      }
      (*quiet_steps_)[i] = quiet ? std::min((*quiet_steps_)[i] + 1, settle) : 0;
    }
    return v2;
  }, active_chunk());
  counters_.max_speed = std::sqrt(max_v2);
  counters_.time += dt;
  counters_.last_dt = dt;
  ++counters_.step;
  const int shepard = params_.numerics.shepard_interval;
  if (shepard > 0 && counters_.step % shepard == 0) apply_shepard_filter();
  const int mls = params_.numerics.mls_interval;
  if (mls > 0 && counters_.step % mls == 0) apply_mls_regularisation();
  check_health();
  counters_.phase_seconds.integrate_and_check += (before_rates - start) + (omp_get_wtime() - after_rates);
}

#define TERRASPH_INSTANTIATE(D) \
  template void Simulation<D>::compute_rates(double); \
  template double Simulation<D>::stable_time_step() const; \
  template std::int64_t Simulation<D>::advance(double, std::int64_t); \
  template void Simulation<D>::apply_due_removals(); \
  template void Simulation<D>::schedule_wall_removal(std::int32_t, double); \
  template void Simulation<D>::step(double);
TERRASPH_INSTANTIATE(2)
TERRASPH_INSTANTIATE(3)
#undef TERRASPH_INSTANTIATE

}  // namespace terrasph
