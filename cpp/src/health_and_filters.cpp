// Simulation<D>: the health check that stops a run going wrong, the density and stress filters
// (Shepard, MLS) and the kernel sums for diagnostics.
#include "terrasph/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "terrasph/errors.hpp"
#include "terrasph/mls.hpp"
#include "terrasph/parallel.hpp"

namespace terrasph {

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

#define TERRASPH_INSTANTIATE(D) \
  template void Simulation<D>::check_health() const; \
  template void Simulation<D>::apply_mls_regularisation(); \
  template void Simulation<D>::apply_shepard_filter(); \
  template ScalarArray Simulation<D>::kernel_sum() const; \
  template VecArray<D> Simulation<D>::kernel_gradient_sum() const;
TERRASPH_INSTANTIATE(2)
TERRASPH_INSTANTIATE(3)
#undef TERRASPH_INSTANTIATE

}  // namespace terrasph
