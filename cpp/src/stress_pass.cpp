// Simulation<D>: the passes before the forces: the walls' ghost velocity, ∇v (Eq. 2.48) with the
// stress of the constitutive model (and, with numerics.symplectic_density, Dρ/Dt and the density's
// update), the small strain of mu_i_strain (Eq. 3.6), and the walls' extrapolated stress (Eq. 3.31).
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <variant>

#include "pair_loops.hpp"

namespace terrasph {

using namespace detail;  // the pair passes' shared pieces (pair_loops.hpp)

// The ∇v-and-stress pass and the wall stress pass of this run, compiled for its constitutive model
// and for where the density's rate is summed (here with numerics.symplectic_density, with δ-SPH or not).
template <int D> void Simulation<D>::compose_stress_passes() {
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
    for_each_batched_pair<D, BatchTerm::value>(xw, wall_granular_.offsets[w], wall_granular_.offsets[w + 1],
                                               wall_granular_.indices.data(), kernel_, granular_.position,
                                               [&](Index, std::int32_t f, const PairBatch<D>& batch, int k) {
      if (batch.r2[k] >= h2x4) return;
      const double weight = batch.value[k];
      sum_w += weight;
      sum_v += weight * row_vec<D>(granular_.velocity, f);
    });
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
[[gnu::flatten]] void Simulation<D>::add_granular_velocity_gradient(Index i, bool correct, const ForceConstants<D>& c, Mat<D>& grad,
                                                   Mat<D>& moment, double& drho) {
  const GranularParticles<D>& p = granular_;
  const Vec<D> vi = row_vec<D>(p.velocity, i);
  [[maybe_unused]] const double rho_i = p.density[i];
  Mat<D> g = grad, m = moment;  // local accumulators: the cache stores cannot alias them
  double r = drho;
  for_each_listed_pair<D, false>(i, granular_granular_, kernel_, p.position, [&](std::int32_t j, const PairBatch<D>& batch,
                                                                                 int k) {
    const Vec<D>& xij = batch.x[k];
    const double grad_factor = batch.gradient_factor[k];
    const Vec<D> vji = row_vec<D>(p.velocity, j) - vi;
    add_gradient_pair<D>(g, p.volume[j], grad_factor, vji, xij);
    if (correct) add_moment_pair<D>(m, p.volume[j], grad_factor, xij);
    if constexpr (Density != no_density_terms)  // ∇_iW_ij = F x_ij (Eq. 2.39)
      density_rate_pair<D, Density>(c, p.mass[j], p.volume[j], dynamic_density_difference<D>(c, rho_i, p.density[j], xij),
                                    Vec<D>(-vji), Vec<D>(grad_factor * xij), grad_factor).add_to(r);
  });
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
[[gnu::flatten]] void Simulation<D>::add_half_list_gradient_pairs(Index i, const ForceConstants<D>& c) {
  GranularParticles<D>& p = granular_;
  const Vec<D> vi = row_vec<D>(p.velocity, i);
  [[maybe_unused]] const double rho_i = p.density[i], m_i = p.mass[i];
  const double volume_i = p.volume[i];
  const FieldRows<D> in(p);  // the arrays' addresses, taken once
  double* const velocity_gradient = p.velocity_gradient.data();
  [[maybe_unused]] double* const density_rate = p.density_rate.data();
  Mat<D> g = Mat<D>::Zero();  // i's sums
  double r = 0.0;
  const bool i_awake = for_each_held_pair<false>(i, [&](std::int32_t j, bool j_awake, const PairBatch<D>& batch, int k) {
    const Vec<D>& xij = batch.x[k];
    const double grad_factor = batch.gradient_factor[k];
    const Vec<D> vji = in.velocity(j) - vi;
    add_gradient_pair<D>(g, in.volume[j], grad_factor, vji, xij);
    [[maybe_unused]] DensityRatePair<Density> drho_i, drho_j;
    if constexpr (Density != no_density_terms) {
      const Vec<D> vij = -vji;
      const Vec<D> grad_w = grad_factor * xij;  // ∇_iW_ij (Eq. 2.39)
      const double difference = dynamic_density_difference<D>(c, rho_i, in.density[j], xij);
      drho_i = density_rate_pair<D, Density>(c, in.mass[j], in.volume[j], difference, vij, grad_w, grad_factor);
      drho_j = density_rate_pair<D, Density>(c, m_i, volume_i, -difference, vij, grad_w, grad_factor);
      r += drho_i.total();
    }
    if (j_awake) {
      add_gradient_pair<D>(Eigen::Map<Mat<D>>(velocity_gradient + D * D * j), volume_i, grad_factor, vji, xij);
      if constexpr (Density != no_density_terms) density_rate[j] += drho_j.total();
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
[[gnu::flatten]] void Simulation<D>::add_wall_velocity_gradient(Index i, bool correct, Mat<D>& grad, Mat<D>& moment,
                                               double& drho) const {
  const WendlandC2<D> kernel = kernel_;
  const double wall_volume = wall_volume_;
  const Vec<D> xi = row_vec<D>(granular_.position, i);
  const Vec<D> vi = row_vec<D>(granular_.velocity, i);
  Mat<D> g = grad, m = moment;
  double r = drho;
  for_each_batched_pair<D, BatchTerm::gradient_factor>(xi, granular_wall_.offsets[i], granular_wall_.offsets[i + 1],
                                                       granular_wall_.indices.data(), kernel, walls_.position,
                                                       [&](Index, std::int32_t w, const PairBatch<D>& batch, int k) {
    const Vec<D>& xiw = batch.x[k];
    const double factor = batch.gradient_factor[k];
    add_gradient_pair<D>(g, wall_volume, factor, Vec<D>(row_vec<D>(walls_.ghost_velocity, w) - vi), xiw);
    if (correct) add_moment_pair<D>(m, wall_volume, factor, xiw);
    if constexpr (Continuity)  // Eq. 2.42 with the wall's own velocity, as in the force pass
      r += pair_terms::continuity<D>(walls_.mass[w], Vec<D>(vi - row_vec<D>(walls_.velocity, w)), Vec<D>(factor * xiw));
  });
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
      const double grad_factor = kernel_.gradient_factor(std::sqrt(r2));
      add_gradient_pair<D>(grad, granular_.volume[j], grad_factor, Vec<D>(xj - row_vec<D>(reference, j) - ui), xij);
      add_moment_pair<D>(moment, granular_.volume[j], grad_factor, xij);
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
    for_each_batched_pair<D, BatchTerm::value>(xw, wall_granular_.offsets[w], wall_granular_.offsets[w + 1],
                                               wall_granular_.indices.data(), kernel_, granular_.position,
                                               [&](Index, std::int32_t f, const PairBatch<D>& batch, int k) {
      if (batch.r2[k] >= h2x4) return;
      const double weight = batch.value[k];
      sum_w += weight;
      sum_sigma += weight * row_mat<D>(granular_.stress, f);
      sum_rho_x += (weight * granular_.density[f]) * batch.x[k];
    });
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

#define TERRASPH_INSTANTIATE(D) \
  template void Simulation<D>::compose_stress_passes(); \
  template void Simulation<D>::wall_velocity_pass(); \
  template void Simulation<D>::small_strain_pass(VecArray<D>&, MatArray<D>&, double);
TERRASPH_INSTANTIATE(2)
TERRASPH_INSTANTIATE(3)
#undef TERRASPH_INSTANTIATE

}  // namespace terrasph
