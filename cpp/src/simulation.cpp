// Simulation<D>: setting up (checks, optional fields, the passes of the run), restoring a saved
// state, storage order and scene edits. The step's jobs live beside it: neighbours.cpp (lists,
// cell order, strips, active domain), stress_pass.cpp and force_pass.cpp (the rate passes),
// bodies_and_loads.cpp, integration.cpp (the step and its bound), health_and_filters.cpp.
// Each file instantiates its members for 2D (and 3D to keep it compiling).
#include "terrasph/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "terrasph/errors.hpp"

namespace terrasph {

namespace {

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

// The scale of ∇W: 1/s with s the kernel's gradient moment Σ_j V_j (x_j − x_i)_z ∂W_ij/∂z_i on the
// start lattice (numerics.kernel_gradient_normalisation), so that Σ_j V_j (f_j − f_i) ∇_iW_ij is the
// exact gradient of a linear f there, in every term that uses ∇W (continuity, stress divergence,
// Π_ij, δ-SPH, ∇v). It is the constant-matrix form (M = s I on the lattice, computed once) of the
// kernel gradient correction of Bonet & Lok (1999), ∇W̃ = M_i⁻¹∇W: one constant keeps every pair
// antisymmetric, so momentum stays conserved pair by pair, at no cost per step.
template <int D> double kernel_gradient_scale(const NumericsParams& numerics) {
  if (!numerics.kernel_gradient_normalisation) return 1.0;
  return 1.0 / WendlandC2<D>::lattice_gradient_moment(numerics.h_factor);
}

}  // namespace

template <int D>
Simulation<D>::Simulation(const ModelParams<D>& params, GranularParticles<D> granular, WallParticles<D> walls)
    : params_(validated(params)),
      kernel_(params.smoothing_length(), kernel_gradient_scale<D>(params.numerics)),
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
  compose_stress_passes();
  compose_force_pass();
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

#define TERRASPH_INSTANTIATE(D) \
  template Simulation<D>::Simulation(const ModelParams<D>&, GranularParticles<D>, WallParticles<D>); \
  template void Simulation<D>::check_ids() const; \
  template void Simulation<D>::compose_passes(); \
  template void Simulation<D>::mark_interior_walls(); \
  template void Simulation<D>::refresh(); \
  template void Simulation<D>::restore(const RunCounters&, const std::vector<RigidBody<D>>&, std::vector<WallRemoval>); \
  template void Simulation<D>::permute_granular(const std::vector<Index>&); \
  template void Simulation<D>::permute_walls(const std::vector<Index>&); \
  template void Simulation<D>::remove_wall_group(std::int32_t); \
  template std::size_t Simulation<D>::memory_bytes() const;
TERRASPH_INSTANTIATE(2)
TERRASPH_INSTANTIATE(3)
#undef TERRASPH_INSTANTIATE

}  // namespace terrasph
