// A granular SPH simulation: model constants + particle state + the step.
// Per step (kick–drift–kick, DESIGN §3.7):
//   v ← v + ½dt a,  ρ ← ρ + ½dt Dρ/Dt          (kick)
//   x ← x + dt (v + δv_XSPH)                   (drift)
//   rates at the new positions                  (wall ghosts, ∇v and σ, wall stress, forces)
//   v ← v + ½dt a,  ρ ← ρ + ½dt Dρ/Dt          (kick), then health checks
#pragma once

#include <cstdint>
#include <vector>

#include "terrasph/bodies.hpp"
#include "terrasph/kernel.hpp"
#include "terrasph/neighbours.hpp"
#include "terrasph/params.hpp"
#include "terrasph/particles.hpp"
#include "terrasph/rheology.hpp"

namespace terrasph {

// Wall-clock seconds spent in each phase of the step, summed over the run.
struct PhaseTimes {
  double neighbours = 0.0;
  double wall_velocity = 0.0;
  double velocity_gradient_and_stress = 0.0;
  double wall_stress = 0.0;
  double forces = 0.0;
  double integrate_and_check = 0.0;
};

struct RunCounters {
  std::int64_t step = 0;
  double time = 0.0;
  double last_dt = 0.0;
  std::int64_t neighbour_builds = 0;
  double max_speed = 0.0;         // max |v| over granular particles after the last step
  double max_acceleration = 0.0;  // max |a| of the last rate evaluation
  // leak diagnostics: a granular particle closer than Δx/2 to an interior wall particle (one that
  // lies a layer or more inside its wall) has got past the wall's surface row
  std::int64_t penetrating_particles = 0;  // at the last rate evaluation
  std::int64_t penetrated_particles = 0;   // distinct particles that ever were, over the run
  PhaseTimes phase_seconds;
};

template <int D> class Simulation {
 public:
  // Takes ownership of the particle sets; their densities and masses must be set.
  Simulation(const ModelParams<D>& params, GranularParticles<D> granular, WallParticles<D> walls);

  const ModelParams<D>& params() const { return params_; }
  GranularParticles<D>& granular() { return granular_; }
  WallParticles<D>& walls() { return walls_; }
  const WallParticles<D>& walls_const() const { return walls_; }
  const RunCounters& counters() const { return counters_; }
  double smoothing_length() const { return kernel_.h; }
  const WendlandC2<D>& kernel() const { return kernel_; }

  // Advances until `t_end` (the last step is shortened to land on it) or `max_steps` steps;
  // returns the number of steps taken. Throws InstabilityError on a blow-up.
  std::int64_t advance(double t_end, std::int64_t max_steps);

  // Largest stable step for the current state: C·min(h/(c + |v|max), √(h/|a|max)).
  double stable_time_step() const;

  // Re-evaluates neighbours and all rates from the current state (after the state was edited).
  void refresh();

  // Removes the wall particles of one group (e.g. the gate of a column collapse).
  void remove_wall_group(std::int32_t group);

  // Kernel sums for diagnostics and tests: Σ_j V_j W_ij (self included) and Σ_j V_j ∇W_ij
  // over granular neighbours only.
  ScalarArray kernel_sum() const;
  VecArray<D> kernel_gradient_sum() const;

  // Applies the Shepard density filter once (Eq. 2.41).
  void apply_shepard_filter();

  // Makes the wall particles of `wall_group` a rigid body whose reference point is at `reference`
  // and whose current particle layout is the body rotated clockwise by `angle` (rad). From now on
  // it follows `motion` (times relative to now) and the granular load on it is accumulated.
  // Returns the body's index.
  int add_body(std::int32_t wall_group, const Vec<D>& reference, double angle,
               std::vector<MotionSegment<D>> motion);
  const std::vector<RigidBody<D>>& bodies() const { return bodies_; }
  // Restarts the time averages of force and torque (impulse / elapsed time) of every body.
  void reset_body_impulses();

 private:
  void step(double dt);
  void update_neighbours_if_needed();
  void build_neighbours();
  void compute_rates(double dt);
  void wall_velocity_pass();
  template <bool ElasticQuasiStatic> void velocity_gradient_and_stress_pass(double dt);
  void add_granular_velocity_gradient(Index i, bool correct, Mat<D>& grad, Mat<D>& moment);
  void add_wall_velocity_gradient(Index i, bool correct, Mat<D>& grad, Mat<D>& moment) const;
  void wall_stress_pass();
  template <bool UseDelta, bool UseXsph, bool WithBodies> void force_pass();
  void move_bodies(double time);
  void accumulate_body_loads(double dt);
  void check_health() const;
  void mark_interior_walls();

  ModelParams<D> params_;
  WendlandC2<D> kernel_;
  EquationOfState eos_;
  MuIRheology<D> rheology_;
  double sound_speed_;
  double signal_speed_;
  double shear_modulus_;
  double wall_volume_;  // V_w = Δx^D

  GranularParticles<D> granular_;
  WallParticles<D> walls_;
  RunCounters counters_;

  // neighbour lists with a Verlet skin, and the positions they were built at
  CellGrid<D> granular_grid_;
  CellGrid<D> wall_grid_;
  NeighbourList granular_granular_;
  NeighbourList granular_wall_;
  NeighbourList wall_granular_;
  // W and (dW/dr)/r of every listed granular pair at the current positions, written by the
  // ∇v pass and read by the force pass (0 beyond the support)
  std::vector<double> pair_kernel_value_;
  std::vector<double> pair_gradient_factor_;
  // force each granular–wall pair exerts on the wall, kept for walls that belong to a body
  VecArray<D> pair_body_force_;
  std::vector<RigidBody<D>> bodies_;
  std::vector<std::uint8_t> penetrated_;   // 1 once a granular particle has got past a wall's surface row
  VecArray<D> granular_position_at_build_;
  VecArray<D> wall_position_at_build_;
  bool neighbours_valid_ = false;
};

}  // namespace terrasph
