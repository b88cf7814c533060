// The pieces the pair passes share (stress_pass.cpp, force_pass.cpp): the flags made compile-time,
// the run's pair constants, the batched kernel evaluation, and the two loop drivers over a grain's
// pairs (the whole list, gathered; the strips' half list, each pair once). Private to cpp/src.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <type_traits>

#include "terrasph/pair_terms.hpp"
#include "terrasph/parallel.hpp"
#include "terrasph/simulation.hpp"

namespace terrasph::detail {

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
  const Vec<D> xi = row_vec<D>(granular_.position, i);
  const Index end = granular_half_.offsets[i + 1];
  for (Index first = granular_half_.offsets[i]; first < end; first += detail::kPairBatch) {
    const int count = static_cast<int>(std::min<Index>(detail::kPairBatch, end - first));
    const std::int32_t* js = granular_half_.indices.data() + first;
    detail::PairBatch<D> batch;
    detail::gather_pairs<D, WithValue>(kernel_, js, count, xi, granular_.position, batch);
    for (int k = 0; k < count; ++k) {
      const bool j_awake = !frozen(js[k]);
      if (i_awake || j_awake) visit(js[k], j_awake, batch, k);
    }
  }
  return i_awake;
}

}  // namespace terrasph
