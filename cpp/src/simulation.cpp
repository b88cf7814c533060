// Implementation of Simulation<D>; explicitly instantiated for 2D (and 3D to keep it compiling).
#include "terrasph/simulation.hpp"

#include <Eigen/LU>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>
#include <string>

#include "terrasph/errors.hpp"
#include "terrasph/mls.hpp"
#include "terrasph/pair_terms.hpp"
#include "terrasph/parallel.hpp"

namespace terrasph {

namespace {

// Calls f(std::bool_constant<b>...) with each runtime flag made a compile-time one: optional terms
// are chosen once per run (when the passes are composed), not tested per pair, and without a
// hand-written ladder of branches.
template <class F> auto dispatch_flags(F&& f) { return f(); }
template <class F, class... Rest> auto dispatch_flags(F&& f, bool first, Rest... rest) {
  if (first)
    return dispatch_flags([&](auto... tail) { return f(std::true_type{}, tail...); }, rest...);
  return dispatch_flags([&](auto... tail) { return f(std::false_type{}, tail...); }, rest...);
}

// Both granular pair passes take neighbours in batches of at most kPairBatch: x_ij and |x_ij|² are
// gathered into arrays so that the kernel is evaluated in SIMD lanes; the pair terms are then summed
// one by one in list order, so every sum is the plain loop's (thread-count independent).
constexpr int kPairBatch = 32;

// Which terms of Dρ/Dt a pair pass sums: none (the other pass does), continuity (Eq. 2.42's first
// term), or continuity with δ-SPH's density diffusion (Eq. 2.42–2.43). The density's rate is summed
// in the force pass when the density is kicked with the velocity, and in the ∇v pass, before the
// forces, with numerics.symplectic_density (Simulation::step).
enum DensityTerms : int { no_density_terms = 0, continuity_only = 1, continuity_and_diffusion = 2 };

inline constexpr int density_terms(bool in_this_pass, bool delta) {
  return in_this_pass ? (delta ? continuity_and_diffusion : continuity_only) : no_density_terms;
}

// The pair terms' constants of a run: h, α_Π and c0 (Eq. 2.46), δhc0 (Eq. 2.43), χ (Eq. 2.49) and
// δ-SPH's hydrostatic gradient ∇ρ^H = s ρ0 g / c² (Antuono et al. 2012's hydrostatic correction;
// s < 1 when the pressure carries only part of the weight, as in a geostatic bed whose
// σ_xx = K0 σ_zz), c the EOS's sound speed.
template <int D> ForceConstants<D> force_constants(const ModelParams<D>& params, double h, double c0) {
  const double eos_c = params.eos_sound_speed();
  const double share = params.numerics.density_diffusion_pressure_share > 0.0
                           ? params.numerics.density_diffusion_pressure_share : 1.0;
  const Vec<D> hydrostatic_gradient =
      share * params.material.reference_density / (eos_c * eos_c) * params.domain.gravity;
  return {h, params.numerics.artificial_viscosity, c0, params.numerics.delta_sph * h * c0, params.numerics.xsph,
          hydrostatic_gradient};
}

// One batch of a particle's neighbours j[0..count): x_ij, |x_ij|² and (dW/dr)/r, and W_ij when
// WithValue, the kernel evaluated in SIMD lanes. Both passes of a step gather on the same positions,
// so they see the same values without a per-pair cache (16 bytes a listed pair); a pair beyond the
// support gets 0 for both.
template <int D> struct PairBatch {
  std::array<Vec<D>, kPairBatch> x;
  std::array<double, kPairBatch> r2, value, gradient_factor;
};

template <int D, bool WithValue>
void gather_pairs(const WendlandC2<D>& kernel, const std::int32_t* j, int count, const Vec<D>& xi,
                  const VecArray<D>& position, PairBatch<D>& batch) {
  for (int k = 0; k < count; ++k) {
    batch.x[k] = xi - row_vec<D>(position, j[k]);
    batch.r2[k] = batch.x[k].squaredNorm();
  }
  for (int k = 0; k < count; ++k) {
    if constexpr (WithValue) kernel.pair_value_and_gradient_factor(batch.r2[k], batch.value[k], batch.gradient_factor[k]);
    else batch.gradient_factor[k] = kernel.pair_gradient_factor_without_value(batch.r2[k]);
  }
}

// The granular pairs' share of Dv_i/Dt, the XSPH sum and the Density terms of Dρ_i/Dt of particle
// i, in list order. A pair beyond the support has W = (dW/dr)/r = 0, so all its terms are exact
// zeros: adding them is cheaper than a mispredicted branch.
template <int D, int Density, bool UseXsph>
void add_granular_forces(Index i, const GranularParticles<D>& p, const NeighbourList& list,
                         const WendlandC2<D>& kernel, const ForceConstants<D>& constants, Vec<D>& acc,
                         Vec<D>& xsph, double& drho) {
  namespace term = pair_terms;
  const ForceConstants<D> c = constants;
  const Vec<D> xi = row_vec<D>(p.position, i);
  const Vec<D> vi = row_vec<D>(p.velocity, i);
  const double rho_i = p.density[i];
  const Mat<D> si = row_mat<D>(p.stress_over_rho2, i);
  Vec<D> a = acc, x = xsph;  // local accumulators
  double r = drho;
  const Index end = list.offsets[i + 1];
  for (Index first = list.offsets[i]; first < end; first += kPairBatch) {
    const int count = static_cast<int>(std::min<Index>(kPairBatch, end - first));
    const std::int32_t* js = list.indices.data() + first;
    PairBatch<D> batch;
    gather_pairs<D, UseXsph>(kernel, js, count, xi, p.position, batch);  // W only for XSPH
    for (int k = 0; k < count; ++k) {
      const double grad_factor = batch.gradient_factor[k];
      const std::int32_t j = js[k];
      const Vec<D>& xij = batch.x[k];
      const double r2 = batch.r2[k];
      const Vec<D> grad_w = grad_factor * xij;  // ∇_iW_ij (Eq. 2.39)
      const Vec<D> vij = vi - row_vec<D>(p.velocity, j);
      const double m_j = p.mass[j];
      const double rho_j = p.density[j];
      const double inv_rho_mean = 2.0 / (rho_i + rho_j);  // 1/ρ̄_ij, shared by Π_ij and XSPH
      if constexpr (Density >= continuity_only) r += term::continuity<D>(m_j, vij, grad_w);
      if constexpr (Density == continuity_and_diffusion)  // x_ji = −x_ij
        r += term::density_diffusion(c.delta_h_c0, rho_j - rho_i + c.hydrostatic_gradient.dot(xij), p.volume[j], grad_factor);
      const double pi_ij = term::artificial_viscosity(vij.dot(xij), r2, c.h, c.alpha, c.c0, inv_rho_mean);
      a.noalias() += term::momentum<D>(m_j, si, row_mat<D>(p.stress_over_rho2, j), pi_ij, grad_w);
      if constexpr (UseXsph) x += term::xsph<D>(c.chi, m_j, inv_rho_mean, batch.value[k], vij);
    }
  }
  acc = a;
  xsph = x;
  drho = r;
}

// The constitutive model a scene asks for, with its fields registered in the granular set.
template <int D>
ConstitutiveModelVariant<D> make_model(const ModelParams<D>& params, FieldRegistry& granular_fields) {
  ConstitutiveModelVariant<D> model = make_constitutive_model(params);
  std::visit([&](auto& m) { m.register_fields(granular_fields); }, model);
  return model;
}

template <int D> const ModelParams<D>& validated(const ModelParams<D>& params) {
  params.validate();
  return params;
}

// The speed c of the step bound h/(c + |v|): the fastest signal of any term, the larger of c0 (which
// the artificial viscosity Π_ij and δ-SPH carry, Eq. 2.42-2.46) and the model's fastest physical wave.
// A bound on the wave alone let c0's explicit damping outrun the step (docs/design_decisions.md).
double step_signal_speed(double c0, double wave_speed) { return std::max(c0, wave_speed); }

}  // namespace

template <int D>
Simulation<D>::Simulation(const ModelParams<D>& params, GranularParticles<D> granular, WallParticles<D> walls)
    : params_(validated(params)),
      kernel_(params.smoothing_length()),
      model_(make_model(params, granular.fields)),
      sound_speed_(params.artificial_sound_speed()),
      signal_speed_(step_signal_speed(sound_speed_, std::visit([](const auto& m) { return m.wave_speed(); }, model_))),
      wall_volume_(std::pow(params.numerics.spacing, D)),
      granular_(std::move(granular)),
      walls_(std::move(walls)) {
  const Index n = granular_.size();
  for (Index i = 0; i < n; ++i) {
    const Vec<D> x = row_vec<D>(granular_.position, i);
    for (int k = 0; k < D; ++k) {
      if (!(x[k] >= params_.domain.lower[k] && x[k] <= params_.domain.upper[k]))
        throw std::invalid_argument("granular particle " + std::to_string(granular_.id[i]) +
                                    " lies outside the domain box (parameter 'domain')");
    }
    if (!(granular_.mass[i] > 0.0) || !(granular_.density[i] > 0.0))
      throw std::invalid_argument("granular particle " + std::to_string(granular_.id[i]) +
                                  " has a non-positive mass or density");
  }
  check_ids();
  if (params_.numerics.xsph > 0.0)
    xsph_correction_ = &granular_.fields.template add<double, D>("xsph_correction", "m/s",
                                                                 "XSPH velocity correction (Eq. 2.49)");
  if (params_.numerics.freeze_speed > 0.0) {
    quiet_steps_ = &granular_.fields.template add<std::int32_t, 1>(
        "quiet_steps", "steps", "consecutive steps below numerics.freeze_speed (active domain)");
    frozen_ = &granular_.fields.template add<std::uint8_t, 1>("frozen", "", "1: not updated this step (active domain)");
  }
  mark_interior_walls();
  compose_passes();
  refresh();
}

// Ids must be unique within a set: everything a user reads is keyed by them.
template <int D> void Simulation<D>::check_ids() const {
  auto check = [](const IdArray& ids, const char* set) {
    std::vector<std::int64_t> sorted(ids.data(), ids.data() + ids.size());
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
      throw std::invalid_argument(std::string(set) + " particle ids must be unique");
  };
  check(granular_.id, "granular");
  check(walls_.id, "wall");
}

// The passes of this run, compiled for its constitutive model and its optional terms.
template <int D> void Simulation<D>::compose_passes() {
  const bool symplectic = params_.numerics.symplectic_density;
  const bool delta = params_.numerics.delta_sph > 0.0;
  std::visit([&](const auto& model) {
    using Model = std::decay_t<decltype(model)>;
    stress_pass_ = dispatch_flags([](auto density_here, auto with_delta) -> StressPass {
      constexpr int density = density_terms(decltype(density_here)::value, decltype(with_delta)::value);
      if constexpr (uses_small_strain<Model>) return &Simulation::template strain_and_stress_pass<Model, density>;
      else return &Simulation::template velocity_gradient_and_stress_pass<Model, density>;
    }, symplectic, delta);
    wall_stress_pass_ = &Simulation::template wall_stress_pass<Model>;
  }, model_);
  force_pass_ = dispatch_flags([](auto density_here, auto with_delta, auto xsph, auto keep, auto friction) -> ForcePass {
    return &Simulation::template force_pass<density_terms(decltype(density_here)::value, decltype(with_delta)::value),
                                            decltype(xsph)::value, decltype(keep)::value, decltype(friction)::value>;
  }, !symplectic, delta, params_.numerics.xsph > 0.0, keeps_pair_forces(),
     params_.numerics.wall_friction_coefficient > 0.0);
}

// A wall particle is interior when another particle of its wall group sits one spacing further
// out along its normal (within Δx/2 of x_w + Δx n_w): it is not on the surface row. Grains reach
// such particles only by getting past the surface row, which is what the leak counter counts.
template <int D> void Simulation<D>::mark_interior_walls() {
  const double dx = params_.numerics.spacing;
  const Index nw = walls_.size();
  if (nw == 0) return;
  VecArray<D> outward(nw, D);
  for (Index w = 0; w < nw; ++w)
    row_vec<D>(outward, w) = row_vec<D>(walls_.position, w) + dx * row_vec<D>(walls_.normal, w);
  Vec<D> lower, upper;
  bounding_box<D>(walls_.position, outward, dx, lower, upper);
  CellGrid<D> grid;
  grid.build(walls_.position, lower, upper, 0.5 * dx);
  NeighbourList next_layer;
  build_neighbour_list<D>(outward, walls_.position, grid, 0.5 * dx, false, next_layer);
  for (Index w = 0; w < nw; ++w) {
    walls_.interior[w] = 0;
    for (Index s = next_layer.offsets[w]; s < next_layer.offsets[w + 1]; ++s)
      if (walls_.group[next_layer.indices[s]] == walls_.group[w]) walls_.interior[w] = 1;
  }
}

template <int D> void Simulation<D>::refresh() {
  neighbours_valid_ = false;
  body_fields_.clear();  // the bodies or their particles may have changed
  if (quiet_steps_) {  // the state may have been edited: every grain must settle again before it freezes
    quiet_steps_->setZero();
    frozen_->setZero();
  }
  compute_rates(0.0);
}

// ---------------------------------------------------------------- state restore and storage order

template <int D>
void Simulation<D>::restore(const RunCounters& counters, const std::vector<RigidBody<D>>& bodies,
                            std::vector<WallRemoval> pending_removals) {
  if (bodies.size() != bodies_.size())
    throw std::invalid_argument("the saved state has " + std::to_string(bodies.size()) + " bodies, the scene " +
                                std::to_string(bodies_.size()));
  if (granular_.fields.size() != granular_.position.rows() || walls_.fields.size() != walls_.position.rows())
    throw std::invalid_argument("restored particle fields have inconsistent lengths");
  check_ids();
  counters_ = counters;
  bodies_ = bodies;
  body_fields_.clear();
  pending_removals_ = std::move(pending_removals);
  compose_passes();
  build_neighbour_lists(granular_.position_at_build, walls_.position_at_build);
  neighbours_valid_ = true;
}

template <int D> void Simulation<D>::permute_granular(const std::vector<Index>& order) {
  if (static_cast<Index>(order.size()) != granular_.size())
    throw std::invalid_argument("a storage order must list every granular particle once");
  granular_.fields.gather(order);
  build_neighbour_lists(granular_.position_at_build, walls_.position_at_build);
}

template <int D> void Simulation<D>::permute_walls(const std::vector<Index>& order) {
  if (static_cast<Index>(order.size()) != walls_.size())
    throw std::invalid_argument("a storage order must list every wall particle once");
  walls_.fields.gather(order);
  build_neighbour_lists(granular_.position_at_build, walls_.position_at_build);
}

// ---------------------------------------------------------------- neighbours

template <int D> void Simulation<D>::build_neighbours() {
  if (params_.numerics.cell_order) sort_into_cell_order();
  build_neighbour_lists(granular_.position, walls_.position);
  granular_.position_at_build = granular_.position;
  walls_.position_at_build = walls_.position;
  neighbours_valid_ = true;
  ++counters_.neighbour_builds;
}

// Cell-ordered storage: each set's rows are gathered into the order of the cells of the coming
// neighbour build (cells lexicographic, the current order inside a cell), so that the particles
// of a cell, and of neighbouring cells in a row, are contiguous in memory. Nothing a user reads
// changes (it is keyed by id); the sums follow the new list order. A set already in that order
// (fixed walls after the first sort) is left alone.
template <int D> void Simulation<D>::sort_into_cell_order() {
  const double radius = kernel_.support_radius() * (1.0 + 0.5 * params_.numerics.neighbour_skin);
  Vec<D> lower, upper;
  bounding_box<D>(granular_.position, walls_.position, radius, lower, upper);
  auto sort_set = [&](FieldRegistry& fields, const VecArray<D>& position) {
    CellGrid<D> grid;
    grid.build(position, lower, upper, radius);
    const std::vector<std::int32_t>& cells = grid.cell_order();
    bool sorted = true;
    for (std::size_t k = 0; k < cells.size() && sorted; ++k) sorted = cells[k] == static_cast<std::int32_t>(k);
    if (sorted) return;
    fields.gather(std::vector<Index>(cells.begin(), cells.end()));
  };
  sort_set(granular_.fields, granular_.position);
  sort_set(walls_.fields, walls_.position);
}

// Active domain. A grain is quiet in a step when its speed |v| and the speed its acceleration
// would add over numerics.freeze_steps steps, N·dt·|a|, are both below numerics.freeze_speed (a
// grain released from rest is not quiet); it is settled once it was quiet N steps in a row. It
// is frozen for the coming step (position, velocity, density, stress and rates kept, its
// neighbours still reading them) when it is settled and no unsettled grain and no body particle
// lies within its neighbour-list radius 2h(1 + skin/2). A grain that unsettles wakes every grain
// within that radius for the next step: the awake region grows by ≥ 2h per step, faster than any
// signal the step resolves (c·dt ≤ C·h). What stays frozen is what no grain above the thresholds
// has come near: that is the criterion's error.
// With numerics.active_radius R the test is geometric first (Chrono's active domain): a grain
// within R of any body particle is never quiet, one farther away is quiet on |v| alone.
template <int D> void Simulation<D>::update_frozen() {
  const std::int32_t settle = params_.numerics.freeze_steps;
  const Int32Array& quiet = *quiet_steps_;
  for_each_particle(granular_.size(), [&](Index i) {
    bool freeze = quiet[i] >= settle;
    for (Index s = granular_granular_.offsets[i]; freeze && s < granular_granular_.offsets[i + 1]; ++s)
      freeze = quiet[granular_granular_.indices[s]] >= settle;
    for (Index s = granular_wall_.offsets[i]; freeze && s < granular_wall_.offsets[i + 1]; ++s)
      freeze = walls_.body[granular_wall_.indices[s]] < 0;
    (*frozen_)[i] = freeze ? 1 : 0;
  });
  update_idle_walls();
}

// A fixed wall particle whose granular neighbours were all frozen in this step and the last one
// is idle: its ghost velocity and stress, extrapolated from those unchanged neighbours at its
// unchanged place, would come out bit for bit as they are, and no awake grain reads them. A
// neighbour rebuild wakes every wall (the lists, and with them the sums, may change).
template <int D> void Simulation<D>::update_idle_walls() {
  const Index n = walls_.size();  // the vectors have this size since the last neighbour build
  for_each_particle(n, [&](Index w) {
    bool all_frozen = walls_.body[w] < 0;
    for (Index s = wall_granular_.offsets[w]; all_frozen && s < wall_granular_.offsets[w + 1]; ++s)
      all_frozen = (*frozen_)[wall_granular_.indices[s]] != 0;
    const std::size_t k = static_cast<std::size_t>(w);
    wall_idle_[k] = all_frozen && walls_frozen_around_[k];
    walls_frozen_around_[k] = all_frozen;
  });
}

// The lists of all pairs within 2h(1 + skin/2) of the given positions.
template <int D>
void Simulation<D>::build_neighbour_lists(const VecArray<D>& granular_at, const VecArray<D>& walls_at) {
  const double radius = kernel_.support_radius() * (1.0 + 0.5 * params_.numerics.neighbour_skin);
  Vec<D> lower, upper;
  bounding_box<D>(granular_at, walls_at, radius, lower, upper);
  granular_grid_.build(granular_at, lower, upper, radius);
  wall_grid_.build(walls_at, lower, upper, radius);
  build_neighbour_list<D>(granular_at, granular_at, granular_grid_, radius, true, granular_granular_);
  build_neighbour_list<D>(granular_at, walls_at, wall_grid_, radius, false, granular_wall_);
  build_neighbour_list<D>(walls_at, granular_at, granular_grid_, radius, false, wall_granular_);
  if (params_.numerics.symmetric_pairs) build_pair_strips(granular_at, radius);
  if (keeps_pair_forces()) pair_wall_force_.resize(static_cast<Index>(granular_wall_.indices.size()), D);
  if (frozen_) {  // new lists: no wall is idle until its neighbours have been frozen for two steps again
    wall_idle_.assign(static_cast<std::size_t>(walls_.size()), 0);
    walls_frozen_around_.assign(static_cast<std::size_t>(walls_.size()), 0);
  }
}

// Strips for numerics.symmetric_pairs: the grains binned along one axis into strips one list radius
// wide, so that every listed pair lies in one strip or two neighbouring ones; a strip then writes
// only its own grains and the next strip's, and the even strips (then the odd ones) can run side by
// side. The strips are layers across the cell order's slowest axis (z), so a strip's grains are
// contiguous in memory (strips across x, a row's worth of scattered cells each, were 12 % slower on
// the leg-wheel when dealt to free threads, 1.4x slower when dealt in blocks, which gave one thread
// the awake half of the bed). The half list keeps, of each grain's list and in its order, the
// pairs the grain holds: with a grain of the next strip, or of its own strip and a higher index.
// Every choice depends on the positions alone, so the sums are the same for any thread count.
template <int D> void Simulation<D>::build_pair_strips(const VecArray<D>& granular_at, double radius) {
  const Index n = granular_.size();
  constexpr int axis = D - 1;
  const double lowest = n > 0 ? granular_at.col(axis).minCoeff() : 0.0;
  std::vector<std::int32_t> strip(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) strip[i] = static_cast<std::int32_t>(std::floor((granular_at(i, axis) - lowest) / radius));
  const Index strips = n > 0 ? *std::max_element(strip.begin(), strip.end()) + 1 : 0;
  strip_start_.assign(static_cast<std::size_t>(strips + 1), 0);  // counting sort, stable in the index
  for (Index i = 0; i < n; ++i) ++strip_start_[strip[i] + 1];
  for (Index k = 0; k < strips; ++k) strip_start_[k + 1] += strip_start_[k];
  strip_members_.resize(static_cast<std::size_t>(n));
  std::vector<Index> fill(strip_start_.begin(), strip_start_.end() - 1);
  for (Index i = 0; i < n; ++i) strip_members_[fill[strip[i]]++] = static_cast<std::int32_t>(i);
  const NeighbourList& full = granular_granular_;
  auto held = [&](Index i, std::int32_t j) { return strip[j] == strip[i] + 1 || (strip[j] == strip[i] && j > i); };
  granular_half_.offsets.assign(static_cast<std::size_t>(n + 1), 0);
  for_each_particle(n, [&](Index i) {
    Index count = 0;
    for (Index s = full.offsets[i]; s < full.offsets[i + 1]; ++s) count += held(i, full.indices[s]) ? 1 : 0;
    granular_half_.offsets[i + 1] = count;
  });
  for (Index i = 0; i < n; ++i) granular_half_.offsets[i + 1] += granular_half_.offsets[i];
  granular_half_.indices.resize(static_cast<std::size_t>(granular_half_.offsets[n]));
  for_each_particle(n, [&](Index i) {
    Index slot = granular_half_.offsets[i];
    for (Index s = full.offsets[i]; s < full.offsets[i + 1]; ++s)
      if (held(i, full.indices[s])) granular_half_.indices[slot++] = full.indices[s];
  });
}

// The lists hold all pairs within 2h(1 + skin/2); they stay complete while no two particles
// have closed in by more than h·skin, i.e. while the two largest displacements sum to less.
template <int D> void Simulation<D>::update_neighbours_if_needed() {
  if (!neighbours_valid_) {
    build_neighbours();
    return;
  }
  const double max_granular = max_over_particles(granular_.size(), 0.0, [&](Index i) {
    return (row_vec<D>(granular_.position, i) - row_vec<D>(granular_.position_at_build, i)).squaredNorm();
  });
  const double max_wall = max_over_particles(walls_.size(), 0.0, [&](Index w) {
    return (row_vec<D>(walls_.position, w) - row_vec<D>(walls_.position_at_build, w)).squaredNorm();
  });
  const double allowed = 0.5 * params_.numerics.neighbour_skin * kernel_.support_radius();
  if (2.0 * std::sqrt(max_granular) >= allowed ||
      std::sqrt(max_granular) + std::sqrt(max_wall) >= allowed)
    build_neighbours();
}

// ---------------------------------------------------------------- rates

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
  if (!bodies_.empty()) accumulate_body_loads(dt);
  if (tracks_wall_loads_) accumulate_wall_loads(dt);
  lap(t.forces);
}

