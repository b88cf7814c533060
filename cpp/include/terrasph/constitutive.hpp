// Constitutive models behind one interface (docs/design.md §1.1, §3.3). A model owns its parameters and
// the per-particle state it registers, and provides:
//   register_fields(FieldRegistry&)        the state it keeps per granular particle (or nothing)
//   update(i, ∇v_i, ρ_i, dt, P&) → σ_i     its stress update; dt = 0 evaluates without advancing state
//   wave_speed()                           the fastest physical wave the explicit step must resolve
//   wall_pressure_floor()                  its tension cut-off, applied to the wall stress
//   density_for_pressure(P)                inverse of its pressure law, for the wall density (Eq. 3.32)
// The simulation picks the model once per run and its passes are compiled for that model, so a
// scene pays nothing for a model it does not use. In 2D the models work in plane strain with the
// in-plane D×D tensors; a model that needs σ_yy registers it as part of its own state.
#pragma once

#include <cmath>
#include <variant>

#include "terrasph/fields.hpp"
#include "terrasph/math.hpp"
#include "terrasph/params.hpp"
#include "terrasph/rheology.hpp"

namespace terrasph {

// Bulk modulus of the EOS at ρ0: K = κγ(1 + w).
inline double eos_bulk_modulus(const MaterialParams& m) {
  return m.bulk_stiffness * m.eos_exponent * (1.0 + m.water_content);
}

// The tension-free EOS of the μ(I) models (Eq. 2.30) and what walls need from it: no tension, and
// the density of a wall particle from its pressure (Eq. 3.32).
class TensionFreeEos {
 public:
  explicit TensionFreeEos(const MaterialParams& m) : eos_(m) {}
  double wall_pressure_floor() const { return 0.0; }
  double density_for_pressure(double p) const { return eos_.density(p); }
  double reference_density() const { return eos_.reference_density(); }

