// The pair terms of the continuity and momentum equations, one small unit each, shared by
// granular–granular and granular–wall pairs. i is the particle being updated, j a neighbour,
// x_ij = x_i − x_j, v_ij = v_i − v_j, ∇_iW_ij = F(r) x_ij with F = (dW/dr)/r.
#pragma once

#include <algorithm>

#include "terrasph/math.hpp"

namespace terrasph {

// Constants of the pair terms of the continuity and momentum equations.
template <int D> struct ForceConstants {
  double h, alpha, c0, delta_h_c0, chi;
  Vec<D> hydrostatic_gradient;  // ∇ρ^H = ρ0 g / c², c of the EOS
};

}  // namespace terrasph

namespace terrasph::pair_terms {

// Continuity (Eq. 2.42, first term): m_j v_ij·∇_iW_ij.
template <int D> inline double continuity(double m_j, const Vec<D>& v_ij, const Vec<D>& grad_w) {
  return m_j * v_ij.dot(grad_w);
}

// δ-SPH density diffusion, Molteni & Colagrossi (2009) form of Eq. 2.42–2.43 written so that it
// reduces density differences, applied to the dynamic part of the difference only (Fourtakas,
// Rogers et al. 2019): the hydrostatic difference ρ0 g·x_ji / c_eos² is subtracted, so a bed at
// rest under gravity is not driven by the diffusion of its own lithostatic density gradient.
//   2δhc0 (ρ_j − ρ_i − ρ0 g·x_ji/c²) (x_ji·∇_iW_ij)/|x_ij|² V_j,   x_ji·∇_iW_ij/|x_ij|² = −F
inline double density_diffusion(double delta_h_c0, double rho_difference, double volume_j, double grad_factor) {
  return 2.0 * delta_h_c0 * rho_difference * (-grad_factor) * volume_j;
}

// Monaghan artificial viscosity Π_ij (Eq. 2.46–2.47) with α_Π = alpha, β_Π = 0, c_ij = c0.
// Written without a branch: approaching and receding pairs are equally likely, so a branch on the
// sign of v_ij·x_ij would be mispredicted half the time. min(v_ij·x_ij, 0) is spelt as the select
// std::min is (0 < v ? 0 : v, the same value for −0 too): GCC 12 compiled std::min here to a
// branch, the select to a conditional move.
inline double artificial_viscosity(double v_dot_x, double r2, double h, double alpha, double c0,
                                   double inv_rho_mean) {
  const double approaching = 0.0 < v_dot_x ? 0.0 : v_dot_x;
  const double phi = h * approaching / (r2 + 0.01 * h * h);
  return -alpha * c0 * phi * inv_rho_mean;
}

// (σ_i/ρ_i² + σ_j/ρ_j²)·∇_iW_ij of the momentum equation (Eq. 2.45), row by row in registers:
// Eigen's product of the summed matrices goes through a stack temporary whose reload stalls
// store forwarding.
template <int D, class MatJ>
inline Vec<D> stress_divergence(const Mat<D>& si, const MatJ& sj, const Vec<D>& grad_w) {
  Vec<D> term;
  for (int r = 0; r < D; ++r) {
    double sum = (si(r, 0) + sj(r, 0)) * grad_w[0];
    for (int c = 1; c < D; ++c) sum += (si(r, c) + sj(r, c)) * grad_w[c];
    term[r] = sum;
  }
  return term;
}

// Momentum pair term of Eq. 2.45: m_j [(σ_i/ρ_i² + σ_j/ρ_j²) − Π_ij I]·∇_iW_ij.
template <int D, class MatJ>
inline Vec<D> momentum(double m_j, const Mat<D>& si, const MatJ& sj, double pi_ij, const Vec<D>& grad_w) {
  return m_j * (stress_divergence<D>(si, sj, grad_w) - pi_ij * grad_w);
}

// XSPH (Eq. 2.49): the share of χ Σ_j (m_j/ρ̄_ij)(v_j − v_i) W_ij from pair ij.
template <int D>
inline Vec<D> xsph(double chi, double m_j, double inv_rho_mean, double w_ij, const Vec<D>& v_ij) {
  return -(chi * m_j * inv_rho_mean * w_ij) * v_ij;
}

// Contact barrier between a grain and a wall particle closer than r0 (wall_barrier_reach):
// a_i = K (1 − r/r0)² x_iw/r with K = c²/h, whose largest value keeps the acceleration step bound
// √(h/|a|) at the sound-speed bound h/c (terrasph's own addition, in the spirit of Monaghan's 1994
// repulsive boundary force). Returns the factor b with a_i = b x_iw.
// The barrier's reach r0 in spacings. It must cover the holes of a wall's surface layer, through
// which a grain would pass, and stay within the contact distance Δx of a grain resting on a wall
// (so the barrier is zero in normal contact and in a settled bed). The hole is the gap between two
// particles of a row in 2D, Δx/2 from both: r0 = 0.75Δx. In 3D it is the middle of a square of
// four particles of a layer, Δx/√2 = 0.707Δx from each, where 0.75Δx leaves (1 − 0.943)² = 0.3 %
// of K and grains pushed by a plate passed through its layers (docs/sph3d.md, the slab against the
// planar scenes): r0 = Δx, the most within the contact distance.
template <int D> constexpr double wall_barrier_reach() { return D == 2 ? 0.75 : 1.0; }

inline double wall_barrier(double r, double r0, double strength) {
  const double gap = 1.0 - r / r0;
  return strength * gap * gap / r;
}

// Coulomb friction of a grain on a wall (numerics.wall_friction_coefficient μ_w), per granular–wall
// pair iw, replacing the tangential part of the pair's acceleration a_iw:
//   a_f,iw = −μ_w N_iw v_t / max(|v_t|, v_ε),   v_ε = μ_w N_i Δt,
// N_iw = max(n_w·a_iw, 0) the normal part of the pair acceleration (pushing the grain off the wall),
// N_i = Σ_w N_iw over the grain's wall pairs, v_t = v_iw − (v_iw·n_w) n_w the slip velocity.
// Sliding (|v_t| ≥ v_ε), Σ_w a_f,iw has magnitude μ_w N_i: Coulomb's kinetic friction |τ| = μ_w σ_n,
// the basal friction tan δ of granular avalanches (Savage & Hutter 1989, J. Fluid Mech. 199:177).
// Slower, it falls linearly with the slip and is at most what stops the slip within the step Δt
// (on a flat wall |Σ a_f| = min(μ_w N_i, |v_t|/Δt)), so a grain at rest is not driven and the
// explicit step never reverses the slip: the friction update of explicit contact algorithms, which
// limit the tangential impulse to μ times the normal one and to the impulse that sticks the
// surfaces (Bardenhagen et al. 2001, CMES 2(4):509, for the material point method).
template <int D>
inline Vec<D> coulomb_wall_friction(double mu, double normal, const Vec<D>& slip, double regularisation_speed) {
  const double scale = std::max(slip.norm(), regularisation_speed);
  if (!(scale > 0.0)) return Vec<D>::Zero();
  return (-mu * normal / scale) * slip;
}

}  // namespace terrasph::pair_terms