// Ghost velocity of wall particles for ∇v (Adami, Hu & Adams 2012): ṽ_w = Σ_f v_f W_wf / Σ_f W_wf,
// then 2v_w − ṽ_w for a no-slip wall, ṽ_w (no shear from the wall) for a free-slip wall.
template <int D> void Simulation<D>::wall_velocity_pass() {
  const double h2x4 = 4.0 * kernel_.h * kernel_.h;
  for_each_particle(walls_.size(), [&](Index w) {
    if (wall_idle(w)) return;
    const Vec<D> xw = row_vec<D>(walls_.position, w);
    double sum_w = 0.0;
    Vec<D> sum_v = Vec<D>::Zero();
    for (Index s = wall_granular_.offsets[w]; s < wall_granular_.offsets[w + 1]; ++s) {
      const std::int32_t f = wall_granular_.indices[s];
      const double r2 = (xw - row_vec<D>(granular_.position, f)).squaredNorm();
      if (r2 >= h2x4) continue;
      const double weight = kernel_.value(std::sqrt(r2));
      sum_w += weight;
      sum_v += weight * row_vec<D>(granular_.velocity, f);
    }
    const Vec<D> vw = row_vec<D>(walls_.velocity, w);
    if (sum_w <= 0.0) {
      row_vec<D>(walls_.ghost_velocity, w) = vw;
      return;
    }
    const Vec<D> extrapolated = sum_v / sum_w;
    row_vec<D>(walls_.ghost_velocity, w) = walls_.no_slip[w] ? Vec<D>(2.0 * vw - extrapolated) : extrapolated;
  }, active_chunk());
}

