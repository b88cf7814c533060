// Constitutive models behind one interface (DESIGN §1.1, §3.3). A model owns its parameters and
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

// μ(I) visco-plasticity in rate form (Eq. 2.29–2.32) with the tension-free EOS (Eq. 2.30):
// σ = −P I + (μ(I)P + c) D′/(|D′| + ε). No state.
template <int D> class MuIRateModel {
 public:
  MuIRateModel(const MaterialParams& m, double epsilon)
      : eos_(m), rheology_(m, epsilon), wave_speed_(std::sqrt(eos_bulk_modulus(m) / m.reference_density)) {}

  void register_fields(FieldRegistry&) {}

  Mat<D> update(Index, const Mat<D>& velocity_gradient, double rho, double, double& pressure) const {
    pressure = eos_.pressure(rho);
    return rheology_.stress(velocity_gradient, pressure);
  }

  // √(dP/dρ) of the EOS at ρ0: √(κγ(1+w)/ρ0).
  double wave_speed() const { return wave_speed_; }
  double wall_pressure_floor() const { return 0.0; }  // no tension, as in the EOS
  double density_for_pressure(double p) const { return eos_.density(p); }
  double reference_density() const { return eos_.reference_density(); }

 private:
  EquationOfState eos_;
  MuIRheology<D> rheology_;
  double wave_speed_;
};

// Hypoelastic–plastic μ(I): the deviatoric stress s is state, loaded elastically with the Jaumann
// rate (shear modulus G) and returned radially onto |s| ≤ μ(I)P + c, so a bed at rest holds shear
// stress below yield (the aim of the dissertation's Eq. 3.6, reached differently). σ = −P I + s.
template <int D> class MuIHypoelasticModel {
 public:
  MuIHypoelasticModel(const MaterialParams& m, double epsilon)
      : eos_(m), rheology_(m, epsilon), shear_modulus_(shear_modulus(m)),
        // P-wave speed √((K + 4G/3)/ρ0), which exceeds the EOS sound speed
        wave_speed_(std::sqrt((eos_bulk_modulus(m) + 4.0 / 3.0 * shear_modulus_) / m.reference_density)) {}

  // G given, or from K and ν = 0.3: G = 3K(1 − 2ν)/(2(1 + ν)).
  static double shear_modulus(const MaterialParams& m) {
    if (m.shear_modulus > 0.0) return m.shear_modulus;
    constexpr double poisson = 0.3;
    return 3.0 * eos_bulk_modulus(m) * (1.0 - 2.0 * poisson) / (2.0 * (1.0 + poisson));
  }

  void register_fields(FieldRegistry& fields) {
    deviatoric_ = &fields.add<double, D * D>("deviatoric_stress", "Pa",
                                             "deviatoric stress s, state of the hypoelastic mu(I) model");
  }

  Mat<D> update(Index i, const Mat<D>& velocity_gradient, double rho, double dt, double& pressure) const {
    pressure = eos_.pressure(rho);
    return rheology_.elastic_plastic_stress(velocity_gradient, pressure, dt, shear_modulus_,
                                            row_mat<D>(*deviatoric_, i));
  }

  double wave_speed() const { return wave_speed_; }
  double wall_pressure_floor() const { return 0.0; }
  double density_for_pressure(double p) const { return eos_.density(p); }
  double reference_density() const { return eos_.reference_density(); }

 private:
  EquationOfState eos_;
  MuIRheology<D> rheology_;
  double shear_modulus_;
  double wave_speed_;
  MatArray<D>* deviatoric_ = nullptr;  // registered in the granular fields
};

template <int D> using ConstitutiveModelVariant = std::variant<MuIRateModel<D>, MuIHypoelasticModel<D>>;

// The model a configuration asks for (its fields not yet registered).
template <int D> ConstitutiveModelVariant<D> make_constitutive_model(const ModelParams<D>& params) {
  const double epsilon = params.strain_rate_epsilon();
  if (params.material.model == ConstitutiveModel::mu_i_hypoelastic)
    return MuIHypoelasticModel<D>(params.material, epsilon);
  return MuIRateModel<D>(params.material, epsilon);
}

}  // namespace terrasph
