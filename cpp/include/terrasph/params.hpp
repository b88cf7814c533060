// Model constants of a simulation (the "model", kept apart from the particle state).
// All SI. validate() checks every field with a message naming it and its range.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "terrasph/errors.hpp"
#include "terrasph/math.hpp"
#include "terrasph/parameter.hpp"

namespace terrasph {

// The stress model of the grains (docs/design.md §3.3; docs/design_decisions.md).
enum class ConstitutiveModel {
  mu_i_rate,         // Eq. 2.29 everywhere: τ = (μ(I)P + c) D′/(|D′| + ε), no stress state
  mu_i_hypoelastic,  // hypoelastic–plastic μ(I): deviatoric stress s as state (Jaumann rate),
                     // capped at |s| ≤ μ(I)P + c
  drucker_prager,    // elasto-plastic Drucker–Prager with the Jaumann rate (Eq. 2.17–2.28,
                     // Appendix A): the full stress (σ_yy included) as state
  mu_i_strain,       // Eq. 3.6: Eq. 2.29 for I > 0.001, the small strain's direction E′/|E′| below;
                     // reference positions as state
};
// The names in the order of the enum's values (the Python side sees a str).
template <> struct ChoiceNames<ConstitutiveModel> {
  static constexpr std::array<const char*, 4> names = {"mu_i_rate", "mu_i_hypoelastic", "drucker_prager",
                                                       "mu_i_strain"};
};

// Plastic flow of the Drucker–Prager model: along the yield surface's normal (Eq. 2.18) or along
// the plastic potential with the dilatancy angle ψ (Eq. 2.19).
enum class PlasticFlow { associated, non_associated };
template <> struct ChoiceNames<PlasticFlow> {
  static constexpr std::array<const char*, 2> names = {"associated", "non_associated"};
};

// THE definition of every material and numerics parameter: everything else (struct fields and
// defaults, range checks, the bindings, the Python dataclasses, HDF5 units, CLI help) derives
// from these lists. An entry is X(type, name, default, unit, lower, upper, one-line doc); type is
// double, int, bool or a choice enum with ChoiceNames; unit "1" is a pure number. A rule that
// links two parameters goes into the group's validate() below. docs/design_decisions.md.
#define TERRASPH_MATERIAL_PARAMETERS(X)                                                                  \
  X(double, grain_density, 2532.0, "kg/m^3", exclusive(0.0), exclusive(inf),                             \
    "rho_s, density of the grains' solid (Table 2.1); > reference_density")                              \
  X(double, reference_density, 1519.2, "kg/m^3", exclusive(0.0), exclusive(inf),                         \
    "rho_0, bulk reference density of the EOS (Eq. 2.30): the packing's, packing_fraction*grain_density "  \
    "(0.6*2532; Table 2.1's 2507 is 99 % of the grains' and gives c0 = 89 m/s, docs/design_decisions.md)") \
  X(double, grain_diameter, 0.002, "m", exclusive(0.0), exclusive(inf), "d, grain diameter")             \
  X(double, mu1, 0.3838640350354158, "1", inclusive(0.0), exclusive(inf),                                \
    "mu_1, quasi-static friction coefficient of mu(I) (Eq. 2.31), tan 21 deg")                           \
  X(double, mu2, 0.6494075931975106, "1", inclusive(0.0), exclusive(inf),                                \
    "mu_2, dynamic friction limit of mu(I) (Eq. 2.31), tan 33 deg; >= mu1")                              \
  X(double, inertial_number_i0, 0.279, "1", exclusive(0.0), exclusive(inf),                              \
    "I_0 of mu(I) (Eq. 2.31; Jop, Forterre & Pouliquen 2006) with their I = gamma_dot*d/sqrt(P/rho_s), "   \
    "gamma_dot = sqrt(2 D':D'); the dissertation's I (|D'| = sqrt(D':D'/2)) is I0 = 0.1395")            \
  X(double, bulk_stiffness, 28000.0, "Pa", exclusive(0.0), exclusive(inf),                               \
    "kappa, stiffness of the EOS (Eq. 2.30)")                                                            \
  X(double, eos_exponent, 7.0, "1", inclusive(1.0), exclusive(inf),                                      \
    "gamma, exponent of the EOS (Eq. 2.30)")                                                             \
  X(double, water_content, 0.0, "1", inclusive(0.0), exclusive(1.0),                                     \
    "w, gravimetric water content (kg water per kg grains); 0 = dry")                                    \
  X(double, packing_fraction, 0.6, "1", exclusive(0.0), inclusive(1.0),                                  \
    "nu, solid packing fraction in the cohesion of Eq. 2.33")                                            \
  X(double, bridges_per_grain, 6.0, "1", exclusive(0.0), exclusive(inf),                                 \
    "k, liquid bridges per grain in Eq. 2.33")                                                           \
  X(double, surface_tension, 0.0725, "N/m", inclusive(0.0), exclusive(inf),                              \
    "gamma_s, surface tension of the liquid (water) in Eq. 2.34")                                        \
  X(double, filling_angle, 0.2617993877991494, "rad", inclusive(0.0), inclusive(0.5235987755982988),     \
    "phi, filling angle of a liquid bridge in Eq. 2.34 (15 deg); <= 30 deg, where bridges merge")        \
  X(double, liquid_density, 1000.0, "kg/m^3", exclusive(0.0), exclusive(inf),                            \
    "rho_l, density of the liquid (water), for the liquid saturation of the pendular check")             \
  X(ConstitutiveModel, model, ConstitutiveModel::mu_i_hypoelastic, "1", exclusive(-inf),                 \
    exclusive(inf), "mu_i_rate: Eq. 2.29 everywhere; mu_i_hypoelastic: deviatoric stress as state, "     \
    "Jaumann rate, capped at mu(I)P + c; drucker_prager: Eq. 2.17-2.28 with phi = atan(mu1), c; "        \
    "mu_i_strain: Eq. 3.6, the direction of the small strain E from reference positions for I <= 0.001")  \
  X(double, shear_modulus, 0.0, "Pa", inclusive(0.0), exclusive(inf),                                    \
    "G of mu_i_hypoelastic and drucker_prager; 0 = 3K(1-2nu)/(2(1+nu)), K = kappa*gamma*(1+w), nu = 0.3") \
  X(PlasticFlow, plastic_flow, PlasticFlow::non_associated, "1", exclusive(-inf), exclusive(inf),        \
    "drucker_prager flow rule: associated (Eq. 2.18) or non_associated with dilatancy_angle (Eq. 2.19)") \
  X(double, dilatancy_angle, 0.0, "rad", inclusive(0.0), exclusive(1.5707963267948966),                  \
    "psi of the non-associated drucker_prager flow (Eq. 2.19); <= the friction angle atan(mu1)")          \
  X(double, strain_reference_time, 0.0, "s", inclusive(0.0), exclusive(inf),                             \
    "mu_i_strain: the reference positions X of the small strain E follow the particles until this "      \
    "simulated time and stay fixed from then on; 0 = the positions at the start")

#define TERRASPH_NUMERICS_PARAMETERS(X)                                                                  \
  X(double, spacing, 0.0026, "m", exclusive(0.0), exclusive(inf),                                        \
    "dx, lattice spacing; a particle's volume is dx^D")                                                  \
  X(double, h_factor, 1.3, "1", inclusive(1.0), inclusive(2.0),                                          \
    "smoothing length h = h_factor*dx (Wendland C2, support 2h; ~21 neighbours in 2D at 1.3)")           \
  X(double, cfl, 0.5, "1", exclusive(0.0), inclusive(1.0),                                               \
    "C in the adaptive step dt = C*min(h/(c + |v|), sqrt(h/|a|)), c = max(c_0, the model's wave speed); "  \
    "above 0.5 only with symplectic_density")                                                            \
  X(double, fixed_dt, 0.0, "s", inclusive(0.0), exclusive(inf),                                          \
    "fixed time step, checked against the stable bound every step; 0 = adaptive")                        \
  X(double, sound_speed, 0.0, "m/s", inclusive(0.0), exclusive(inf),                                     \
    "c_0 of the artificial viscosity, the density diffusion and the step; 0 = Eq. 2.44 from the material") \
  X(bool, symplectic_density, true, "1", exclusive(-inf), exclusive(inf),                                \
    "advance the density over the whole step in the first pair pass, before the forces, from the "       \
    "velocity at the drifted positions (symplectic Euler in velocity and density, as the stress is); "   \
    "false = kicked in halves with the velocity (forward Euler in the pair, held by delta-SPH)")          \
  X(bool, symmetric_pairs, true, "1", exclusive(-inf), exclusive(inf),                                   \
    "both pair passes evaluate each granular pair once and add it to both grains (Newton's third law "   \
    "on a half neighbour list, the grains dealt to threads in strips so that no two write one grain): "  \
    "every pair term as before, summed in another order; false = each pair from both sides (gather)")   \
  X(double, mass_scaling, 1.0, "1", inclusive(1.0), exclusive(inf),                                     \
    "f: each grain's inertial mass is f times its mass, gravity and every force unchanged (explicit "    \
    "dynamics' mass scaling): every wave is sqrt(f) slower and the step sqrt(f) longer, for scenes "     \
    "slow against the bed's waves; 1 = off")                                                             \
  X(double, artificial_viscosity, 0.02, "1", inclusive(0.0), exclusive(inf),                             \
    "alpha_Pi (Eq. 2.46) between grains, beta_Pi = 0: it carries shear the rheology should "             \
    "(docs/fidelity.md: the column's runout and the inclined plane)")                                    \
  X(double, wall_artificial_viscosity, 1.0, "1", inclusive(0.0), exclusive(inf),                         \
    "alpha_Pi for granular-wall pairs, which keeps grains out of walls")                                 \
  X(double, wall_barrier, 1.0, "1", inclusive(0.0), exclusive(inf),                                      \
    "strength of the contact barrier near wall particles (r < 0.75 dx in 2D, dx in 3D), "                \
    "1 = K = c^2/h; 0 = off")                                                                            \
  X(double, wall_friction_coefficient, 0.0, "1", inclusive(0.0), exclusive(inf),                         \
    "mu_w, Coulomb friction on every wall: the tangential part of each granular-wall pair force becomes " \
    "-mu_w N v_t/max(|v_t|, mu_w N_i dt), never reversing the slip within a step; 0 = off (the walls' own " \
    "shear terms)")                                                                                      \
  X(double, delta_sph, 0.1, "1", inclusive(0.0), inclusive(1.0),                                         \
    "delta of the density diffusion (Eq. 2.42-2.43); 0 = off")                                           \
  X(double, density_diffusion_pressure_share, 0.0, "1", inclusive(0.0), inclusive(1.0),                  \
    "share s of the lithostatic weight the pressure carries in delta-SPH's hydrostatic density "         \
    "correction grad rho_H = s*rho_0*g/c^2; 0 = 1 (a hydrostatic start); a geostatic start sets (1+K0)/2") \
  X(double, xsph, 0.2, "1", inclusive(0.0), inclusive(1.0), "chi of XSPH (Eq. 2.49); 0 = off")           \
  X(int, shepard_interval, 0, "steps", inclusive(0.0), exclusive(inf),                                   \
    "Shepard density filter every N steps (Eq. 2.41); 0 = off")                                          \
  X(int, mls_interval, 0, "steps", inclusive(0.0), exclusive(inf),                                       \
    "MLS regularisation (Eq. 3.26-3.30, linear basis) of the model's stress state every N steps; 0 = off") \
  X(bool, kernel_gradient_normalisation, true, "1", exclusive(-inf), exclusive(inf),                    \
    "scale every grad W by 1/s, s the kernel's gradient moment on the start lattice at this h_factor "   \
    "(0.974 at 1.3 in 2D): linear fields' gradients exact on the lattice and a bed at rest carries its " \
    "weight within 0.5 % (docs/fidelity.md); false = the kernel's own gradient (Eq. 2.48 unscaled)")      \
  X(bool, kernel_gradient_correction, false, "1", exclusive(-inf), exclusive(inf),                       \
    "renormalise grad v so that linear velocity fields are exact")                                       \
  X(double, strain_rate_epsilon, 1e-7, "1/s", exclusive(0.0), exclusive(inf),                           \
    "epsilon of |D'| + epsilon in Eq. 2.29, a strain rate independent of h (the dissertation's 0.01*h^2 " \
    "read as 1/s is 1.1e-7 at its dx = 2.6 mm)")                                                         \
  X(double, neighbour_skin, 0.15, "1", inclusive(0.0), inclusive(1.0),                                   \
    "Verlet skin of the neighbour lists as a fraction of h")                                             \
  X(bool, cell_order, true, "1", exclusive(-inf), exclusive(inf),                                       \
    "store particles in cell order, re-sorted at each neighbour build (ids stable; sums reordered)")     \
  X(double, freeze_speed, 0.0, "m/s", inclusive(0.0), exclusive(inf),                                    \
    "active domain: a grain with |v| and freeze_steps*dt*|a| below this for freeze_steps steps, and no " \
    "body particle or unsettled grain within its neighbour radius, is frozen (not updated); 0 = off")    \
  X(int, freeze_steps, 200, "steps", inclusive(1.0), exclusive(inf),                                     \
    "N of freeze_speed: steps a grain must stay quiet before it counts as settled (active domain)")     \
  X(double, active_radius, 0.0, "m", inclusive(0.0), exclusive(inf),                                     \
    "active domain: a grain within this of a body particle is never frozen, one farther away counts "  \
    "as quiet on |v| alone (no acceleration test); 0 = off. Needs freeze_speed > 0")                     \
  X(double, density_floor, 0.0, "1", inclusive(0.0), inclusive(1.0),                                     \
    "rho >= density_floor*rho_0 after every kick; 0 = off")                                              \
  X(double, density_ratio_min, 0.5, "1", exclusive(0.0), exclusive(1.0),                                 \
    "the run stops if rho/rho_0 falls below this")                                                       \
  X(double, density_ratio_max, 1.5, "1", exclusive(1.0), exclusive(inf),                                 \
    "the run stops if rho/rho_0 rises above this")

// Granular material: μ(I) rheology (Eq. 2.29–2.32), the EOS of Eq. 2.30 and wet cohesion
// (Eq. 2.33–2.34).
struct MaterialParams {
  TERRASPH_PARAMETER_GROUP(MaterialParams, "material", TERRASPH_MATERIAL_PARAMETERS)