// The granular terms of ∇v_i and M_i (Eq. 2.48), in neighbour-list order. A pair beyond the
// support adds exact zeros, which is cheaper than a branch on it. Neighbours go in batches:
// |x_ij|² gathered, the kernel evaluated in SIMD lanes, then the terms summed in list order.
// With Density, the granular pairs' terms of Dρ_i/Dt too (numerics.symplectic_density), as the
// force pass sums them otherwise.
template <int D>
template <int Density>
void Simulation<D>::add_granular_velocity_gradient(Index i, bool correct, const ForceConstants<D>& c, Mat<D>& grad,
                                                   Mat<D>& moment, double& drho) {
  namespace term = pair_terms;
  const Vec<D> xi = row_vec<D>(granular_.position, i);
  const Vec<D> vi = row_vec<D>(granular_.velocity, i);
  [[maybe_unused]] const double rho_i = granular_.density[i];
  Mat<D> g = grad, m = moment;  // local accumulators: the cache stores cannot alias them
  double r = drho;
  const Index end = granular_granular_.offsets[i + 1];
  for (Index first = granular_granular_.offsets[i]; first < end; first += kPairBatch) {
    const int count = static_cast<int>(std::min<Index>(kPairBatch, end - first));
    const std::int32_t* j = granular_granular_.indices.data() + first;
    PairBatch<D> batch;
    gather_pairs<D, false>(kernel_, j, count, xi, granular_.position, batch);
    for (int k = 0; k < count; ++k) {
      const Vec<D>& xij = batch.x[k];
      const double vf = granular_.volume[j[k]] * batch.gradient_factor[k];
      const Vec<D> vji = row_vec<D>(granular_.velocity, j[k]) - vi;
      g.noalias() += (vf * vji) * xij.transpose();
      if (correct) m.noalias() -= (vf * xij) * xij.transpose();
      if constexpr (Density >= continuity_only) {
        const Vec<D> grad_w = batch.gradient_factor[k] * xij;  // ∇_iW_ij (Eq. 2.39)
        r += term::continuity<D>(granular_.mass[j[k]], Vec<D>(-vji), grad_w);
      }
      if constexpr (Density == continuity_and_diffusion)  // x_ji = −x_ij
        r += term::density_diffusion(c.delta_h_c0, granular_.density[j[k]] - rho_i + c.hydrostatic_gradient.dot(xij),
                                     granular_.volume[j[k]], batch.gradient_factor[k]);
    }
  }
  grad = g;
  moment = m;
  drho = r;
}

