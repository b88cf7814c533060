// Simulation<D>: the neighbour lists and what is derived with them (cell-ordered storage, the
// strips and half list of numerics.symmetric_pairs), and the active domain's frozen grains and
// idle walls.
#include "terrasph/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "terrasph/parallel.hpp"

namespace terrasph {

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

#define TERRASPH_INSTANTIATE(D) \
  template void Simulation<D>::build_neighbours(); \
  template void Simulation<D>::sort_into_cell_order(); \
  template void Simulation<D>::update_frozen(); \
  template void Simulation<D>::update_idle_walls(); \
  template void Simulation<D>::build_neighbour_lists(const VecArray<D>&, const VecArray<D>&); \
  template void Simulation<D>::build_pair_strips(const VecArray<D>&, double); \
  template void Simulation<D>::update_neighbours_if_needed();
TERRASPH_INSTANTIATE(2)
TERRASPH_INSTANTIATE(3)
#undef TERRASPH_INSTANTIATE

}  // namespace terrasph