  // Capillary cohesion c (Pa) of a pendular wet material, 0 when dry.
  // c = ν k F / (π d²) (Rumpf; Eq. 2.33) with the mean bridge force
  // F = 2π r γ_s / (1 + tan(φ/2)) (Eq. 2.34), r = d/2.
  double cohesion() const {
    if (water_content == 0.0) return 0.0;
    constexpr double pi = 3.141592653589793;
    const double radius = 0.5 * grain_diameter;
    const double bridge_force = 2.0 * pi * radius * surface_tension / (1.0 + std::tan(0.5 * filling_angle));
    return packing_fraction * bridges_per_grain * bridge_force / (pi * grain_diameter * grain_diameter);
  }

  // Pendular state (Eq. 2.33–2.34 hold only while the liquid sits in separate bridges): the
  // liquid saturation S = V_liquid/V_pores = w ρ_s,dry ν / (ρ_l (1 − ν)) at most this. 0.1 is the
  // low end of the 10–30 % usually quoted for the pendular–funicular transition (Mitarai & Nori
  // 2006); ρ_s,dry = grain_density/(1 + w) because wet densities carry the (1 + w) of Table 2.1.
  static constexpr double max_pendular_saturation = 0.1;

  double liquid_saturation() const {
    const double dry_grain_density = grain_density / (1.0 + water_content);
    return water_content * dry_grain_density * packing_fraction / (liquid_density * (1.0 - packing_fraction));
  }