// numerics.symmetric_pairs (without the kernel gradient correction): the granular terms of ∇v and
// of Dρ/Dt (with Density) of every awake grain, each pair evaluated once and added to both grains
// (its terms for j are those for i with x_ij and v_ij turned round, so each is the gather's to the
// bit), into the velocity gradient and density rate arrays, which the ∇v pass then completes.
template <int D>
template <int Density>
void Simulation<D>::granular_gradient_pairs_once(const ForceConstants<D>& constants) {
  for_each_particle(granular_.size(), [&](Index i) {
    if (frozen(i)) return;
    row_mat<D>(granular_.velocity_gradient, i).setZero();
    if constexpr (Density != no_density_terms) granular_.density_rate[i] = 0.0;
  }, active_chunk());
  for_each_grain_by_strips([&](Index i) { add_half_list_gradient_pairs<Density>(i, constants); });
}

template <int D>
template <int Density>
void Simulation<D>::add_half_list_gradient_pairs(Index i, const ForceConstants<D>& c) {
  namespace term = pair_terms;
  GranularParticles<D>& p = granular_;
  const Vec<D> vi = row_vec<D>(p.velocity, i);
  [[maybe_unused]] const double rho_i = p.density[i], m_i = p.mass[i];
  const double volume_i = p.volume[i];
  Mat<D> g = Mat<D>::Zero();  // i's sums
  double r = 0.0;
  const bool i_awake = for_each_held_pair<false>(i, [&](std::int32_t j, bool j_awake, const PairBatch<D>& batch, int k) {
    const Vec<D>& xij = batch.x[k];
    const double grad_factor = batch.gradient_factor[k];
    const Vec<D> vji = row_vec<D>(p.velocity, j) - vi;
    // V_j (v_j − v_i) ⊗ ∇_iW_ij for i; V_i (v_i − v_j) ⊗ ∇_jW_ji, the same product, for j (Eq. 2.48)
    g.noalias() += ((p.volume[j] * grad_factor) * vji) * xij.transpose();
    double drho_i = 0.0, drho_j = 0.0;
    if constexpr (Density >= continuity_only) {
      const Vec<D> grad_w = grad_factor * xij;  // ∇_iW_ij (Eq. 2.39)
      drho_i = term::continuity<D>(p.mass[j], Vec<D>(-vji), grad_w);
      drho_j = term::continuity<D>(m_i, Vec<D>(-vji), grad_w);  // v_ji·∇_jW_ji = v_ij·∇_iW_ij
    }
    if constexpr (Density == continuity_and_diffusion) {  // ρ_j − ρ_i + ∇ρ^H·x_ij, antisymmetric
      const double difference = p.density[j] - rho_i + c.hydrostatic_gradient.dot(xij);
      drho_i += term::density_diffusion(c.delta_h_c0, difference, p.volume[j], grad_factor);
      drho_j += term::density_diffusion(c.delta_h_c0, -difference, volume_i, grad_factor);
    }
    r += drho_i;
    if (j_awake) {
      row_mat<D>(p.velocity_gradient, j).noalias() += ((volume_i * grad_factor) * vji) * xij.transpose();
      if constexpr (Density != no_density_terms) p.density_rate[j] += drho_j;
    }
  });
  if (!i_awake) return;
  row_mat<D>(p.velocity_gradient, i) += g;
  if constexpr (Density != no_density_terms) p.density_rate[i] += r;
}

// The wall terms of ∇v_i and M_i (Eq. 2.48) with the ghost velocities and V_w = Δx^D.
// With Continuity, the walls' continuity terms of Dρ_i/Dt too, with the walls' own velocities.
template <int D>
template <bool Continuity>
void Simulation<D>::add_wall_velocity_gradient(Index i, bool correct, Mat<D>& grad, Mat<D>& moment,
                                               double& drho) const {
  const WendlandC2<D> kernel = kernel_;
  const double wall_volume = wall_volume_;
  const Vec<D> xi = row_vec<D>(granular_.position, i);
  const Vec<D> vi = row_vec<D>(granular_.velocity, i);
  Mat<D> g = grad, m = moment;
  double r = drho;
  for (Index s = granular_wall_.offsets[i]; s < granular_wall_.offsets[i + 1]; ++s) {
    const std::int32_t w = granular_wall_.indices[s];
    const Vec<D> xiw = xi - row_vec<D>(walls_.position, w);
    const double factor = kernel.pair_gradient_factor(xiw.squaredNorm());
    const double vf = wall_volume * factor;
    g.noalias() += (vf * (row_vec<D>(walls_.ghost_velocity, w) - vi)) * xiw.transpose();
    if (correct) m.noalias() -= (vf * xiw) * xiw.transpose();
    if constexpr (Continuity)  // Eq. 2.42 with the wall's own velocity, as in the force pass
      r += pair_terms::continuity<D>(walls_.mass[w], Vec<D>(vi - row_vec<D>(walls_.velocity, w)), Vec<D>(factor * xiw));
  }
  grad = g;
  moment = m;
  drho = r;
}

// ∇v_i = Σ_j V_j (v_j − v_i) ⊗ ∇_iW_ij (Eq. 2.48), optionally renormalised by
// M_i = Σ_j V_j (x_j − x_i) ⊗ ∇_iW_ij so that linear fields are exact; then P and σ from the
// constitutive model.
// With Density (numerics.symplectic_density) the pass also sums Dρ_i/Dt (Eq. 2.42–2.43) and
// advances the density over the whole step, ρ ← ρ + dt Dρ/Dt, before the stress and the forces use
// it: the velocity and the density then form a symplectic Euler pair (the velocity kicked with the
// pressure of the density already advanced), as the velocity and the hypoelastic stress do. The
// new densities are stored after the pass, since the neighbours' sums read the old ones.
template <int D>
template <class Model, int Density>
void Simulation<D>::velocity_gradient_and_stress_pass(double dt) {
  const Model& model = std::get<Model>(model_);
  const bool correct = params_.numerics.kernel_gradient_correction;
  const ForceConstants<D> constants = force_constants(params_, kernel_.h, sound_speed_);
  const bool advance_density = Density != no_density_terms && dt > 0.0;
  const bool pairs_once = params_.numerics.symmetric_pairs && !correct;
  if (pairs_once) granular_gradient_pairs_once<Density>(constants);
  for_each_particle(granular_.size(), [&](Index i) {
    if (frozen(i)) return;
    Mat<D> grad = Mat<D>::Zero();
    Mat<D> moment = Mat<D>::Zero();
    double drho = 0.0;
    if (pairs_once) {  // the granular pairs' sums, already in the arrays
      grad = row_mat<D>(granular_.velocity_gradient, i);
      if constexpr (Density != no_density_terms) drho = granular_.density_rate[i];
    } else {
      add_granular_velocity_gradient<Density>(i, correct, constants, grad, moment, drho);
    }
    add_wall_velocity_gradient<Density != no_density_terms>(i, correct, grad, moment, drho);
    if (correct && std::abs(moment.determinant()) > 0.1) grad = grad * moment.inverse();
    row_mat<D>(granular_.velocity_gradient, i) = grad;
    if constexpr (Density != no_density_terms) granular_.density_rate[i] = drho;
    const double rho = advance_density ? advanced_density(granular_.density[i], drho, dt) : granular_.density[i];
    double p;
    const Mat<D> sigma = model.update(i, grad, rho, dt, p);
    granular_.pressure[i] = p;
    row_mat<D>(granular_.stress, i) = sigma;
    row_mat<D>(granular_.stress_over_rho2, i) = sigma / (rho * rho);
  }, active_chunk());
  if (advance_density)
    for_each_particle(granular_.size(), [&](Index i) {
      if (!frozen(i)) granular_.density[i] = advanced_density(granular_.density[i], granular_.density_rate[i], dt);
    }, active_chunk());
}

// ρ + Δt Dρ/Dt, held at the optional floor numerics.density_floor·ρ0: with the tension-free EOS a
// grain that separates from the bulk carries no pressure below ρ0 either way; the floor keeps it
// from re-entering the bed unresisted. The kicks (Δt/2) and the symplectic update (Δt) use it.
template <int D> double Simulation<D>::advanced_density(double rho, double rate, double dt) const {
  return std::max(rho + dt * rate, params_.numerics.density_floor * params_.material.reference_density);
}

// The stress pass of a model that needs the small strain E (mu_i_strain, Eq. 3.6): E first.
template <int D>
template <class Model, int Density>
void Simulation<D>::strain_and_stress_pass(double dt) {
  Model& model = std::get<Model>(model_);
  small_strain_pass(model.reference_position(), model.small_strain(), model.reference_time());
  velocity_gradient_and_stress_pass<Model, Density>(dt);
}

