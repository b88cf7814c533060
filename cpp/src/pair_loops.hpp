// The pieces the pair passes share (stress_pass.cpp, force_pass.cpp): the flags made compile-time,
// the run's pair constants, the batched kernel evaluation, the loop drivers over a grain's pairs
// (its whole list, gathered; the strips' half list, each pair once) and the granular pair
// interactions, each written once for both drivers. Private to cpp/src.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <type_traits>

#include "terrasph/pair_terms.hpp"
#include "terrasph/parallel.hpp"
#include "terrasph/simulation.hpp"

namespace terrasph::detail {
// Internal linkage, as helpers local to each pass file. The per-grain pair sums (add_granular_forces
// here, the passes' add_* members) are [[gnu::flatten]]: the loop driver and the interactions are
// inlined into them whatever their size, so the sums stay in registers (without it the split passes
// ran 15-22 % slower, measured with bench_ab.py).
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

// The addresses of the granular fields a pair sum reads, taken once per grain: read through the
// particle set's named references, each array's address was loaded again at every pair (two loads a
// field), as the compiler cannot tell that the sums' stores into other arrays leave it alone.
template <int D> struct FieldRows {
  const double* velocity_data;
  const double* mass;
  const double* density;
  const double* volume;
  const double* stress_data;
  explicit FieldRows(const GranularParticles<D>& p)
      : velocity_data(p.velocity.data()), mass(p.mass.data()), density(p.density.data()), volume(p.volume.data()),
        stress_data(p.stress_over_rho2.data()) {}
  Eigen::Map<const Vec<D>> velocity(Index j) const { return Eigen::Map<const Vec<D>>(velocity_data + D * j); }
  Eigen::Map<const Mat<D>> stress_over_rho2(Index j) const { return Eigen::Map<const Mat<D>>(stress_data + D * D * j); }
};

// visit(j, batch, k) for each pair of grain i in `list`, in list order, the kernel of a batch of
// them evaluated at once (W too when WithValue): the loop driver of every granular pair sum, the
// gathers over the full list and the each-pair-once sums over the strips' half list.
template <int D, bool WithValue, class Visit>
void for_each_listed_pair(Index i, const NeighbourList& list, const WendlandC2<D>& kernel, const VecArray<D>& position,
                          Visit&& visit) {
  const Vec<D> xi = row_vec<D>(position, i);
  const Index end = list.offsets[i + 1];
  for (Index first = list.offsets[i]; first < end; first += kPairBatch) {
    const int count = static_cast<int>(std::min<Index>(kPairBatch, end - first));
    const std::int32_t* js = list.indices.data() + first;
    PairBatch<D> batch;
    gather_pairs<D, WithValue>(kernel, js, count, xi, position, batch);
    for (int k = 0; k < count; ++k) visit(js[k], batch, k);
  }
}

// Which kernel term for_each_batched_pair evaluates: (dW/dr)/r into the batch's gradient_factor,
// rounded as WendlandC2::pair_gradient_factor (a grain's wall sums), or W into its value, rounded as
// WendlandC2::pair_value (a wall's extrapolations from its grains).
enum class BatchTerm { gradient_factor, value };

// visit(s, j, batch, k) for each pair of a particle at xi with the particles j = others[s] of
// `position` (list slots s = first..end), in list order, the kernel term of a batch of them
// evaluated at once: the loop driver of the sums between grains and walls (a grain's over its wall
// pairs, a wall's over its grains). A pair beyond the support gets a term of 0.
template <int D, BatchTerm Term, class Visit>
void for_each_batched_pair(const Vec<D>& xi, Index first, Index end, const std::int32_t* others,
                           const WendlandC2<D>& kernel, const VecArray<D>& position, Visit&& visit) {
  for (Index start = first; start < end; start += kPairBatch) {
    const int count = static_cast<int>(std::min<Index>(kPairBatch, end - start));
    const std::int32_t* js = others + start;
    PairBatch<D> batch;
    for (int k = 0; k < count; ++k) {
      batch.x[k] = xi - row_vec<D>(position, js[k]);
      batch.r2[k] = batch.x[k].squaredNorm();
    }
    for (int k = 0; k < count; ++k) {
      if constexpr (Term == BatchTerm::value) batch.value[k] = kernel.pair_value(batch.r2[k]);
      else batch.gradient_factor[k] = kernel.pair_gradient_factor(batch.r2[k]);
    }
    for (int k = 0; k < count; ++k) visit(start + k, js[k], batch, k);
  }
}

// ---- The granular pair interactions, each written once. A pass's gather (i's sums over its full
// list) and its each-pair-once variant (i's and j's sums from the half list) call the same function;
// j's terms are i's with the pair turned round (x_ji = −x_ij, v_ji = −v_ij, ∇_jW_ji = −∇_iW_ij), so
// each is the gather's to the bit. A pair beyond the support has W = (dW/dr)/r = 0, so all its terms
// are exact zeros: adding them is cheaper than a mispredicted branch.

// Adds V_j (f_j − f_i) ⊗ ∇_iW_ij, pair ij's share of the SPH gradient of a field f (Eq. 2.48: f = v
// for ∇v, with the walls' ghost velocities; f = u for the small strain of Eq. 3.6), to `sum`. With
// V_i it is the same pair's share for j (f_ij ⊗ ∇_jW_ji = f_ji ⊗ ∇_iW_ij). In place, so the outer
// product is summed without a temporary.
template <int D, class Sum>
void add_gradient_pair(Sum&& sum, double volume_j, double grad_factor, const Vec<D>& f_ji, const Vec<D>& xij) {
  sum.noalias() += ((volume_j * grad_factor) * f_ji) * xij.transpose();
}

// Subtracts V_j x_ij ⊗ ∇_iW_ij from the renormalisation matrix M_i = Σ_j V_j x_ji ⊗ ∇_iW_ij
// (Eq. 2.48).
template <int D> void add_moment_pair(Mat<D>& moment, double volume_j, double grad_factor, const Vec<D>& xij) {
  moment.noalias() -= ((volume_j * grad_factor) * xij) * xij.transpose();
}

// ρ_j − ρ_i + ∇ρ^H·x_ij, the dynamic density difference δ-SPH diffuses (pair_terms::density_diffusion);
// j's is its negative.
template <int D>
double dynamic_density_difference(const ForceConstants<D>& c, double rho_i, double rho_j, const Vec<D>& xij) {
  return rho_j - rho_i + c.hydrostatic_gradient.dot(xij);
}

// The Density terms of Dρ_i/Dt from one granular pair (Eq. 2.42–2.43), kept apart so that each
// driver sums them in its own fixed order: a gather adds them one by one, a pair evaluated once
// adds their total to i and to j.
template <int Density> struct DensityRatePair {
  double continuity = 0.0, diffusion = 0.0;
  void add_to(double& sum) const {
    if constexpr (Density >= continuity_only) sum += continuity;
    if constexpr (Density == continuity_and_diffusion) sum += diffusion;
  }
  double total() const {
    if constexpr (Density == continuity_and_diffusion) return continuity + diffusion;
    return continuity;
  }
};

// Continuity m_j v_ij·∇_iW_ij and, with δ-SPH, the diffusion of the dynamic density difference
// (Eq. 2.42–2.43) of pair ij for i; for j: (m_i, V_i, −difference) with the same v_ij and ∇_iW_ij
// (v_ji·∇_jW_ji = v_ij·∇_iW_ij).
template <int D, int Density>
DensityRatePair<Density> density_rate_pair(const ForceConstants<D>& c, double m_j, double volume_j, double difference,
                                           const Vec<D>& vij, const Vec<D>& grad_w, double grad_factor) {
  DensityRatePair<Density> terms;
  if constexpr (Density >= continuity_only) terms.continuity = pair_terms::continuity<D>(m_j, vij, grad_w);
  if constexpr (Density == continuity_and_diffusion)
    terms.diffusion = pair_terms::density_diffusion(c.delta_h_c0, difference, volume_j, grad_factor);
  return terms;
}

// (σ_i/ρ_i² + σ_j/ρ_j² − Π_ij I)·∇_iW_ij, the momentum term of pair ij per unit neighbour mass
// (Eq. 2.45–2.47): i gains m_j times it, j loses m_i times it.
template <int D, class MatJ>
Vec<D> momentum_per_unit_mass(const ForceConstants<D>& c, const Mat<D>& si, const MatJ& sj, const Vec<D>& vij,
                              const Vec<D>& xij, double r2, const Vec<D>& grad_w, double inv_rho_mean) {
  const double pi_ij = pair_terms::artificial_viscosity(vij.dot(xij), r2, c.h, c.alpha, c.c0, inv_rho_mean);
  return pair_terms::momentum<D>(1.0, si, sj, pi_ij, grad_w);
}

// The granular pairs' share of Dv_i/Dt, the XSPH sum and the Density terms of Dρ_i/Dt of particle
// i, in list order (the force pass's gather).
template <int D, int Density, bool UseXsph>
[[gnu::flatten]] void add_granular_forces(Index i, const GranularParticles<D>& p, const NeighbourList& list,
                         const WendlandC2<D>& kernel, const ForceConstants<D>& constants, Vec<D>& acc,
                         Vec<D>& xsph, double& drho) {
  const ForceConstants<D> c = constants;
  const Vec<D> vi = row_vec<D>(p.velocity, i);
  const double rho_i = p.density[i];
  const Mat<D> si = row_mat<D>(p.stress_over_rho2, i);
  Vec<D> a = acc, x = xsph;  // local accumulators
  double r = drho;
  // W only for XSPH
  for_each_listed_pair<D, UseXsph>(i, list, kernel, p.position, [&](std::int32_t j, const PairBatch<D>& batch, int k) {
    const double grad_factor = batch.gradient_factor[k];
    const Vec<D>& xij = batch.x[k];
    const Vec<D> grad_w = grad_factor * xij;  // ∇_iW_ij (Eq. 2.39)
    const Vec<D> vij = vi - row_vec<D>(p.velocity, j);
    const double m_j = p.mass[j];
    const double rho_j = p.density[j];
    const double inv_rho_mean = 2.0 / (rho_i + rho_j);  // 1/ρ̄_ij, shared by Π_ij and XSPH
    density_rate_pair<D, Density>(c, m_j, p.volume[j], dynamic_density_difference<D>(c, rho_i, rho_j, xij), vij,
                                  grad_w, grad_factor).add_to(r);
    a.noalias() += m_j * momentum_per_unit_mass<D>(c, si, row_mat<D>(p.stress_over_rho2, j), vij, xij, batch.r2[k],
                                                   grad_w, inv_rho_mean);
    if constexpr (UseXsph) x += pair_terms::xsph<D>(c.chi, m_j, inv_rho_mean, batch.value[k], vij);
  });
  acc = a;
  xsph = x;
  drho = r;
}

}  // namespace
}  // namespace terrasph::detail

namespace terrasph {

// Whether a grain the half list gives grain i is awake: a frozen grain's pairs count only for those.
template <int D> inline bool Simulation<D>::has_awake_half_neighbour(Index i) const {
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

// visit(j, j_awake, batch, k) for each pair grain i holds (its half list, in order) with an awake
// grain in it, the kernel of a batch of them evaluated at once (W too when WithValue); returns
// whether i is awake. A frozen grain whose held pairs are all with frozen grains is skipped whole.
template <int D>
template <bool WithValue, class Visit>
bool Simulation<D>::for_each_held_pair(Index i, Visit&& visit) const {
  const bool i_awake = !frozen(i);
  if (!i_awake && !has_awake_half_neighbour(i)) return false;
  const std::uint8_t* const frozen_flags = frozen_ ? frozen_->data() : nullptr;  // its address taken once
  detail::for_each_listed_pair<D, WithValue>(i, granular_half_, kernel_, granular_.position,
                                             [&](std::int32_t j, const detail::PairBatch<D>& batch, int k) {
    const bool j_awake = !frozen_flags || !frozen_flags[j];
    if (i_awake || j_awake) visit(j, j_awake, batch, k);
  });
  return i_awake;
}

}  // namespace terrasph