  // The largest water content of the pendular state for this packing and these densities.
  double max_pendular_water_content() const {
    if (packing_fraction >= 1.0) return 0.0;  // no pores: only the dry state
    const double dry_grain_density = grain_density / (1.0 + water_content);
    return max_pendular_saturation * liquid_density * (1.0 - packing_fraction) /
           (dry_grain_density * packing_fraction);
  }

  // Each parameter in its range, then the rules that link parameters.
  void validate() const {
    check_ranges(*this);
    if (water_content > 0.0 && !(liquid_saturation() <= max_pendular_saturation))
      throw parameter_error("material.water_content", water_content,
                            "water_content <= " + format_number(max_pendular_water_content()) +
                                " (pendular state: liquid saturation w*rho_s*nu/(rho_l*(1-nu)) <= " +
                                format_number(max_pendular_saturation) + ")");
    if (!(mu2 >= mu1)) throw parameter_error("material.mu2", mu2, "mu2 >= mu1 = " + format_number(mu1));
    // A packing is less dense than its grains (ρ0 ≈ νρ_s); Eq. 2.44 needs it too.
    if (!(grain_density > reference_density))
      throw parameter_error("material.grain_density", grain_density,
                            "grain_density > reference_density = " + format_number(reference_density));
    // a granular material cannot dilate faster than its friction allows (ψ ≤ φ)
    if (!(dilatancy_angle <= std::atan(mu1)))
      throw parameter_error("material.dilatancy_angle", dilatancy_angle,
                            "dilatancy_angle <= friction angle atan(mu1) = " + format_number(std::atan(mu1)) + " rad");
  }
};

// Discretisation and the optional numerical terms; a term with 0 is switched off.
struct NumericsParams {
  TERRASPH_PARAMETER_GROUP(NumericsParams, "numerics", TERRASPH_NUMERICS_PARAMETERS)