// Small strain of Eq. 3.6 from the displacement u = x − X, computed as ∇v is (Eq. 2.48) with u
// for v, over granular neighbours and renormalised, so that a homogeneous (linear) displacement
// gives its exact gradient also at walls and the free surface:
//   ∇u_i = [Σ_j V_j (u_j − u_i) ⊗ ∇_iW_ij] M_i⁻¹,  M_i = Σ_j V_j (x_j − x_i) ⊗ ∇_iW_ij,
//   E_i = ½(∇u_i + ∇u_iᵀ)   (the unrenormalised sum where M_i is near-singular, as for ∇v).
// The gradient is taken in the current configuration, which for small strain is the reference one.
// Before `reference_time` the reference moves with the particles (X = x, E = 0).
template <int D>
void Simulation<D>::small_strain_pass(VecArray<D>& reference, MatArray<D>& strain, double reference_time) {
  const bool follow = counters_.time < reference_time;
  const double h2x4 = 4.0 * kernel_.h * kernel_.h;
  for_each_particle(granular_.size(), [&](Index i) {
    if (frozen(i)) return;
    const Vec<D> xi = row_vec<D>(granular_.position, i);
    if (follow) {
      row_vec<D>(reference, i) = xi;
      row_mat<D>(strain, i).setZero();
      return;
    }
    const Vec<D> ui = xi - row_vec<D>(reference, i);
    Mat<D> grad = Mat<D>::Zero();
    Mat<D> moment = Mat<D>::Zero();
    for (Index s = granular_granular_.offsets[i]; s < granular_granular_.offsets[i + 1]; ++s) {
      const std::int32_t j = granular_granular_.indices[s];
      const Vec<D> xj = row_vec<D>(granular_.position, j);
      const Vec<D> xij = xi - xj;
      const double r2 = xij.squaredNorm();
      if (r2 >= h2x4) continue;
      const double vf = granular_.volume[j] * kernel_.gradient_factor(std::sqrt(r2));
      grad.noalias() += (vf * (xj - row_vec<D>(reference, j) - ui)) * xij.transpose();
      moment.noalias() -= (vf * xij) * xij.transpose();
    }
    if (std::abs(moment.determinant()) > 0.1) grad = grad * moment.inverse();
    row_mat<D>(strain, i) = 0.5 * (grad + grad.transpose());
  }, active_chunk());
}

// Wall stress extrapolated from the granular neighbours with the hydrostatic correction
// (Adami, Hu & Adams 2012, Eq. 3.31, applied to the full stress tensor):
//   σ_w = Σ_f σ_f W_wf / Σ_f W_wf − [(g − a_w)·Σ_f ρ_f x_wf W_wf / Σ_f W_wf] I,
// all of it for a rough (no-slip) wall, less the shear traction on its surface for a smooth one;
// pressure held at the model's tension cut-off; ρ_w from the model's inverse EOS (Eq. 3.32).
template <int D>
template <class Model>
void Simulation<D>::wall_stress_pass() {
  const Model& model = std::get<Model>(model_);
  const double floor = model.wall_pressure_floor();
  const double h2x4 = 4.0 * kernel_.h * kernel_.h;
  const Vec<D> g = params_.domain.gravity;
  const double inertia = params_.numerics.mass_scaling;
  for_each_particle(walls_.size(), [&](Index w) {
    if (wall_idle(w)) return;
    const Vec<D> xw = row_vec<D>(walls_.position, w);
    double sum_w = 0.0;
    Mat<D> sum_sigma = Mat<D>::Zero();
    Vec<D> sum_rho_x = Vec<D>::Zero();
    for (Index s = wall_granular_.offsets[w]; s < wall_granular_.offsets[w + 1]; ++s) {
      const std::int32_t f = wall_granular_.indices[s];
      const Vec<D> xwf = xw - row_vec<D>(granular_.position, f);
      const double r2 = xwf.squaredNorm();
      if (r2 >= h2x4) continue;
      const double weight = kernel_.value(std::sqrt(r2));
      sum_w += weight;
      sum_sigma += weight * row_mat<D>(granular_.stress, f);
      sum_rho_x += (weight * granular_.density[f]) * xwf;
    }
    Mat<D> sigma = Mat<D>::Zero();
    if (sum_w > 0.0) {
      // f ρ a = ∇·σ + ρ g with mass scaling f: grains carried along at a_w feel g − f a_w
      const double hydrostatic = (g - inertia * row_vec<D>(walls_.acceleration, w)).dot(sum_rho_x) / sum_w;
      sigma = sum_sigma / sum_w - hydrostatic * Mat<D>::Identity();
      const double p = -sigma.trace() / D;
      if (p < floor) sigma += (p - floor) * Mat<D>::Identity();  // tension cut-off
      if (!walls_.no_slip[w]) {  // smooth wall: remove the shear traction τ = σn − (n·σn)n
        const Vec<D> n = row_vec<D>(walls_.normal, w);
        const Vec<D> traction = sigma * n;
        const Vec<D> shear = traction - n.dot(traction) * n;
        sigma -= n * shear.transpose() + shear * n.transpose();
      }
      walls_.density[w] = model.density_for_pressure(std::max(p, floor));
    } else {
      walls_.density[w] = model.reference_density();
    }
    const double rho = walls_.density[w];
    row_mat<D>(walls_.stress, w) = sigma;
    row_mat<D>(walls_.stress_over_rho2, w) = sigma / (rho * rho);
  }, active_chunk());
}

// Continuity with δ-SPH (Eq. 2.42–2.43), momentum with artificial viscosity (Eq. 2.45–2.47) and
// the XSPH velocity correction (Eq. 2.49), fused into one gather over each particle's pairs.
// KeepPairForces: the force of each granular–wall pair on the wall is kept for Eq. 3.24–3.25, for
// the walls of bodies and, when wall loads are tracked, for all walls.
// UseWallFriction: Coulomb friction on every wall (pair_terms::coulomb_wall_friction) replaces the
// tangential part of each granular–wall pair force; dt is the step the rates are for (0 on an
// evaluation only: the last step's).
// Leak diagnostic: a granular particle closer than Δx/2 to an interior wall particle has got past
// the wall's surface row.
template <int D>
template <int Density, bool UseXsph, bool KeepPairForces, bool UseWallFriction>
void Simulation<D>::force_pass(double dt) {
  const double h = kernel_.h;
  const double h2x4 = 4.0 * h * h;
  const double alpha_wall = params_.numerics.wall_artificial_viscosity;
  const double c0 = sound_speed_;
  const Vec<D> g = params_.domain.gravity;
  const double inside_wall2 = 0.25 * params_.numerics.spacing * params_.numerics.spacing;
  const double barrier_radius = 0.75 * params_.numerics.spacing;
  const double barrier_strength = params_.numerics.wall_barrier * signal_speed_ * signal_speed_ / h;
  const double barrier_reach2 = barrier_strength > 0.0 ? barrier_radius * barrier_radius : 0.0;  // 0: off
  const ForceConstants<D> constants = force_constants(params_, h, c0);
  const bool pairs_once = params_.numerics.symmetric_pairs;
  if (pairs_once) granular_pairs_once<Density, UseXsph>(constants);
  const bool keep_every_wall = tracks_wall_loads_;
  [[maybe_unused]] const double wall_friction = params_.numerics.wall_friction_coefficient;
  // mass scaling f: Dv_i/Dt = (Σ pair forces/m_i + g)/f, every force unchanged
  const double inverse_inertia = 1.0 / params_.numerics.mass_scaling;
  // the slip a step of friction can take away is f times smaller
  [[maybe_unused]] const double friction_dt = (dt > 0.0 ? dt : counters_.last_dt) * inverse_inertia;
  struct FrictionPair {  // a granular–wall pair of grain i: list slot, N_iw, slip v_t, reaction kept
    Index slot;
    double normal;
    Vec<D> slip;
    bool kept;
  };
  struct Partial {
    double max_acc2 = 0.0;
    std::int64_t penetrating = 0, newly_penetrated = 0;
  };
  const Partial total = reduce_over_particles(granular_.size(), Partial{}, [&](Index i, Partial& partial) {
    namespace term = pair_terms;
    if (frozen(i)) {  // rates kept; still counted by the leak diagnostic (it does not move)
      if (penetrates_interior_wall(i)) ++partial.penetrating;
      return;
    }
    const Vec<D> xi = row_vec<D>(granular_.position, i);
    const Vec<D> vi = row_vec<D>(granular_.velocity, i);
    const double rho_i = granular_.density[i];
    const Mat<D> si = row_mat<D>(granular_.stress_over_rho2, i);
    Vec<D> acc = Vec<D>::Zero();
    Vec<D> xsph = Vec<D>::Zero();
    double drho = 0.0;
    if (pairs_once) {  // the granular pairs' sums, already in the arrays
      acc = row_vec<D>(granular_.acceleration, i);
      if constexpr (UseXsph) xsph = row_vec<D>(*xsph_correction_, i);
      if constexpr (Density != no_density_terms) drho = granular_.density_rate[i];
    } else {
      add_granular_forces<D, Density, UseXsph>(i, granular_, granular_granular_, kernel_, constants, acc, xsph, drho);
    }
    double nearest_wall2 = std::numeric_limits<double>::infinity();
    // wall friction: the pairs' normal parts and slips, gathered in list order (per thread, reused)
    static thread_local std::vector<FrictionPair> friction_pairs;
    [[maybe_unused]] double normal_sum = 0.0;  // N_i
    if constexpr (UseWallFriction) friction_pairs.clear();
    for (Index s = granular_wall_.offsets[i]; s < granular_wall_.offsets[i + 1]; ++s) {
      const std::int32_t w = granular_wall_.indices[s];
      const bool kept = KeepPairForces && (keep_every_wall || walls_.body[w] >= 0);
      if (kept) row_vec<D>(pair_wall_force_, s).setZero();
      const Vec<D> xiw = xi - row_vec<D>(walls_.position, w);
      const double r2 = xiw.squaredNorm();
      if (walls_.interior[w]) nearest_wall2 = std::min(nearest_wall2, r2);
      if (r2 >= h2x4) continue;
      const Vec<D> grad_w = kernel_.gradient_factor(std::sqrt(r2)) * xiw;
      const Vec<D> viw = vi - row_vec<D>(walls_.velocity, w);
      const double m_w = walls_.mass[w];
      if constexpr (Density >= continuity_only) drho += term::continuity<D>(m_w, viw, grad_w);
      // a smooth wall resists only the approach along its normal: the tangential part of v_iw would
      // make the viscosity a wall friction (a sliding block stopped as on a rough wall)
      const double approach = walls_.no_slip[w] ? viw.dot(xiw) : viw.dot(row_vec<D>(walls_.normal, w)) *
                                                                     row_vec<D>(walls_.normal, w).dot(xiw);
      const double pi_iw = term::artificial_viscosity(approach, r2, h, alpha_wall, c0, 2.0 / (rho_i + walls_.density[w]));
      Vec<D> pair_acc = term::momentum<D>(m_w, si, row_mat<D>(walls_.stress_over_rho2, w), pi_iw, grad_w);
      if (r2 < barrier_reach2) pair_acc += term::wall_barrier(std::sqrt(r2), barrier_radius, barrier_strength) * xiw;
      if constexpr (UseWallFriction) {  // keep the normal part; the friction below is the tangential one
        const Vec<D> n = row_vec<D>(walls_.normal, w);
        const double along = pair_acc.dot(n);
        pair_acc = along * n;
        const double normal = std::max(along, 0.0);
        normal_sum += normal;
        friction_pairs.push_back({s, normal, viw - viw.dot(n) * n, kept});
      }
      acc.noalias() += pair_acc;
      if (kept) row_vec<D>(pair_wall_force_, s) = -granular_.mass[i] * pair_acc;  // Eq. 3.24, reaction
    }
    if constexpr (UseWallFriction) {
      const double regularisation_speed = wall_friction * normal_sum * friction_dt;
      for (const FrictionPair& pair : friction_pairs) {
        const Vec<D> friction = term::coulomb_wall_friction<D>(wall_friction, pair.normal, pair.slip, regularisation_speed);
        acc.noalias() += friction;
        if (pair.kept) row_vec<D>(pair_wall_force_, pair.slot) -= granular_.mass[i] * friction;  // Eq. 3.24
      }
    }
    if (nearest_wall2 < inside_wall2) {
      ++partial.penetrating;
      if (!granular_.penetrated[i]) {
        granular_.penetrated[i] = 1;
        ++partial.newly_penetrated;
      }
    }
    acc += g;
    acc *= inverse_inertia;
    row_vec<D>(granular_.acceleration, i) = acc;
    if constexpr (Density != no_density_terms) granular_.density_rate[i] = drho;
    if constexpr (UseXsph) row_vec<D>(*xsph_correction_, i) = xsph;
    partial.max_acc2 = std::max(partial.max_acc2, acc.squaredNorm());
  }, [](Partial& sum, const Partial& p) {
    sum.max_acc2 = std::max(sum.max_acc2, p.max_acc2);
    sum.penetrating += p.penetrating;
    sum.newly_penetrated += p.newly_penetrated;
  }, active_chunk());
  counters_.max_acceleration = std::sqrt(total.max_acc2);
  counters_.penetrating_particles = total.penetrating;
  counters_.penetrated_particles += total.newly_penetrated;
}