 protected:
  EquationOfState eos_;
};

// μ(I) visco-plasticity in rate form (Eq. 2.29–2.32) with the tension-free EOS (Eq. 2.30):
// σ = −P I + (μ(I)P + c) D′/(|D′| + ε). No state.
template <int D> class MuIRateModel : public TensionFreeEos {
 public:
  MuIRateModel(const MaterialParams& m, double epsilon)
      : TensionFreeEos(m), rheology_(m, epsilon), wave_speed_(std::sqrt(eos_bulk_modulus(m) / m.reference_density)) {}

  void register_fields(FieldRegistry&) {}
  // the state fields an MLS regularisation smooths (numerics.mls_interval): none
  template <class Visit> void for_each_state_field(Visit&&) {}

  Mat<D> update(Index, const Mat<D>& velocity_gradient, double rho, double, double& pressure) const {
    pressure = eos_.pressure(rho);
    return rheology_.stress(velocity_gradient, pressure);
  }

  // √(dP/dρ) of the EOS at ρ0: √(κγ(1+w)/ρ0).
  double wave_speed() const { return wave_speed_; }

 private:
  MuIRheology<D> rheology_;
  double wave_speed_;
};

// μ(I) of Eq. 3.6 with the strain-based quasi-static branch: Eq. 2.29 in flow (I > 0.001); below,
// the shear stress (μ(I)P + c) points along the deviator of the small strain E = ½(∇u + ∇uᵀ) of
// the displacement u = x − X from each particle's reference position X (MuIRheology::
// strain_branch_stress). It registers X and E; the simulation computes E before the stress
// (Simulation::small_strain_pass, the ∇v sum with u for v, renormalised) and, until
// material.strain_reference_time, keeps moving X with the particles. Only scenes that choose this
// model store X and E.
template <int D> class MuIStrainModel : public TensionFreeEos {
 public:
  MuIStrainModel(const MaterialParams& m, double epsilon)
      : TensionFreeEos(m), rheology_(m, epsilon), reference_time_(m.strain_reference_time),
        wave_speed_(std::sqrt(eos_bulk_modulus(m) / m.reference_density)) {}

  // X starts at the positions the particles have when the model is registered (if they have any).
  void register_fields(FieldRegistry& fields) {
    reference_ = &fields.add<double, D>("reference_position", "m",
                                        "X, reference position of the small strain of mu_i_strain (Eq. 3.6)");
    if (fields.contains("position")) *reference_ = fields.get<double, D>("position");
    strain_ = &fields.add<double, D * D>("small_strain", "1",
                                         "E = sym grad(x - X), small strain of mu_i_strain (Eq. 3.6)");
  }
  // the state fields an MLS regularisation smooths: none (X is a position, E is recomputed)
  template <class Visit> void for_each_state_field(Visit&&) {}

  Mat<D> update(Index i, const Mat<D>& velocity_gradient, double rho, double, double& pressure) const {
    pressure = eos_.pressure(rho);
    return rheology_.strain_branch_stress(velocity_gradient, row_mat<D>(*strain_, i), pressure);
  }

  double wave_speed() const { return wave_speed_; }
  VecArray<D>& reference_position() { return *reference_; }
  MatArray<D>& small_strain() { return *strain_; }
  // X follows the particles while the simulated time is below this
  double reference_time() const { return reference_time_; }

 private:
  MuIRheology<D> rheology_;
  double reference_time_;
  double wave_speed_;
  VecArray<D>* reference_ = nullptr;  // registered in the granular fields
  MatArray<D>* strain_ = nullptr;
};

// Shear modulus of the models with an elastic part: G given, or from K and ν = 0.3:
// G = 3K(1 − 2ν)/(2(1 + ν)).
inline double elastic_shear_modulus(const MaterialParams& m) {
  if (m.shear_modulus > 0.0) return m.shear_modulus;
  constexpr double poisson = 0.3;
  return 3.0 * eos_bulk_modulus(m) * (1.0 - 2.0 * poisson) / (2.0 * (1.0 + poisson));
}

// Hypoelastic–plastic μ(I): the deviatoric stress s is state, loaded elastically with the Jaumann
// rate (shear modulus G) and returned radially onto |s| ≤ μ(I)P + c, so a bed at rest holds shear
// stress below yield (the aim of the dissertation's Eq. 3.6, reached differently). σ = −P I + s.
template <int D> class MuIHypoelasticModel : public TensionFreeEos {
 public:
  MuIHypoelasticModel(const MaterialParams& m, double epsilon)
      : TensionFreeEos(m), rheology_(m, epsilon), shear_modulus_(elastic_shear_modulus(m)),
        // P-wave speed √((K + 4G/3)/ρ0), which exceeds the EOS sound speed
        wave_speed_(std::sqrt((eos_bulk_modulus(m) + 4.0 / 3.0 * shear_modulus_) / m.reference_density)) {}

  void register_fields(FieldRegistry& fields) {
    deviatoric_ = &fields.add<double, D * D>("deviatoric_stress", "Pa",
                                             "deviatoric stress s, state of the hypoelastic mu(I) model");
  }
  template <class Visit> void for_each_state_field(Visit&& visit) { visit(*deviatoric_); }

  Mat<D> update(Index i, const Mat<D>& velocity_gradient, double rho, double dt, double& pressure) const {
    pressure = eos_.pressure(rho);
    return rheology_.elastic_plastic_stress(velocity_gradient, pressure, dt, shear_modulus_,
                                            row_mat<D>(*deviatoric_, i));
  }

  double wave_speed() const { return wave_speed_; }

 private:
  MuIRheology<D> rheology_;
  double shear_modulus_;
  double wave_speed_;
  MatArray<D>* deviatoric_ = nullptr;  // registered in the granular fields
};

// Elasto-plastic Drucker–Prager with the Jaumann stress rate (Eq. 2.17–2.28, Appendix A; Bui,
// Fukagawa, Sako & Ohno 2008). The full stress σ is state, 3×3 even in 2D, where plane strain
// keeps σ_yy (stored after the in-plane components: rows x, z, y in 2D; x, y, z in 3D). Per step:
//   elastic predictor with the Jaumann rate (Eq. 2.27/2.28):
//     σ* = σ + dt (Wσ − σW + 2G D′ + K tr(D) I),  W = ½(L − Lᵀ), D′ the 3D deviator of D;
//   plastic corrector where f(σ*) = √J2 + α I1 − k_c > 0 (Eq. 2.17), the closed-form return of
//   the same flow rule, which integrates Eq. 2.22–2.25 over the step:
//     Δλ = f / (G + 9Kαβ),  s ← s (√J2 − GΔλ)/√J2,  I1 ← I1 − 9KβΔλ,
//   with β = α (associated, Eq. 2.18) or β = tan ψ/√(9 + 12 tan²ψ) (non-associated); a return
//   past the cone's apex lands on the apex; then the tension cut-off I1 ≤ k_c/α.
// α = tan φ/√(9 + 12 tan²φ), k_c = 3c/√(9 + 12 tan²φ) (plane strain, Eq. 2.21), φ = atan μ1 and
// c the capillary cohesion. K = κγ(1 + w), G as for the hypoelastic μ(I).
template <int D> class DruckerPragerModel {
 public:
  using Mat3 = Mat<3>;

  explicit DruckerPragerModel(const MaterialParams& m)
      : bulk_(eos_bulk_modulus(m)), shear_(elastic_shear_modulus(m)), rho0_(m.reference_density),
        alpha_(plane_strain_coefficient(m.mu1)),
        k_c_(3.0 * m.cohesion() / std::sqrt(9.0 + 12.0 * m.mu1 * m.mu1)),
        beta_(m.plastic_flow == PlasticFlow::associated ? alpha_
                                                        : plane_strain_coefficient(std::tan(m.dilatancy_angle))),
        wave_speed_(std::sqrt((bulk_ + 4.0 / 3.0 * shear_) / rho0_)) {}

  // tan φ/√(9 + 12 tan²φ) of Eq. 2.21 (and of the plastic potential with ψ for φ).
  static double plane_strain_coefficient(double tan_angle) {
    return tan_angle / std::sqrt(9.0 + 12.0 * tan_angle * tan_angle);
  }

  void register_fields(FieldRegistry& fields) {
    stress_ = &fields.add<double, 9>("stress_state", "Pa",
                                     "full stress of drucker_prager, 3x3: in-plane rows first, then the out-of-plane one");
  }
  template <class Visit> void for_each_state_field(Visit&& visit) { visit(*stress_); }

  Mat<D> update(Index i, const Mat<D>& velocity_gradient, double, double dt, double& pressure) const {
    Eigen::Map<Mat3> sigma(stress_->data() + 9 * i);
    const Mat3 l = embed(velocity_gradient);
    const Mat3 strain_rate = 0.5 * (l + l.transpose());
    const Mat3 spin = 0.5 * (l - l.transpose());
    const double volumetric = strain_rate.trace();
    const Mat3 deviator = strain_rate - (volumetric / 3.0) * Mat3::Identity();
    const Mat3 trial = sigma + dt * (spin * sigma - sigma * spin + 2.0 * shear_ * deviator +
                                     bulk_ * volumetric * Mat3::Identity());
    sigma = return_to_yield(trial);
    pressure = -sigma.trace() / 3.0;
    return sigma.template topLeftCorner<D, D>();
  }

  // The stress on or inside the yield cone closest along the flow rule (see above).
  Mat3 return_to_yield(const Mat3& trial) const {
    double i1 = trial.trace();
    Mat3 s = trial - (i1 / 3.0) * Mat3::Identity();
    const double root_j2 = std::sqrt(0.5 * s.cwiseProduct(s).sum());
    const double f = root_j2 + alpha_ * i1 - k_c_;
    if (f > 0.0) {
      const double multiplier = f / (shear_ + 9.0 * bulk_ * alpha_ * beta_);
      const double remaining = root_j2 - shear_ * multiplier;
      if (remaining <= 0.0 && alpha_ > 0.0) return (k_c_ / alpha_ / 3.0) * Mat3::Identity();  // the apex
      s *= std::max(remaining, 0.0) / root_j2;
      i1 -= 9.0 * bulk_ * beta_ * multiplier;
    }
    if (alpha_ > 0.0) i1 = std::min(i1, k_c_ / alpha_);  // tension cut-off at the apex
    return s + (i1 / 3.0) * Mat3::Identity();
  }

  double wave_speed() const { return wave_speed_; }
  // the apex's mean stress: tension up to the cohesion's share, none when dry
  double wall_pressure_floor() const { return alpha_ > 0.0 ? -k_c_ / (3.0 * alpha_) : 0.0; }
  // the linear bulk law of the elastic part: ρ = ρ0 (1 + P/K)
  double density_for_pressure(double p) const { return rho0_ * (1.0 + p / bulk_); }
  double reference_density() const { return rho0_; }

 private:
  // L in 3D: the in-plane D×D block, zeros out of plane (plane strain).
  static Mat3 embed(const Mat<D>& l) {
    Mat3 out = Mat3::Zero();
    out.template topLeftCorner<D, D>() = l;
    return out;
  }

  double bulk_, shear_, rho0_, alpha_, k_c_, beta_, wave_speed_;
  FieldArray<double, 9>* stress_ = nullptr;  // registered in the granular fields
};

template <int D>
using ConstitutiveModelVariant =
    std::variant<MuIRateModel<D>, MuIHypoelasticModel<D>, DruckerPragerModel<D>, MuIStrainModel<D>>;

// Whether a model's stress needs the small strain E (its passes then compute it first).
template <class Model> constexpr bool uses_small_strain = false;
template <int D> constexpr bool uses_small_strain<MuIStrainModel<D>> = true;

// The model a configuration asks for (its fields not yet registered).
template <int D> ConstitutiveModelVariant<D> make_constitutive_model(const ModelParams<D>& params) {
  const double epsilon = params.strain_rate_epsilon();
  if (params.material.model == ConstitutiveModel::drucker_prager) return DruckerPragerModel<D>(params.material);
  if (params.material.model == ConstitutiveModel::mu_i_strain) return MuIStrainModel<D>(params.material, epsilon);
  if (params.material.model == ConstitutiveModel::mu_i_hypoelastic)
    return MuIHypoelasticModel<D>(params.material, epsilon);
  return MuIRateModel<D>(params.material, epsilon);
}

}  // namespace terrasph
