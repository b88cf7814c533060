// Model constants of a simulation (the "model", kept apart from the particle state).
// All SI. Every field is validated by validate() with a message naming it and its range.
#pragma once

#include <cmath>
#include <string>

#include "terrasph/errors.hpp"
#include "terrasph/math.hpp"

namespace terrasph {

// Granular material: μ(I) rheology (Eq. 2.29–2.32) with the EOS of Eq. 2.30.
struct MaterialParams {
  double grain_density = 2532.0;      // ρ_s, density of the grains' solid (kg/m³)
  double reference_density = 2507.0;  // ρ0, bulk reference density of the EOS (kg/m³)
  double grain_diameter = 0.002;      // d (m)
  double mu1 = 0.3838640350354158;    // μ1, quasi-static friction, tan 21°
  double mu2 = 0.6494075931975106;    // μ2, dynamic friction limit, tan 33°
  double inertial_number_i0 = 0.279;  // I0 (Jop, Forterre & Pouliquen 2006)
  double bulk_stiffness = 28000.0;    // κ (Pa)
  double eos_exponent = 7.0;          // γ
  double water_content = 0.0;         // w, gravimetric
  double cohesion = 0.0;              // c (Pa), Eq. 2.33–2.34, computed by the Python layer
  // Quasi-static branch: false → the rate form of Eq. 2.29 everywhere; true → the deviatoric
  // stress is state, loaded elastically (Jaumann rate, shear modulus G) and capped at μ(I)P + c
  // (radial return), so a bed at rest holds shear stress below yield (the aim of Eq. 3.6).
  bool elastic_quasi_static = false;
  double shear_modulus = 0.0;         // G (Pa); 0 → 3K(1−2ν)/(2(1+ν)), K = κγ(1+w), ν = 0.3
};

// Discretisation and the optional numerical terms; a term with 0 is switched off.
struct NumericsParams {
  double spacing = 0.0026;                  // Δx (m): lattice spacing, particle volume Δx^D
  double h_factor = 1.3;                    // h = h_factor·Δx
  double cfl = 0.25;                        // C in dt = C·min(h/(c+|v|), √(h/|a|))
  double fixed_dt = 0.0;                    // 0: adaptive step; > 0: fixed, checked every step
  double sound_speed = 0.0;                 // c0; 0: Eq. 2.44 from the material
  double artificial_viscosity = 0.1;        // α_Π (Eq. 2.46) between grains; β_Π = 0; see docs/design_decisions.md
  double wall_artificial_viscosity = 1.0;   // α_Π for granular–wall pairs: keeps grains out of walls
  double wall_barrier = 1.0;                // strength of the contact barrier inside walls (r < Δx/2); 0: off
  double delta_sph = 0.1;                   // δ of the density diffusion (Eq. 2.42–2.43)
  double xsph = 0.2;                        // χ (Eq. 2.49)
  int shepard_interval = 0;                 // Shepard filter every N steps (Eq. 2.41); 0: off
  bool kernel_gradient_correction = false;  // renormalise ∇v so linear fields are exact
  double strain_rate_epsilon = -1.0;        // ε of |D′|+ε (1/s); < 0: 0.01·h² (dissertation)
  double neighbour_skin = 0.15;             // Verlet skin as a fraction of h
  double density_floor = 0.0;               // ρ ≥ density_floor·ρ0 after each kick; 0: no floor
  double density_ratio_min = 0.5;           // sane band for ρ/ρ0; outside it the run stops
  double density_ratio_max = 1.5;
};

template <int D> struct DomainParams {
  Vec<D> lower = Vec<D>::Constant(-1.0);  // granular particles must stay inside this box
  Vec<D> upper = Vec<D>::Constant(1.0);
  Vec<D> gravity = Vec<D>::Zero();        // body force per unit mass (m/s²)
};

template <int D> struct ModelParams {
  MaterialParams material;
  NumericsParams numerics;
  DomainParams<D> domain;

  double smoothing_length() const { return numerics.h_factor * numerics.spacing; }

  // c0 = √(κγρ_s / (ρ0(ρ_s − ρ0))) (Eq. 2.44) unless set explicitly.
  double artificial_sound_speed() const {
    if (numerics.sound_speed > 0.0) return numerics.sound_speed;
    const MaterialParams& m = material;
    return std::sqrt(m.bulk_stiffness * m.eos_exponent * m.grain_density /
                     (m.reference_density * (m.grain_density - m.reference_density)));
  }

  // √(dP/dρ) of the EOS at ρ0: √(κγ(1+w)/ρ0); the step must respect it too.
  double eos_sound_speed() const {
    const MaterialParams& m = material;
    return std::sqrt(m.bulk_stiffness * m.eos_exponent * (1.0 + m.water_content) /
                     m.reference_density);
  }

  double strain_rate_epsilon() const {
    const double h = smoothing_length();
    return numerics.strain_rate_epsilon >= 0.0 ? numerics.strain_rate_epsilon : 0.01 * h * h;
  }

  void validate() const {
    const MaterialParams& m = material;
    const NumericsParams& n = numerics;
    require_positive("material.grain_density", m.grain_density);
    require_positive("material.reference_density", m.reference_density);
    require_positive("material.grain_diameter", m.grain_diameter);
    if (!(m.mu1 >= 0.0)) throw parameter_error("material.mu1", m.mu1, "mu1 >= 0");
    if (!(m.mu2 >= m.mu1))
      throw parameter_error("material.mu2", m.mu2, "mu2 >= mu1 = " + format_number(m.mu1));
    require_positive("material.inertial_number_i0", m.inertial_number_i0);
    require_positive("material.bulk_stiffness", m.bulk_stiffness);
    if (!(m.eos_exponent >= 1.0))
      throw parameter_error("material.eos_exponent", m.eos_exponent, "gamma >= 1");
    if (!(m.water_content >= 0.0 && m.water_content < 1.0))
      throw parameter_error("material.water_content", m.water_content, "0 <= w < 1");
    if (!(m.cohesion >= 0.0)) throw parameter_error("material.cohesion", m.cohesion, "c >= 0");
    if (!(m.shear_modulus >= 0.0))
      throw parameter_error("material.shear_modulus", m.shear_modulus, ">= 0 (0 = from the EOS)");
    if (n.sound_speed <= 0.0 && !(m.grain_density > m.reference_density))
      throw parameter_error("material.grain_density", m.grain_density,
                            "grain_density > reference_density when c0 comes from Eq. 2.44");
    require_positive("numerics.spacing", n.spacing);
    if (!(n.h_factor >= 1.0 && n.h_factor <= 2.0))
      throw parameter_error("numerics.h_factor", n.h_factor, "1.0 <= h_factor <= 2.0");
    if (!(n.cfl > 0.0 && n.cfl <= 0.5))
      throw parameter_error("numerics.cfl", n.cfl, "0 < cfl <= 0.5");
    if (!(n.fixed_dt >= 0.0)) throw parameter_error("numerics.fixed_dt", n.fixed_dt, ">= 0");
    if (!(n.artificial_viscosity >= 0.0))
      throw parameter_error("numerics.artificial_viscosity", n.artificial_viscosity, ">= 0");
    if (!(n.wall_artificial_viscosity >= 0.0))
      throw parameter_error("numerics.wall_artificial_viscosity", n.wall_artificial_viscosity, ">= 0");
    if (!(n.wall_barrier >= 0.0)) throw parameter_error("numerics.wall_barrier", n.wall_barrier, ">= 0");
    if (!(n.density_floor >= 0.0 && n.density_floor <= 1.0))
      throw parameter_error("numerics.density_floor", n.density_floor, "0 <= density_floor <= 1");
    if (!(n.delta_sph >= 0.0 && n.delta_sph <= 1.0))
      throw parameter_error("numerics.delta_sph", n.delta_sph, "0 <= delta <= 1");
    if (!(n.xsph >= 0.0 && n.xsph <= 1.0))
      throw parameter_error("numerics.xsph", n.xsph, "0 <= chi <= 1");
    if (n.shepard_interval < 0)
      throw parameter_error("numerics.shepard_interval", n.shepard_interval, ">= 0");
    if (!(n.neighbour_skin >= 0.0 && n.neighbour_skin <= 1.0))
      throw parameter_error("numerics.neighbour_skin", n.neighbour_skin, "0 <= skin <= 1");
    if (!(n.density_ratio_min > 0.0 && n.density_ratio_min < 1.0))
      throw parameter_error("numerics.density_ratio_min", n.density_ratio_min, "(0, 1)");
    if (!(n.density_ratio_max > 1.0))
      throw parameter_error("numerics.density_ratio_max", n.density_ratio_max, "> 1");
    for (int k = 0; k < D; ++k) {
      if (!(domain.upper[k] > domain.lower[k]))
        throw parameter_error("domain.upper[" + std::to_string(k) + "]", domain.upper[k],
                              "> domain.lower");
    }
  }

 private:
  static void require_positive(const std::string& name, double value) {
    if (!(value > 0.0) || !std::isfinite(value)) throw parameter_error(name, value, "> 0 and finite");
  }
};

}  // namespace terrasph