// numerics.symmetric_pairs: the granular pairs' share of Dv/Dt, the XSPH sum and the Density
// terms of Dρ/Dt of every awake grain, each pair evaluated once and added to both grains (its terms
// for j are those for i with x_ij, v_ij and ∇W turned round, so each is the gather's to the bit),
// into the acceleration, density rate and XSPH arrays, which the force pass then completes. The
// even strips run side by side, then the odd ones; within a strip the grains go in index order.
// A frozen grain's sums are left as they are; its pairs with awake grains still count for those.
template <int D>
template <int Density, bool UseXsph>
void Simulation<D>::granular_pairs_once(const ForceConstants<D>& constants) {
  const Index n = granular_.size();
  for_each_particle(n, [&](Index i) {
    if (frozen(i)) return;
    row_vec<D>(granular_.acceleration, i).setZero();
    if constexpr (Density != no_density_terms) granular_.density_rate[i] = 0.0;
    if constexpr (UseXsph) row_vec<D>(*xsph_correction_, i).setZero();
  }, active_chunk());
  for_each_grain_by_strips([&](Index i) { add_half_list_pairs<Density, UseXsph>(i, constants); });
}

// Whether a grain the half list gives grain i is awake: a frozen grain's pairs count only for those.
template <int D> bool Simulation<D>::has_awake_half_neighbour(Index i) const {
  for (Index s = granular_half_.offsets[i]; s < granular_half_.offsets[i + 1]; ++s)
    if (!frozen(granular_half_.indices[static_cast<std::size_t>(s)])) return true;
  return false;
}

// body(i) for every grain, strip by strip (numerics.symmetric_pairs): the even strips side by side,
// then the odd ones, the grains of a strip in index order. A body that writes only to the grains of
// its strip and of the next is free of races, and the order of every grain's sums is fixed by the
// strips alone, whichever thread takes a strip: so the strips of a parity go to whichever thread is
// free next (a bed of 11 strips a parity left one of two threads idle for about a strip's time when
// dealt in fixed blocks).
template <int D> template <class Body> void Simulation<D>::for_each_grain_by_strips(Body&& body) {
  const Index strips = static_cast<Index>(strip_start_.size()) - 1;
  for (Index parity = 0; parity < 2; ++parity) {
#pragma omp parallel for schedule(dynamic, 1) num_threads(team_size(granular_.size()))
    for (Index k = parity; k < strips; k += 2)
      for (Index m = strip_start_[k]; m < strip_start_[k + 1]; ++m) body(strip_members_[static_cast<std::size_t>(m)]);
  }
}

template <int D>
template <int Density, bool UseXsph>
void Simulation<D>::add_half_list_pairs(Index i, const ForceConstants<D>& c) {
  namespace term = pair_terms;
  GranularParticles<D>& p = granular_;
  const Vec<D> vi = row_vec<D>(p.velocity, i);
  const double rho_i = p.density[i], m_i = p.mass[i], volume_i = p.volume[i];
  const Mat<D> si = row_mat<D>(p.stress_over_rho2, i);
  Vec<D> a = Vec<D>::Zero(), x = Vec<D>::Zero();  // i's sums
  double r = 0.0;
  const bool i_awake = for_each_held_pair<UseXsph>(i, [&](std::int32_t j, bool j_awake, const PairBatch<D>& batch, int k) {
    const double grad_factor = batch.gradient_factor[k];
    const Vec<D>& xij = batch.x[k];
    const Vec<D> grad_w = grad_factor * xij;  // ∇_iW_ij (Eq. 2.39); ∇_jW_ji = −∇_iW_ij
    const Vec<D> vij = vi - row_vec<D>(p.velocity, j);
    const double m_j = p.mass[j];
    const double rho_j = p.density[j];
    const double inv_rho_mean = 2.0 / (rho_i + rho_j);
    const double pi_ij = term::artificial_viscosity(vij.dot(xij), batch.r2[k], c.h, c.alpha, c.c0, inv_rho_mean);
    // (σ_i/ρ_i² + σ_j/ρ_j² − Π_ij I)·∇_iW_ij, the momentum term per unit neighbour mass (Eq. 2.45)
    const Vec<D> t = term::momentum<D>(1.0, si, row_mat<D>(p.stress_over_rho2, j), pi_ij, grad_w);
    a.noalias() += m_j * t;
    double drho_i = 0.0, drho_j = 0.0;
    if constexpr (Density >= continuity_only) {
      drho_i = term::continuity<D>(m_j, vij, grad_w);
      drho_j = term::continuity<D>(m_i, vij, grad_w);  // v_ji·∇_jW_ji = v_ij·∇_iW_ij
    }
    if constexpr (Density == continuity_and_diffusion) {  // ρ_j − ρ_i + ∇ρ^H·x_ij, antisymmetric
      const double difference = rho_j - rho_i + c.hydrostatic_gradient.dot(xij);
      drho_i += term::density_diffusion(c.delta_h_c0, difference, p.volume[j], grad_factor);
      drho_j += term::density_diffusion(c.delta_h_c0, -difference, volume_i, grad_factor);
    }
    r += drho_i;
    if constexpr (UseXsph) x += term::xsph<D>(c.chi, m_j, inv_rho_mean, batch.value[k], vij);
    if (j_awake) {
      row_vec<D>(p.acceleration, j) -= m_i * t;
      if constexpr (Density != no_density_terms) p.density_rate[j] += drho_j;
      if constexpr (UseXsph)
        row_vec<D>(*xsph_correction_, j) += term::xsph<D>(c.chi, m_i, inv_rho_mean, batch.value[k], Vec<D>(-vij));
    }
  });
  if (!i_awake) return;
  row_vec<D>(p.acceleration, i) += a;
  if constexpr (Density != no_density_terms) p.density_rate[i] += r;
  if constexpr (UseXsph) row_vec<D>(*xsph_correction_, i) += x;
}