  void validate() const {
    check_ranges(*this);
    // Kicked in halves with the velocity, the density and the velocity are forward Euler in the pair,
    // held only by the damping terms: C = 0.4 moved a leg's peak loads by 13-16 % (docs/speed_history.md,
    // eighth round). Advanced before the forces (symplectic Euler) the leg-wheel kept its outcomes
    // within 1 % up to C = 1 (eleventh round): a measured bound, resting on the damping terms.
    if (cfl > 0.5 && !symplectic_density)
      throw parameter_error("numerics.cfl", cfl, "cfl <= 0.5 while numerics.symplectic_density = false "
                                                 "(up to 1 with the density advanced before the forces)");
    if (active_radius > 0.0 && !(freeze_speed > 0.0))
      throw parameter_error("numerics.active_radius", active_radius,
                            "0 while numerics.freeze_speed = 0 (the radius refines the active domain)");
  }
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

  double strain_rate_epsilon() const { return numerics.strain_rate_epsilon; }

  void validate() const {
    material.validate();
    numerics.validate();
    for (int k = 0; k < D; ++k) {
      if (!(domain.upper[k] > domain.lower[k]))
        throw parameter_error("domain.upper[" + std::to_string(k) + "]", domain.upper[k],
                              "> domain.lower");
    }
  }
};

}  // namespace terrasph
