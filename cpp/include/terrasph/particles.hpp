// Particle state as structure-of-arrays. Granular particles evolve; wall particles are the
// fixed ghost (dummy) layers whose state is extrapolated from the granular phase each step.
#pragma once

#include <cstdint>
#include <vector>

#include "terrasph/math.hpp"

namespace terrasph {

template <int D> struct GranularParticles {
  VecArray<D> position;
  VecArray<D> velocity;
  VecArray<D> acceleration;        // Dv/Dt of the last rate evaluation
  VecArray<D> xsph_correction;     // χ Σ ... of Eq. 2.49; allocated only when XSPH is on
  ScalarArray density;
  ScalarArray density_rate;        // Dρ/Dt of the last rate evaluation
  ScalarArray pressure;
  ScalarArray mass;                // per unit depth in 2D: ρ·Δx²
  ScalarArray volume;              // V = m/ρ, refreshed before each rate evaluation
  MatArray<D> stress;              // Cauchy stress σ
  MatArray<D> stress_over_rho2;    // σ/ρ², cached for the momentum sum
  MatArray<D> velocity_gradient;   // L = ∇v (Eq. 2.48)
  MatArray<D> deviatoric_stress;   // s, state of the elastic quasi-static branch; else empty

  Index size() const { return position.rows(); }

  void resize(Index n, bool with_xsph, bool with_stress_state) {
    position.resize(n, D);
    velocity.setZero(n, D);
    acceleration.setZero(n, D);
    if (with_xsph) xsph_correction.setZero(n, D); else xsph_correction.resize(0, D);
    density.resize(n);
    density_rate.setZero(n);
    pressure.setZero(n);
    mass.resize(n);
    volume.resize(n);
    stress.setZero(n, D * D);
    stress_over_rho2.setZero(n, D * D);
    velocity_gradient.setZero(n, D * D);
    if (with_stress_state) deviatoric_stress.setZero(n, D * D); else deviatoric_stress.resize(0, D * D);
  }
};

template <int D> struct WallParticles {
  VecArray<D> position;
  VecArray<D> velocity;       // the wall's own (prescribed) velocity; zero for fixed walls
  VecArray<D> acceleration;   // a_w of Eq. 3.31
  VecArray<D> ghost_velocity; // velocity seen by ∇v: 2v_w − ṽ (no-slip) or ṽ (free-slip)
  VecArray<D> normal;         // unit normal of the wall surface, pointing into the granular side
  ScalarArray density;        // from the inverse EOS of the extrapolated pressure (Eq. 3.32)
  ScalarArray mass;           // ρ0·Δx^D
  MatArray<D> stress;         // extrapolated stress (Eq. 3.31 applied to σ)
  MatArray<D> stress_over_rho2;
  std::vector<std::uint8_t> no_slip;  // 1: rough wall (shear transmitted), 0: smooth
  std::vector<std::int32_t> group;    // wall group, e.g. floor, gate, body
  std::vector<std::int32_t> body;     // index of the rigid body it belongs to, −1 for a fixed wall
  std::vector<std::uint8_t> interior; // 1: a layer or more inside its wall (not on the surface row)
  VecArray<D> body_offset;            // position in the body frame (relative to its reference point)
  VecArray<D> body_normal;            // normal in the body frame

  Index size() const { return position.rows(); }

  void resize(Index n) {
    position.resize(n, D);
    velocity.setZero(n, D);
    acceleration.setZero(n, D);
    ghost_velocity.setZero(n, D);
    normal.setZero(n, D);
    density.resize(n);
    mass.resize(n);
    stress.setZero(n, D * D);
    stress_over_rho2.setZero(n, D * D);
    no_slip.assign(static_cast<size_t>(n), 1);
    group.assign(static_cast<size_t>(n), 0);
    body.assign(static_cast<size_t>(n), -1);
    interior.assign(static_cast<size_t>(n), 0);
    body_offset.setZero(n, D);
    body_normal.setZero(n, D);
  }
};

}  // namespace terrasph