// visit(j, j_awake, batch, k) for each pair grain i holds (its half list, in order) with an awake
// grain in it, the kernel of a batch of them evaluated at once (W too when WithValue); returns
// whether i is awake. A frozen grain whose held pairs are all with frozen grains is skipped whole.
template <int D>
template <bool WithValue, class Visit>
bool Simulation<D>::for_each_held_pair(Index i, Visit&& visit) const {
  const bool i_awake = !frozen(i);
  if (!i_awake && !has_awake_half_neighbour(i)) return false;
  const Vec<D> xi = row_vec<D>(granular_.position, i);
  const Index end = granular_half_.offsets[i + 1];
  for (Index first = granular_half_.offsets[i]; first < end; first += kPairBatch) {
    const int count = static_cast<int>(std::min<Index>(kPairBatch, end - first));
    const std::int32_t* js = granular_half_.indices.data() + first;
    PairBatch<D> batch;
    gather_pairs<D, WithValue>(kernel_, js, count, xi, granular_.position, batch);
    for (int k = 0; k < count; ++k) {
      const bool j_awake = !frozen(js[k]);
      if (i_awake || j_awake) visit(js[k], j_awake, batch, k);
    }
  }
  return i_awake;
}

// Whether grain i lies closer than Δx/2 to an interior wall particle (the leak diagnostic).
template <int D> bool Simulation<D>::penetrates_interior_wall(Index i) const {
  const double inside_wall2 = 0.25 * params_.numerics.spacing * params_.numerics.spacing;
  const Vec<D> xi = row_vec<D>(granular_.position, i);
  for (Index s = granular_wall_.offsets[i]; s < granular_wall_.offsets[i + 1]; ++s) {
    const std::int32_t w = granular_wall_.indices[s];
    if (walls_.interior[w] && (xi - row_vec<D>(walls_.position, w)).squaredNorm() < inside_wall2) return true;
  }
  return false;
}

// ---------------------------------------------------------------- rigid bodies

template <int D>
int Simulation<D>::add_body(std::int32_t wall_group, const Vec<D>& reference, double angle,
                            std::vector<MotionSegment<D>> motion) {
  BodyKinematics<D> start;
  start.reference = reference;
  start.angle = angle;
  RigidBody<D> body;
  body.motion = PrescribedMotion<D>(start, std::move(motion));
  body.motion_start = counters_.time;
  return attach_body(wall_group, std::move(body));
}

template <int D> int Simulation<D>::add_driven_body(std::int32_t wall_group, const Vec<D>& reference, double angle) {
  RigidBody<D> body;
  body.driven = true;
  body.kinematics.reference = reference;
  body.kinematics.angle = angle;
  return attach_body(wall_group, std::move(body));
}

template <int D> void Simulation<D>::set_body_kinematics(int index, const BodyKinematics<D>& kinematics) {
  if (index < 0 || index >= static_cast<int>(bodies_.size()))
    throw std::out_of_range("no body " + std::to_string(index));
  if (!bodies_[static_cast<size_t>(index)].driven)
    throw std::invalid_argument("body " + std::to_string(index) + " follows a prescribed motion; only a driven "
                                "body takes its kinematics from outside");
  if (!kinematics.reference.allFinite() || !std::isfinite(kinematics.angle) || !kinematics.velocity.allFinite() ||
      !std::isfinite(kinematics.spin) || !kinematics.acceleration.allFinite() ||
      !std::isfinite(kinematics.angular_acceleration))
    throw std::invalid_argument("body " + std::to_string(index) + " kinematics must be finite numbers");
  bodies_[static_cast<size_t>(index)].kinematics = kinematics;
}

// Makes the particles of `wall_group` the rigid body `body`, its frame given by the body's
// kinematics at the current time (reference point and clockwise angle of the present layout).
template <int D> int Simulation<D>::attach_body(std::int32_t wall_group, RigidBody<D> body) {
  const BodyKinematics<D> now = body.driven ? body.kinematics : body.motion.at(0.0);
  if (!now.reference.allFinite() || !std::isfinite(now.angle))
    throw std::invalid_argument("body reference point and angle must be finite");
  const int index = static_cast<int>(bodies_.size());
  body_offset_ = &walls_.fields.template add<double, D>("body_offset", "m", "position in the body frame");
  body_normal_ = &walls_.fields.template add<double, D>("body_normal", "", "normal in the body frame");
  Index members = 0;
  for (Index w = 0; w < walls_.size(); ++w) {
    if (walls_.group[w] != wall_group) continue;
    if (walls_.body[w] >= 0)
      throw std::invalid_argument("wall group " + std::to_string(wall_group) + " is already a body");
    walls_.body[w] = index;
    row_vec<D>(*body_offset_, w) = rotate_clockwise<D>(row_vec<D>(walls_.position, w) - now.reference, -now.angle);
    row_vec<D>(*body_normal_, w) = rotate_clockwise<D>(row_vec<D>(walls_.normal, w), -now.angle);
    ++members;
  }
  if (members == 0)
    throw std::invalid_argument("wall group " + std::to_string(wall_group) + " has no particles to make a body of");
  bodies_.push_back(std::move(body));
  compose_passes();
  move_bodies(counters_.time);
  refresh();
  reset_body_impulses();
  return index;
}

template <int D> void Simulation<D>::reset_body_impulses() {
  for (RigidBody<D>& body : bodies_) {
    body.impulse.setZero();
    body.angular_impulse = 0.0;
    body.impulse_time = 0.0;
  }
}

// Places every body particle at its body's pose at `time` (the schedule's for a prescribed body,
// the last one set for a driven body), with the rigid-body velocity and acceleration
//   x = c + R(θ) r,  v = v_c + ω J R r,  a = a_c + α J R r − ω² R r  (J: quarter turn clockwise),
// the acceleration entering the wall pressure as (g − a_w) (Eq. 3.31). A prescribed schedule has
// piecewise-constant velocities, so a_c = α = 0 there and a = −ω² R r, the steady-spin term.
template <int D> void Simulation<D>::move_bodies(double time) {
  for (RigidBody<D>& body : bodies_)
    if (!body.driven) body.kinematics = body.motion.at(time - body.motion_start);
  for_each_particle(walls_.size(), [&](Index w) {
    const std::int32_t b = walls_.body[w];
    if (b < 0) return;
    const BodyKinematics<D>& k = bodies_[static_cast<size_t>(b)].kinematics;
    const Vec<D> arm = rotate_clockwise<D>(row_vec<D>(*body_offset_, w), k.angle);
    const Vec<D> turned = quarter_turn_clockwise<D>(arm);
    row_vec<D>(walls_.position, w) = k.reference + arm;
    row_vec<D>(walls_.velocity, w) = k.velocity + k.spin * turned;
    row_vec<D>(walls_.acceleration, w) = k.acceleration + k.angular_acceleration * turned - (k.spin * k.spin) * arm;
    row_vec<D>(walls_.normal, w) = rotate_clockwise<D>(row_vec<D>(*body_normal_, w), k.angle);
  });
}

// Force and clockwise torque of the terrain on each body (Eq. 3.24–3.25), summed from the stored
// pair forces in a fixed order (granular particle, then its neighbour list), so the totals do not
// depend on the thread count and are the exact opposite of the pair forces on the grains.
template <int D> void Simulation<D>::accumulate_body_loads(double dt) {
  for (RigidBody<D>& body : bodies_) {
    body.force.setZero();
    body.torque = 0.0;
  }
  const Index n = granular_.size();
  for (Index i = 0; i < n; ++i) {
    for (Index s = granular_wall_.offsets[i]; s < granular_wall_.offsets[i + 1]; ++s) {
      const std::int32_t w = granular_wall_.indices[s];
      const std::int32_t b = walls_.body[w];
      if (b < 0) continue;
      RigidBody<D>& body = bodies_[static_cast<size_t>(b)];
      const Vec<D> f = row_vec<D>(pair_wall_force_, s);
      body.force += f;
      body.torque += quarter_turn_clockwise<D>(row_vec<D>(walls_.position, w) - body.kinematics.reference).dot(f);
    }
  }
  for (RigidBody<D>& body : bodies_) {
    body.impulse += dt * body.force;
    body.angular_impulse += dt * body.torque;
    body.impulse_time += dt;
  }
}

// Each body's pose after this step's move with its distance field, for the active domain's "far
// from every body" test. The fields are built from the particles' body-frame offsets (in storage
// order, serially) at the first call after the bodies or the walls last changed.
template <int D> BodyProximity<D> Simulation<D>::body_proximity(double radius) {
  if (body_fields_.empty()) {
    std::vector<std::vector<Vec<D>>> offsets(bodies_.size());
    for (Index w = 0; w < walls_.size(); ++w)
      if (walls_.body[w] >= 0) offsets[static_cast<std::size_t>(walls_.body[w])].emplace_back(row_vec<D>(*body_offset_, w));
    for (const std::vector<Vec<D>>& body : offsets) body_fields_.emplace_back(body, radius);
  }
  std::vector<typename BodyProximity<D>::Frame> frames;
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const BodyKinematics<D>& k = bodies_[b].kinematics;
    frames.push_back({&body_fields_[b], k.reference, std::cos(k.angle), std::sin(k.angle)});
  }
  return BodyProximity<D>(std::move(frames));
}

template <int D> void Simulation<D>::track_wall_loads(const Vec<D>& point) {
  if (!point.allFinite()) throw std::invalid_argument("the wall loads' torque point must be finite");
  if (params_.numerics.freeze_speed > 0.0)
    throw std::invalid_argument("wall loads cannot be tracked with the active domain on (numerics.freeze_speed > 0): "
                                "its frozen grains keep old rates");
  std::vector<std::int32_t> groups;
  for (Index w = 0; w < walls_.size(); ++w)
    if (walls_.body[w] < 0) groups.push_back(walls_.group[w]);
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  wall_loads_.assign(groups.size(), WallLoad<D>{});
  for (size_t k = 0; k < groups.size(); ++k) wall_loads_[k].group = groups[k];
  wall_load_point_ = point;
  tracks_wall_loads_ = true;
  compose_passes();
  refresh();
  reset_wall_load_impulses();
}

