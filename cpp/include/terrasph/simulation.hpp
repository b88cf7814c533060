// A granular SPH simulation: the model (constants: ModelParams, kernel, constitutive model) and
// the state (everything a step reads and writes: the two particle sets' registered fields, the
// counters, the bodies, the wall-removal schedule). Per step (kick–drift–kick, docs/design.md §3.7):
//   v ← v + ½dt a,  ρ ← ρ + ½dt Dρ/Dt          (kick)
//   x ← x + dt (v + δv_XSPH)                   (drift)
//   rates at the new positions                  (wall ghosts, ∇v and σ, wall stress, forces)
//   v ← v + ½dt a,  ρ ← ρ + ½dt Dρ/Dt          (kick), then health checks
// With numerics.symplectic_density the density is not kicked: the ∇v pass sums Dρ/Dt at the new
// positions and advances ρ ← ρ + dt Dρ/Dt before σ and the forces use it (symplectic Euler in v and
// ρ, as in v and the hypoelastic stress; the kicked pair is forward Euler, held by the damping).
// A State saved with the accessors below and loaded with restore_* continues bit for bit: the
// neighbour lists are rebuilt from the positions they were built at, and no rate is recomputed.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "terrasph/bodies.hpp"
#include "terrasph/constitutive.hpp"
#include "terrasph/kernel.hpp"
#include "terrasph/neighbours.hpp"
#include "terrasph/pair_terms.hpp"
#include "terrasph/parallel.hpp"
#include "terrasph/params.hpp"
#include "terrasph/particles.hpp"

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

// The scalar part of the state.
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
  PhaseTimes phase_seconds;  // a measurement, not state: not saved

  // f(name, member) for each counter a saved state carries, each named once here (Self is
  // RunCounters or const RunCounters: the saving and the restoring code walk the same list).
  template <class Self, class F> static void for_each_saved(Self& c, F&& f) {
    f("step", c.step);
    f("time", c.time);
    f("last_dt", c.last_dt);
    f("neighbour_builds", c.neighbour_builds);
    f("max_speed", c.max_speed);
    f("max_acceleration", c.max_acceleration);
    f("penetrating_particles", c.penetrating_particles);
    f("penetrated_particles", c.penetrated_particles);
  }
};

// A wall group to remove at a given simulation time (e.g. the gate of a column collapse).
struct WallRemoval {
  double time = 0.0;
  std::int32_t group = 0;
};

// The load of the grains on one fixed wall group (a wall group that is not a body), kept when
// asked for (Simulation::track_wall_loads): Eq. 3.24–3.25 summed over the group's particles, per
// metre of depth, the clockwise torque about the tracking point.
template <int D> struct WallLoad : LoadAccumulator<D> {
  std::int32_t group = 0;
};

