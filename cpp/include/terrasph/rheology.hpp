// Constitutive relations of the granular phase: equation of state and μ(I) visco-plasticity.
#pragma once

#include <cmath>

#include "terrasph/math.hpp"
#include "terrasph/params.hpp"

namespace terrasph {

// P = κ[(ρ/ρ0)^γ − 1](1 + w) for ρ > ρ0, else 0: no tension (Eq. 2.30).
class EquationOfState {
 public:
  explicit EquationOfState(const MaterialParams& m)
      : kappa_wet_(m.bulk_stiffness * (1.0 + m.water_content)),
        rho0_(m.reference_density),
        gamma_(m.eos_exponent),
        integer_gamma_(gamma_ == std::floor(gamma_) && gamma_ <= 16.0 ? int(gamma_) : 0) {}

  double pressure(double rho) const {
    if (rho <= rho0_) return 0.0;
    const double ratio = rho / rho0_;
    const double power = integer_gamma_ > 0 ? int_pow(ratio, integer_gamma_) : std::pow(ratio, gamma_);
    return kappa_wet_ * (power - 1.0);
  }

  // Inverse of pressure() for P ≥ 0: ρ = ρ0 (P/(κ(1+w)) + 1)^(1/γ) (Eq. 3.32).
  double density(double p) const {
    if (p <= 0.0) return rho0_;
    return rho0_ * std::pow(p / kappa_wet_ + 1.0, 1.0 / gamma_);
  }

  double reference_density() const { return rho0_; }

 private:
  double kappa_wet_;
  double rho0_;
  double gamma_;
  int integer_gamma_;
};

// σ = −P I + (μ(I) P + c) D′/(|D′| + ε)  (Eq. 2.29, dense branch; docs/design.md §3.3)
// μ(I) = μ1 + (μ2 − μ1)/(I0/I + 1)       (Eq. 2.31)
// I = γ̇ d / √(P/ρ_s), γ̇ = 2|D′| = √(2 D′:D′)  (Eq. 2.32 with Jop, Forterre & Pouliquen 2006's γ̇,
//   the rate I0 = 0.279 was fitted with; γ̇ is the shear rate du/dy of a simple shear)
template <int D> class MuIRheology {
 public:
  MuIRheology(const MaterialParams& m, double epsilon)
      : mu1_(m.mu1), dmu_(m.mu2 - m.mu1), i0_(m.inertial_number_i0), d_(m.grain_diameter),
        rho_s_(m.grain_density), cohesion_(m.cohesion()), epsilon_(epsilon) {}

  // Cauchy stress from the velocity gradient L = ∇v and the pressure P.
  Mat<D> stress(const Mat<D>& velocity_gradient, double p) const {
    const Mat<D> strain_rate = 0.5 * (velocity_gradient + velocity_gradient.transpose());
    const Mat<D> deviator = strain_rate - (strain_rate.trace() / D) * Mat<D>::Identity();
    const double shear_rate = std::sqrt(0.5 * deviator.cwiseProduct(deviator).sum());
    const double strength = friction(shear_rate, p) * p + cohesion_;
    return strength / (shear_rate + epsilon_) * deviator - p * Mat<D>::Identity();
  }

  // Elastic quasi-static branch: the deviatoric stress s is state, advanced with the Jaumann rate
  //   ds/dt = 2G D′ + Ω s − s Ω,  Ω = ½(L − Lᵀ)   (hypoelastic part of Eq. 2.14/2.26)
  // and returned radially onto the μ(I) yield surface |s| ≤ μ(I)P + c (Eq. 2.29, 2.31), with
  // |s| = √(½ s:s) and I from the total |D′|. Returns σ = −P I + s; updates s in place.
  Mat<D> elastic_plastic_stress(const Mat<D>& velocity_gradient, double p, double dt, double shear_modulus,
                                Eigen::Ref<Mat<D>> deviatoric) const {
    const Mat<D> strain_rate = 0.5 * (velocity_gradient + velocity_gradient.transpose());
    const Mat<D> spin = 0.5 * (velocity_gradient - velocity_gradient.transpose());
    const Mat<D> strain_deviator = strain_rate - (strain_rate.trace() / D) * Mat<D>::Identity();
    Mat<D> s = deviatoric;
    s += dt * (2.0 * shear_modulus * strain_deviator + spin * s - s * spin);
    const double magnitude = std::sqrt(0.5 * s.cwiseProduct(s).sum());
    const double shear_rate = std::sqrt(0.5 * strain_deviator.cwiseProduct(strain_deviator).sum());
    const double yield = friction(shear_rate, p) * p + cohesion_;
    if (magnitude > yield) s *= yield / magnitude;
    deviatoric = s;
    return s - p * Mat<D>::Identity();
  }

  // Eq. 3.6: the rate form above (I > 0.001), and in the quasi-static regime (I ≤ 0.001) the
  // direction of the deviator E′ of the small strain E instead of D′:
  //   σ = −P I + (μ(I)P + c) E′/(|E′| + ε),  |E′| = √(½ E′:E′),
  // with the dissertation's ε for both branches. E′, not E: the shear term is deviatoric, as D′ is.
  Mat<D> strain_branch_stress(const Mat<D>& velocity_gradient, const Mat<D>& strain, double p) const {
    const Mat<D> strain_rate = 0.5 * (velocity_gradient + velocity_gradient.transpose());
    const Mat<D> rate_deviator = strain_rate - (strain_rate.trace() / D) * Mat<D>::Identity();
    const double shear_rate = std::sqrt(0.5 * rate_deviator.cwiseProduct(rate_deviator).sum());
    if (p <= 0.0 || inertial_number(shear_rate, p) > quasi_static_inertial_number)
      return stress(velocity_gradient, p);
    const Mat<D> deviator = strain - (strain.trace() / D) * Mat<D>::Identity();
    const double magnitude = std::sqrt(0.5 * deviator.cwiseProduct(deviator).sum());
    const double strength = friction(shear_rate, p) * p + cohesion_;
    return strength / (magnitude + epsilon_) * deviator - p * Mat<D>::Identity();
  }

  // the quasi-static regime of Eq. 3.6 (and of GDR MiDi 2004): I ≤ 0.001
  static constexpr double quasi_static_inertial_number = 1e-3;

  // I = γ̇ d/√(P/ρ_s) with γ̇ = 2|D′| (Jop et al. 2006) for P > 0; `shear_rate` is |D′| = √(½ D′:D′).
  double inertial_number(double shear_rate, double p) const {
    return 2.0 * shear_rate * d_ * std::sqrt(rho_s_ / p);
  }

  // μ(I) written as μ1 + (μ2 − μ1) I/(I0 + I), which is finite at I = 0.
  double friction(double shear_rate, double p) const {
    if (p <= 0.0) return mu1_ + dmu_;  // I → ∞; irrelevant since μP = 0
    const double inertial = inertial_number(shear_rate, p);
    return mu1_ + dmu_ * inertial / (i0_ + inertial);
  }

 private:
  double mu1_, dmu_, i0_, d_, rho_s_, cohesion_, epsilon_;
};

}  // namespace terrasph