template <int D> void Simulation<D>::reset_wall_load_impulses() {
  for (WallLoad<D>& load : wall_loads_) {
    load.impulse.setZero();
    load.angular_impulse = 0.0;
    load.impulse_time = 0.0;
  }
}

template <int D> void Simulation<D>::restore_wall_loads(const Vec<D>& point, const std::vector<WallLoad<D>>& loads) {
  if (!tracks_wall_loads_)
    throw std::invalid_argument("the saved state tracks wall loads: call track_wall_loads before restoring it");
  if (point != wall_load_point_)
    throw std::invalid_argument("the saved wall loads are about another point than this simulation's track_wall_loads");
  bool same_groups = loads.size() == wall_loads_.size();
  for (size_t k = 0; same_groups && k < loads.size(); ++k) same_groups = loads[k].group == wall_loads_[k].group;
  if (!same_groups) throw std::invalid_argument("the saved wall loads belong to other wall groups");
  wall_loads_ = loads;
}

// Force and clockwise torque about the tracking point of the grains on each fixed wall group
// (Eq. 3.24–3.25), summed in the fixed order of accumulate_body_loads: with the body loads and
// the weight they balance the grains' momentum, Σ m_i a_i = M g − Σ F_bodies − Σ F_walls.
template <int D> void Simulation<D>::accumulate_wall_loads(double dt) {
  for (WallLoad<D>& load : wall_loads_) {
    load.force.setZero();
    load.torque = 0.0;
  }
  auto by_group = [](const WallLoad<D>& load, std::int32_t group) { return load.group < group; };
  const Index n = granular_.size();
  for (Index i = 0; i < n; ++i) {
    for (Index s = granular_wall_.offsets[i]; s < granular_wall_.offsets[i + 1]; ++s) {
      const std::int32_t w = granular_wall_.indices[s];
      if (walls_.body[w] >= 0) continue;
      // every fixed wall's group is listed (track_wall_loads), so the search finds it
      const auto load = std::lower_bound(wall_loads_.begin(), wall_loads_.end(), walls_.group[w], by_group);
      const Vec<D> f = row_vec<D>(pair_wall_force_, s);
      load->force += f;
      load->torque += quarter_turn_clockwise<D>(row_vec<D>(walls_.position, w) - wall_load_point_).dot(f);
    }
  }
  for (WallLoad<D>& load : wall_loads_) {
    load.impulse += dt * load.force;
    load.angular_impulse += dt * load.torque;
    load.impulse_time += dt;
  }
}

// ---------------------------------------------------------------- time stepping

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

// Stops the run on non-finite state, an escaped particle or a density out of the sane band;
// reports the offending particle with the lowest id, so the message is the same for any thread
// count and any storage order.
template <int D> void Simulation<D>::check_health() const {
  const Index n = granular_.size();
  const double rho0 = params_.material.reference_density;
  const double lo = params_.numerics.density_ratio_min * rho0;
  const double hi = params_.numerics.density_ratio_max * rho0;
  const Vec<D> lower = params_.domain.lower, upper = params_.domain.upper;
  constexpr Index none = std::numeric_limits<Index>::max();
  const Index first_bad_id = reduce_over_particles(n, none, [&](Index i, Index& lowest) {
    const Vec<D> x = row_vec<D>(granular_.position, i);
    const Vec<D> v = row_vec<D>(granular_.velocity, i);
    const double rho = granular_.density[i];
    const bool finite = x.allFinite() && v.allFinite() && std::isfinite(rho);
    const bool inside = (x.array() >= lower.array()).all() && (x.array() <= upper.array()).all();
    if (!finite || !inside || rho < lo || rho > hi) lowest = std::min(lowest, granular_.id[i]);
  }, [](Index& total, Index p) { total = std::min(total, p); });
  if (first_bad_id == none) return;
  Index bad = 0;
  while (granular_.id[bad] != first_bad_id) ++bad;
  const Vec<D> x = row_vec<D>(granular_.position, bad);
  const double rho = granular_.density[bad];
  std::string reason;
  if (!(x.allFinite() && row_vec<D>(granular_.velocity, bad).allFinite() && std::isfinite(rho)))
    reason = "non-finite position, velocity or density";
  else if (rho < lo || rho > hi)
    reason = "density " + format_number(rho) + " kg/m3 outside the band [" + format_number(lo) + ", " +
             format_number(hi) + "] (numerics.density_ratio_min/max)";
  else
    reason = "particle left the domain box (a leak through a wall or an escape)";
  throw InstabilityError(reason, counters_.step, counters_.time, first_bad_id);
}

// ---------------------------------------------------------------- filters and diagnostics

// ρ_i = Σ_j m_j W_ij / Σ_j V_j W_ij over granular neighbours, self included (Eq. 2.41).
template <int D> void Simulation<D>::apply_mls_regularisation() {
  update_neighbours_if_needed();
  ScalarArray volume = granular_.mass.cwiseQuotient(granular_.density);
  std::visit([&](auto& model) {
    model.for_each_state_field([&](auto& field) {
      field = mls_regularised<D>(granular_.position, volume, granular_granular_, kernel_, field);
    });
  }, model_);
}

template <int D> void Simulation<D>::apply_shepard_filter() {
  const double h2x4 = 4.0 * kernel_.h * kernel_.h;
  const Index n = granular_.size();
  ScalarArray filtered(n);
  for_each_particle(n, [&](Index i) {
    if (frozen(i)) {
      filtered[i] = granular_.density[i];
      return;
    }
    const Vec<D> xi = row_vec<D>(granular_.position, i);
    const double w0 = kernel_.self_value();
    double num = granular_.mass[i] * w0;
    double den = granular_.mass[i] / granular_.density[i] * w0;
    for (Index s = granular_granular_.offsets[i]; s < granular_granular_.offsets[i + 1]; ++s) {
      const std::int32_t j = granular_granular_.indices[s];
      const double r2 = (xi - row_vec<D>(granular_.position, j)).squaredNorm();
      if (r2 >= h2x4) continue;
      const double weight = kernel_.value(std::sqrt(r2));
      num += granular_.mass[j] * weight;
      den += granular_.mass[j] / granular_.density[j] * weight;
    }
    filtered[i] = num / den;
  }, active_chunk());
  granular_.density = filtered;
}

template <int D> ScalarArray Simulation<D>::kernel_sum() const {
  const double h2x4 = 4.0 * kernel_.h * kernel_.h;
  const Index n = granular_.size();
  ScalarArray sums(n);
  for_each_particle(n, [&](Index i) {
    const Vec<D> xi = row_vec<D>(granular_.position, i);
    double sum = granular_.mass[i] / granular_.density[i] * kernel_.self_value();
    for (Index s = granular_granular_.offsets[i]; s < granular_granular_.offsets[i + 1]; ++s) {
      const std::int32_t j = granular_granular_.indices[s];
      const double r2 = (xi - row_vec<D>(granular_.position, j)).squaredNorm();
      if (r2 < h2x4) sum += granular_.mass[j] / granular_.density[j] * kernel_.value(std::sqrt(r2));
    }
    sums[i] = sum;
  });
  return sums;
}

template <int D> VecArray<D> Simulation<D>::kernel_gradient_sum() const {
  const double h2x4 = 4.0 * kernel_.h * kernel_.h;
  const Index n = granular_.size();
  VecArray<D> sums(n, D);
  for_each_particle(n, [&](Index i) {
    const Vec<D> xi = row_vec<D>(granular_.position, i);
    Vec<D> sum = Vec<D>::Zero();
    for (Index s = granular_granular_.offsets[i]; s < granular_granular_.offsets[i + 1]; ++s) {
      const std::int32_t j = granular_granular_.indices[s];
      const Vec<D> xij = xi - row_vec<D>(granular_.position, j);
      const double r2 = xij.squaredNorm();
      if (r2 < h2x4)
        sum += granular_.mass[j] / granular_.density[j] * kernel_.gradient_factor(std::sqrt(r2)) * xij;
    }
    row_vec<D>(sums, i) = sum;
  });
  return sums;
}

// ---------------------------------------------------------------- scene edits

template <int D> void Simulation<D>::remove_wall_group(std::int32_t group) {
  std::vector<Index> keep;
  for (Index w = 0; w < walls_.size(); ++w)
    if (walls_.group[w] != group) keep.push_back(w);
  walls_.fields.gather(keep);
  refresh();
}

template <int D> std::size_t Simulation<D>::memory_bytes() const {
  auto list_bytes = [](const NeighbourList& l) {
    return l.offsets.capacity() * sizeof(Index) + l.indices.capacity() * sizeof(std::int32_t);
  };
  return granular_.fields.bytes() + walls_.fields.bytes() + list_bytes(granular_granular_) +
         list_bytes(granular_wall_) + list_bytes(wall_granular_) + list_bytes(granular_half_) +
         strip_start_.capacity() * sizeof(Index) + strip_members_.capacity() * sizeof(std::int32_t) +
         static_cast<std::size_t>(pair_wall_force_.size()) * sizeof(double);
}

template class Simulation<2>;
template class Simulation<3>;

}  // namespace terrasph