template <int D> class Simulation {
 public:
  using Orientation = typename BodyRotation<D>::Orientation;  // 2D: clockwise angle; 3D: unit quaternion (w, x, y, z)

  // Takes ownership of the particle sets; positions, velocities, densities and masses of the
  // granular set and positions, normals, masses, slip flags and groups of the walls must be set.
  // Ids are assigned in the given order (0, 1, …) unless the sets carry them already.
  Simulation(const ModelParams<D>& params, GranularParticles<D> granular, WallParticles<D> walls);

  const ModelParams<D>& params() const { return params_; }
  GranularParticles<D>& granular() { return granular_; }
  const GranularParticles<D>& granular() const { return granular_; }
  WallParticles<D>& walls() { return walls_; }
  const WallParticles<D>& walls() const { return walls_; }
  const RunCounters& counters() const { return counters_; }
  double smoothing_length() const { return kernel_.h; }
  const WendlandC2<D>& kernel() const { return kernel_; }

  // Advances until `t_end` (the last step is shortened to land on it) or `max_steps` steps,
  // removing scheduled wall groups when their time comes (a step is shortened to land on it too);
  // returns the number of steps taken. Throws InstabilityError on a blow-up.
  std::int64_t advance(double t_end, std::int64_t max_steps);

  // Largest stable step for the current state: C·min(h/(c + |v|max), √(h/|a|max)).
  double stable_time_step() const;

  // Re-evaluates neighbours and all rates from the current state (after the state was edited).
  void refresh();

  // Removes the wall particles of one group now / at simulation time `time`.
  void remove_wall_group(std::int32_t group);
  void schedule_wall_removal(std::int32_t group, double time);
  const std::vector<WallRemoval>& pending_wall_removals() const { return pending_removals_; }

  // Kernel sums for diagnostics and tests: Σ_j V_j W_ij (self included) and Σ_j V_j ∇W_ij
  // over granular neighbours only.
  ScalarArray kernel_sum() const;
  VecArray<D> kernel_gradient_sum() const;

  // Bytes held by the particle fields, the neighbour lists and the pair caches.
  std::size_t memory_bytes() const;

  // Applies the Shepard density filter once (Eq. 2.41).
  void apply_shepard_filter();
  // Applies the MLS regularisation (Eq. 3.26–3.30, linear basis; mls.hpp) once to the stress state
  // of the constitutive model (none for mu_i_rate).
  void apply_mls_regularisation();

  // Makes the wall particles of `wall_group` a rigid body whose reference point is at `reference`
  // and whose current particle layout is the body turned by `orientation` (2D: clockwise angle,
  // rad; 3D: unit quaternion w, x, y, z). From now on it follows `motion` (times relative to now)
  // and the granular load on it is accumulated. Returns the body's index.
  int add_body(std::int32_t wall_group, const Vec<D>& reference, const Orientation& orientation,
               std::vector<MotionSegment<D>> motion);
  // Makes the particles of `wall_group` a body driven from outside (a multibody engine, docs/design.md
  // §3.6): its kinematics are set with set_body_kinematics before each step, and they are taken
  // as the body's state at the end of that step. `reference` and `orientation` describe the layout now.
  int add_driven_body(std::int32_t wall_group, const Vec<D>& reference, const Orientation& orientation);
  void set_body_kinematics(int index, const BodyKinematics<D>& kinematics);
  const std::vector<RigidBody<D>>& bodies() const { return bodies_; }
  // Restarts the time averages of force and torque (impulse / elapsed time) of every body.
  void reset_body_impulses();

  // From now on keeps the load of the grains on every fixed wall group (one that is not a body
  // now), torques clockwise about `point`, and re-evaluates the rates so the loads at the present
  // state are known (called before the first step, the run is bitwise the one without it). Off
  // by default: a run that does not ask pays nothing. Refused with the active domain on (its
  // frozen grains keep old rates, so their wall loads would not be re-evaluated).
  void track_wall_loads(const Vec<D>& point);
  bool tracks_wall_loads() const { return tracks_wall_loads_; }
  const Vec<D>& wall_load_point() const { return wall_load_point_; }
  const std::vector<WallLoad<D>>& wall_loads() const { return wall_loads_; }  // by group, ascending
  void reset_wall_load_impulses();
  // Continues tracked wall loads from a saved state: the groups and the point must be this
  // simulation's (track_wall_loads was called with the saved point).
  void restore_wall_loads(const Vec<D>& point, const std::vector<WallLoad<D>>& loads);

  // --- state restore (the fields are written through granular()/walls() first) ---
  // Sets the scalar state, the bodies' dynamic state and the removal schedule, then rebuilds the
  // neighbour lists at the saved build positions. Nothing is recomputed.
  void restore(const RunCounters& counters, const std::vector<RigidBody<D>>& bodies,
               std::vector<WallRemoval> pending_removals);

  // Debug hook: reorders the storage of one particle set (order[k] = old storage index of the new
  // row k), as the cell-ordered storage does (numerics.cell_order); everything a user sees is
  // keyed by id and unchanged.
  void permute_granular(const std::vector<Index>& order);
  void permute_walls(const std::vector<Index>& order);

 private:
  using StressPass = void (Simulation::*)(double);
  using ForcePass = void (Simulation::*)(double);

  void compose_passes();
  void compose_stress_passes();
  void compose_force_pass();
  void step(double dt);
  void apply_due_removals();
  void update_neighbours_if_needed();
  void build_neighbours();
  void sort_into_cell_order();
  void update_frozen();
  BodyProximity<D> body_proximity(double radius);
  bool frozen(Index i) const { return frozen_ && (*frozen_)[i]; }
  // the threads' share of the loops that skip frozen grains and idle walls: balanced chunks with
  // the active domain on, one block per thread otherwise (parallel.hpp)
  Index active_chunk() const { return frozen_ ? balanced_chunk : 0; }
  void update_idle_walls();
  bool wall_idle(Index w) const { return frozen_ && wall_idle_[static_cast<std::size_t>(w)]; }
  bool penetrates_interior_wall(Index i) const;
  void build_neighbour_lists(const VecArray<D>& granular_at, const VecArray<D>& walls_at);
  void compute_rates(double dt);
  void wall_velocity_pass();
  template <class Model, int Density> void velocity_gradient_and_stress_pass(double dt);
  template <class Model, int Density> void strain_and_stress_pass(double dt);
  // ρ + Δt Dρ/Dt, held at the optional floor numerics.density_floor·ρ0: with the tension-free EOS a
  // grain that separates from the bulk carries no pressure below ρ0 either way; the floor keeps it
  // from re-entering the bed unresisted. The kicks (Δt/2) and the symplectic update (Δt) use it.
  double advanced_density(double rho, double rate, double dt) const {
    return std::max(rho + dt * rate, params_.numerics.density_floor * params_.material.reference_density);
  }
  void small_strain_pass(VecArray<D>& reference, MatArray<D>& strain, double reference_time);
  template <int Density>
  void add_granular_velocity_gradient(Index i, bool correct, const ForceConstants<D>& constants, Mat<D>& grad,
                                      Mat<D>& moment, double& drho);
  template <bool Continuity>
  void add_wall_velocity_gradient(Index i, bool correct, Mat<D>& grad, Mat<D>& moment, double& drho) const;
  template <class Model> void wall_stress_pass();
  template <int Density, bool UseXsph, bool KeepPairForces, bool UseWallFriction> void force_pass(double dt);
  template <int Density, bool UseXsph> void granular_pairs_once(const ForceConstants<D>& constants);
  template <int Density, bool UseXsph> void add_half_list_pairs(Index i, const ForceConstants<D>& constants);
  template <int Density> void granular_gradient_pairs_once(const ForceConstants<D>& constants);
  template <int Density> void add_half_list_gradient_pairs(Index i, const ForceConstants<D>& constants);
  template <class Body> void for_each_grain_by_strips(Body&& body);
  bool has_awake_half_neighbour(Index i) const;
  template <bool WithValue, class Visit> bool for_each_held_pair(Index i, Visit&& visit) const;
  void build_pair_strips(const VecArray<D>& granular_at, double radius);
  bool keeps_pair_forces() const { return !bodies_.empty() || tracks_wall_loads_; }
  int attach_body(std::int32_t wall_group, RigidBody<D> body);
  void move_bodies(double time);
  void accumulate_loads(double dt);
  void check_health() const;
  void mark_interior_walls();
  void check_ids() const;

  // model
  ModelParams<D> params_;
  WendlandC2<D> kernel_;
  ConstitutiveModelVariant<D> model_;
  double sound_speed_;
  double signal_speed_;
  double wall_volume_;  // V_w = Δx^D

  // state
  GranularParticles<D> granular_;
  WallParticles<D> walls_;
  RunCounters counters_;
  std::vector<RigidBody<D>> bodies_;
  std::vector<WallRemoval> pending_removals_;  // by time
  bool tracks_wall_loads_ = false;
  Vec<D> wall_load_point_ = Vec<D>::Zero();
  std::vector<WallLoad<D>> wall_loads_;  // by group, ascending (tracked only)
  bool neighbours_valid_ = false;

  // optional fields, registered by the modules that use them
  VecArray<D>* xsph_correction_ = nullptr;  // χ Σ ... of Eq. 2.49 (XSPH on)
  VecArray<D>* body_offset_ = nullptr;      // position in the body frame (bodies present)
  VecArray<D>* body_normal_ = nullptr;      // normal in the body frame
  Int32Array* quiet_steps_ = nullptr;       // consecutive steps below freeze_speed (active domain on)
  FlagArray* frozen_ = nullptr;             // 1: not updated this step (active domain on)

  // the passes of this run, composed once for its model and optional terms
  StressPass stress_pass_ = nullptr;
  void (Simulation::*wall_stress_pass_)() = nullptr;
  ForcePass force_pass_ = nullptr;

  // derived from the state at each neighbour build (rebuilt, not saved)
  CellGrid<D> granular_grid_;
  CellGrid<D> wall_grid_;
  NeighbourList granular_granular_;
  NeighbourList granular_wall_;
  NeighbourList wall_granular_;
  // numerics.symmetric_pairs: the granular particles by strip (strip k holds
  // strip_members_[strip_start_[k], strip_start_[k + 1]) in index order) and each granular pair
  // once, listed by the particle of the lower strip, or of the lower index within a strip
  std::vector<Index> strip_start_;
  std::vector<std::int32_t> strip_members_;
  NeighbourList granular_half_;
  // active domain: walls whose granular neighbours are all frozen (this step and the last), whose
  // passes are skipped; derived each step, reset at neighbour builds
  std::vector<std::uint8_t> wall_idle_;
  std::vector<std::uint8_t> walls_frozen_around_;
  // active domain with numerics.active_radius: each body's distance field (BodyDistanceField), built
  // when first needed and dropped whenever the bodies or the walls change (refresh, restore)
  std::vector<BodyDistanceField<D>> body_fields_;
  // force each granular–wall pair exerts on the wall, kept for walls that belong to a body and,
  // when wall loads are tracked, for all walls
  VecArray<D> pair_wall_force_;
};

}  // namespace terrasph
