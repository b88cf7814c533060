// The two particle sets of a simulation. Granular particles evolve; wall particles are the fixed
// ghost (dummy) layers whose state is extrapolated from the granular phase each step. Each set
// keeps its arrays in a FieldRegistry: the fields every step needs are registered here and bound
// to named references; optional modules (XSPH, a constitutive model's state, rigid bodies)
// register theirs when they are switched on. Every particle carries a stable id; the storage
// order is the core's business and may change (a permutation gathers every registered field).
#pragma once

#include "terrasph/fields.hpp"
#include "terrasph/math.hpp"

namespace terrasph {

template <int D> struct GranularParticles {
  FieldRegistry fields;  // first: the references below point into it
  IdArray& id;
  VecArray<D>& position;
  VecArray<D>& velocity;
  VecArray<D>& acceleration;       // Dv/Dt of the last rate evaluation
  ScalarArray& density;
  ScalarArray& density_rate;       // Dρ/Dt of the last rate evaluation
  ScalarArray& pressure;
  ScalarArray& mass;               // per unit depth in 2D: ρ·Δx²
  ScalarArray& volume;             // V = m/ρ, refreshed before each rate evaluation
  MatArray<D>& stress;             // Cauchy stress σ (in-plane components)
  MatArray<D>& stress_over_rho2;   // σ/ρ², cached for the momentum sum
  MatArray<D>& velocity_gradient;  // L = ∇v (Eq. 2.48)
  VecArray<D>& position_at_build;  // positions the neighbour lists were built at
  FlagArray& penetrated;           // 1 once the particle got past a wall's surface row (leak counter)

  GranularParticles()
      : id(fields.add<std::int64_t, 1>("id", "", "stable particle id")),
        position(fields.add<double, D>("position", "m", "position")),
        velocity(fields.add<double, D>("velocity", "m/s", "velocity")),
        acceleration(fields.add<double, D>("acceleration", "m/s2", "Dv/Dt of the last rate evaluation")),
        density(fields.add<double, 1>("density", "kg/m3", "density")),
        density_rate(fields.add<double, 1>("density_rate", "kg/m3/s", "Drho/Dt of the last rate evaluation")),
        pressure(fields.add<double, 1>("pressure", "Pa", "pressure from the equation of state")),
        mass(fields.add<double, 1>("mass", "kg/m^(3-D)", "mass (per metre of depth in 2D)")),
        volume(fields.add<double, 1>("volume", "m^D", "m/rho at the last rate evaluation")),
        stress(fields.add<double, D * D>("stress", "Pa", "Cauchy stress")),
        stress_over_rho2(fields.add<double, D * D>("stress_over_rho2", "Pa m6/kg2", "stress/rho^2")),
        velocity_gradient(fields.add<double, D * D>("velocity_gradient", "1/s", "grad v (Eq. 2.48)")),
        position_at_build(fields.add<double, D>("position_at_build", "m", "position at the last neighbour build")),
        penetrated(fields.add<std::uint8_t, 1>("penetrated", "", "1 once past a wall's surface row")) {}
  GranularParticles(GranularParticles&&) = default;

  Index size() const { return fields.size(); }
  void resize(Index n) { fields.resize(n); }
};

template <int D> struct WallParticles {
  FieldRegistry fields;
  IdArray& id;
  VecArray<D>& position;
  VecArray<D>& velocity;        // the wall's own (prescribed) velocity; zero for fixed walls
  VecArray<D>& acceleration;    // a_w of Eq. 3.31
  VecArray<D>& ghost_velocity;  // velocity seen by ∇v: 2v_w − ṽ (no-slip) or ṽ (free-slip)
  VecArray<D>& normal;          // unit normal of the wall surface, pointing into the granular side
  ScalarArray& density;         // from the inverse EOS of the extrapolated pressure (Eq. 3.32)
  ScalarArray& mass;            // ρ0·Δx^D
  MatArray<D>& stress;          // extrapolated stress (Eq. 3.31 applied to σ)
  MatArray<D>& stress_over_rho2;
  FlagArray& no_slip;           // 1: rough wall (shear transmitted), 0: smooth
  Int32Array& group;            // wall group, e.g. floor, gate, body
  Int32Array& body;             // index of the rigid body it belongs to, −1 for a fixed wall
  FlagArray& interior;          // 1: a layer or more inside its wall (not on the surface row)
  VecArray<D>& position_at_build;

  WallParticles()
      : id(fields.add<std::int64_t, 1>("id", "", "stable wall particle id")),
        position(fields.add<double, D>("position", "m", "position")),
        velocity(fields.add<double, D>("velocity", "m/s", "the wall's own velocity")),
        acceleration(fields.add<double, D>("acceleration", "m/s2", "the wall's own acceleration")),
        ghost_velocity(fields.add<double, D>("ghost_velocity", "m/s", "velocity seen by grad v")),
        normal(fields.add<double, D>("normal", "", "unit normal into the granular side")),
        density(fields.add<double, 1>("density", "kg/m3", "density from the inverse EOS")),
        mass(fields.add<double, 1>("mass", "kg/m^(3-D)", "mass (per metre of depth in 2D)")),
        stress(fields.add<double, D * D>("stress", "Pa", "extrapolated stress (Eq. 3.31)")),
        stress_over_rho2(fields.add<double, D * D>("stress_over_rho2", "Pa m6/kg2", "stress/rho^2")),
        no_slip(fields.add<std::uint8_t, 1>("no_slip", "", "1: rough wall, 0: smooth")),
        group(fields.add<std::int32_t, 1>("group", "", "wall group")),
        body(fields.add<std::int32_t, 1>("body", "", "rigid body index, -1 for a fixed wall")),
        interior(fields.add<std::uint8_t, 1>("interior", "", "1: a layer or more inside its wall")),
        position_at_build(fields.add<double, D>("position_at_build", "m", "position at the last neighbour build")) {}
  WallParticles(WallParticles&&) = default;

  Index size() const { return fields.size(); }
  void resize(Index n) { fields.resize(n); }
};

}  // namespace terrasph
