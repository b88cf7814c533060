// Simulation<D>: the force pass: continuity with δ-SPH, momentum with artificial viscosity, XSPH,
// the wall barrier and wall friction, the pair forces kept for the loads on bodies and walls, and
// the leak diagnostic.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "pair_loops.hpp"

namespace terrasph {

using namespace detail;  // the pair passes' shared pieces (pair_loops.hpp)

// The force pass of this run, compiled for its optional terms: where Dρ/Dt is summed, δ-SPH, XSPH,
// whether the granular–wall pair forces are kept (bodies, tracked wall loads), wall friction.
template <int D> void Simulation<D>::compose_force_pass() {
  const bool symplectic = params_.numerics.symplectic_density;
  const bool delta = params_.numerics.delta_sph > 0.0;
  force_pass_ = dispatch_flags([](auto density_here, auto with_delta, auto xsph, auto keep, auto friction) -> ForcePass {
    return &Simulation::template force_pass<density_terms(decltype(density_here)::value, decltype(with_delta)::value),
                                            decltype(xsph)::value, decltype(keep)::value, decltype(friction)::value>;
  }, !symplectic, delta, params_.numerics.xsph > 0.0, keeps_pair_forces(),
     params_.numerics.wall_friction_coefficient > 0.0);
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
  const double barrier_radius = pair_terms::wall_barrier_reach<D>() * params_.numerics.spacing;
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
    for_each_batched_pair<D, BatchTerm::gradient_factor>(xi, granular_wall_.offsets[i], granular_wall_.offsets[i + 1],
                                                         granular_wall_.indices.data(), kernel_, walls_.position,
                                                         [&](Index s, std::int32_t w, const PairBatch<D>& batch, int k) {
      const bool kept = KeepPairForces && (keep_every_wall || walls_.body[w] >= 0);
      if (kept) row_vec<D>(pair_wall_force_, s).setZero();
      const Vec<D>& xiw = batch.x[k];
      const double r2 = batch.r2[k];
      if (walls_.interior[w]) nearest_wall2 = std::min(nearest_wall2, r2);
      if (r2 >= h2x4) return;
      const Vec<D> grad_w = batch.gradient_factor[k] * xiw;
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
    });
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

template <int D>
template <int Density, bool UseXsph>
[[gnu::flatten]] void Simulation<D>::add_half_list_pairs(Index i, const ForceConstants<D>& c) {
  namespace term = pair_terms;
  GranularParticles<D>& p = granular_;
  const Vec<D> vi = row_vec<D>(p.velocity, i);
  const double rho_i = p.density[i], m_i = p.mass[i], volume_i = p.volume[i];
  const Mat<D> si = row_mat<D>(p.stress_over_rho2, i);
  const FieldRows<D> in(p);  // the arrays' addresses, taken once
  double* const acceleration = p.acceleration.data();
  double* const density_rate = p.density_rate.data();
  [[maybe_unused]] double* const xsph_sums = UseXsph ? xsph_correction_->data() : nullptr;
  Vec<D> a = Vec<D>::Zero(), x = Vec<D>::Zero();  // i's sums
  double r = 0.0;
  const bool i_awake = for_each_held_pair<UseXsph>(i, [&](std::int32_t j, bool j_awake, const PairBatch<D>& batch, int k) {
    const double grad_factor = batch.gradient_factor[k];
    const Vec<D>& xij = batch.x[k];
    const Vec<D> grad_w = grad_factor * xij;  // ∇_iW_ij (Eq. 2.39); ∇_jW_ji = −∇_iW_ij
    const Vec<D> vij = vi - in.velocity(j);
    const double m_j = in.mass[j];
    const double rho_j = in.density[j];
    const double inv_rho_mean = 2.0 / (rho_i + rho_j);
    const Vec<D> t = momentum_per_unit_mass<D>(c, si, in.stress_over_rho2(j), vij, xij, batch.r2[k], grad_w,
                                               inv_rho_mean);
    a.noalias() += m_j * t;
    const double difference = dynamic_density_difference<D>(c, rho_i, rho_j, xij);
    const DensityRatePair<Density> drho_i =
        density_rate_pair<D, Density>(c, m_j, in.volume[j], difference, vij, grad_w, grad_factor);
    r += drho_i.total();
    if constexpr (UseXsph) x += term::xsph<D>(c.chi, m_j, inv_rho_mean, batch.value[k], vij);
    if (j_awake) {
      Eigen::Map<Vec<D>>(acceleration + D * j) -= m_i * t;
      if constexpr (Density != no_density_terms)
        density_rate[j] += density_rate_pair<D, Density>(c, m_i, volume_i, -difference, vij, grad_w, grad_factor).total();
      if constexpr (UseXsph)
        Eigen::Map<Vec<D>>(xsph_sums + D * j) += term::xsph<D>(c.chi, m_i, inv_rho_mean, batch.value[k], Vec<D>(-vij));
    }
  });
  if (!i_awake) return;
  row_vec<D>(p.acceleration, i) += a;
  if constexpr (Density != no_density_terms) p.density_rate[i] += r;
  if constexpr (UseXsph) row_vec<D>(*xsph_correction_, i) += x;
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

#define TERRASPH_INSTANTIATE(D) \
  template void Simulation<D>::compose_force_pass(); \
  template bool Simulation<D>::penetrates_interior_wall(Index) const;
TERRASPH_INSTANTIATE(2)
TERRASPH_INSTANTIATE(3)
#undef TERRASPH_INSTANTIATE

}  // namespace terrasph
