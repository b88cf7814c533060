// The core without Python, for the sanitizer build (CMake option TERRASPH_SANITIZE: AddressSanitizer
// and UndefinedBehaviorSanitizer): the pair terms checked against values worked out by hand, then a
// small bed with a turning leg stepped through every pass (the gather and each-pair-once variants,
// the density in either pass, XSPH, δ-SPH, wall friction, tracked loads, the active domain), with
// the grains' momentum balance checked at the end. Exit status 0 when every check holds; the
// sanitizers abort on the first memory or undefined-behaviour error. Run by .ci/run.
#include <cmath>
#include <cstdio>
#include <vector>

#include "terrasph/pair_terms.hpp"
#include "terrasph/simulation.hpp"

namespace {

using terrasph::Index;
using terrasph::Mat;
using terrasph::Vec;
using Vec2 = Vec<2>;

int failures = 0;

void check_close(double got, double expected, const char* what) {
  const double tolerance = 1e-12 * std::max(1.0, std::abs(expected));
  if (!(std::abs(got - expected) <= tolerance)) {
    std::printf("FAIL %s: %.17g, expected %.17g\n", what, got, expected);
    ++failures;
  }
}

void check(bool ok, const char* what) {
  if (!ok) {
    std::printf("FAIL %s\n", what);
    ++failures;
  }
}

// Each pair term of pair_terms.hpp on small integers and halves, the expected value worked by hand
// from the equation quoted beside the term.
void check_pair_terms() {
  namespace term = terrasph::pair_terms;
  // m_j v_ij·∇W = 2 (1·3 − 1·0.5) = 5
  check_close(term::continuity<2>(2.0, Vec2(1.0, -1.0), Vec2(3.0, 0.5)), 5.0, "continuity");
  // 2 δhc0 Δρ (−F) V_j = 2·0.1·2·4·0.5 = 0.8
  check_close(term::density_diffusion(0.1, 2.0, 0.5, -4.0), 0.8, "density diffusion");
  // receding pair: no viscosity; approaching, φ = h v·x/(r² + 0.01h²) = −0.5/1.0025, Π = −α c0 φ/ρ̄
  check_close(term::artificial_viscosity(1.0, 1.0, 0.5, 0.1, 10.0, 0.5), 0.0, "viscosity, receding");
  check_close(term::artificial_viscosity(-1.0, 1.0, 0.5, 0.1, 10.0, 0.5), 0.25 / 1.0025, "viscosity, approaching");
  // m_j [(σ_i/ρ_i² + σ_j/ρ_j²) − Π I]·∇W = 3 ([[1,1],[1,2]]·(1,2) − 0.5 (1,2)) = (7.5, 12)
  Mat<2> si, sj;
  si << 1.0, 0.0, 0.0, 2.0;
  sj << 0.0, 1.0, 1.0, 0.0;
  const Vec2 momentum = term::momentum<2>(3.0, si, sj, 0.5, Vec2(1.0, 2.0));
  check_close(momentum[0], 7.5, "momentum x");
  check_close(momentum[1], 12.0, "momentum z");
  // −χ m_j W/ρ̄ v_ij = −(0.5·2·0.25·4) (1, 2)
  const Vec2 xsph = term::xsph<2>(0.5, 2.0, 0.25, 4.0, Vec2(1.0, 2.0));
  check_close(xsph[0], -1.0, "xsph x");
  check_close(xsph[1], -2.0, "xsph z");
  // K (1 − r/r0)²/r = 8·0.25/0.5
  check_close(term::wall_barrier(0.5, 1.0, 8.0), 4.0, "wall barrier");
  // sliding: −μN v_t/|v_t| = −0.5·2·(3,4)/5; slow (v_ε = 10 > |v_t|): −μN v_t/v_ε; no slip: nothing
  const Vec2 sliding = term::coulomb_wall_friction<2>(0.5, 2.0, Vec2(3.0, 4.0), 1.0);
  check_close(sliding[0], -0.6, "friction sliding x");
  check_close(sliding[1], -0.8, "friction sliding z");
  const Vec2 slow = term::coulomb_wall_friction<2>(0.5, 2.0, Vec2(3.0, 4.0), 10.0);
  check_close(slow[0], -0.3, "friction slow x");
  check_close(slow[1], -0.4, "friction slow z");
  check(term::coulomb_wall_friction<2>(0.5, 2.0, Vec2::Zero(), 0.0).isZero(), "friction without slip or normal load");
}

struct Layout {
  std::vector<Vec2> grains;
  std::vector<Vec2> walls, normals;
  std::vector<std::int32_t> groups;
};

constexpr std::int32_t box_group = 0;
constexpr std::int32_t leg_group = 1;

// A bed 40 × 12 grains in a box of three wall layers, and a leg (a bar two particles thick)
// standing in it, the grains it displaces left out.
Layout bed_with_leg(double dx) {
  Layout layout;
  constexpr int columns = 40, rows = 12, layers = 3;
  const double leg_x = 20.0 * dx;
  auto in_leg = [&](const Vec2& x) { return std::abs(x[0] - leg_x) < 1.5 * dx && x[1] > 6.0 * dx; };
  for (int k = 0; k < rows; ++k)
    for (int i = 0; i < columns; ++i) {
      const Vec2 x((i + 0.5) * dx, (k + 0.5) * dx);
      if (!in_leg(x)) layout.grains.push_back(x);
    }
  auto add_wall = [&](const Vec2& x, const Vec2& n, std::int32_t group) {
    layout.walls.push_back(x);
    layout.normals.push_back(n);
    layout.groups.push_back(group);
  };
  for (int l = 0; l < layers; ++l) {
    for (int i = -layers; i < columns + layers; ++i) add_wall(Vec2((i + 0.5) * dx, -(l + 0.5) * dx), Vec2(0, 1), box_group);
    for (int k = 0; k < 2 * rows; ++k) {
      add_wall(Vec2(-(l + 0.5) * dx, (k + 0.5) * dx), Vec2(1, 0), box_group);
      add_wall(Vec2((columns + l + 0.5) * dx, (k + 0.5) * dx), Vec2(-1, 0), box_group);
    }
  }
  for (int k = 7; k < 2 * rows; ++k) {
    add_wall(Vec2(leg_x - 0.5 * dx, (k + 0.5) * dx), Vec2(-1, 0), leg_group);
    add_wall(Vec2(leg_x + 0.5 * dx, (k + 0.5) * dx), Vec2(1, 0), leg_group);
  }
  return layout;
}

terrasph::Simulation<2> make_simulation(const terrasph::ModelParams<2>& params, const Layout& layout) {
  const double rho0 = params.material.reference_density;
  const double mass = rho0 * params.numerics.spacing * params.numerics.spacing;
  terrasph::GranularParticles<2> grains;
  grains.resize(static_cast<Index>(layout.grains.size()));
  for (Index i = 0; i < grains.size(); ++i) {
    grains.id[i] = i;
    terrasph::row_vec<2>(grains.position, i) = layout.grains[static_cast<std::size_t>(i)];
    grains.density[i] = rho0;
    grains.mass[i] = mass;
  }
  terrasph::WallParticles<2> walls;
  walls.resize(static_cast<Index>(layout.walls.size()));
  for (Index w = 0; w < walls.size(); ++w) {
    const auto k = static_cast<std::size_t>(w);
    walls.id[w] = w;
    terrasph::row_vec<2>(walls.position, w) = layout.walls[k];
    terrasph::row_vec<2>(walls.normal, w) = layout.normals[k];
    walls.mass[w] = mass;
    walls.density[w] = rho0;
    walls.no_slip[w] = 1;
    walls.group[w] = layout.groups[k];
    walls.body[w] = -1;
  }
  return terrasph::Simulation<2>(params, std::move(grains), std::move(walls));
}

terrasph::ModelParams<2> scene_params() {
  terrasph::ModelParams<2> params;
  params.domain.lower = Vec2(-0.05, -0.05);
  params.domain.upper = Vec2(0.15, 0.15);
  params.domain.gravity = Vec2(0.0, -9.81);
  return params;
}

// The leg turns and moves sideways into the bed (a prescribed motion).
void add_leg(terrasph::Simulation<2>& sim, double dx) {
  terrasph::MotionSegment<2> turn;
  turn.duration = 1.0;
  turn.velocity = Vec2(0.05, 0.0);
  turn.angular_velocity = 2.0;
  sim.add_body(leg_group, Vec2(20.0 * dx, 24.0 * dx), 0.0, {turn});
}

constexpr std::int64_t steps = 50;

// Gather passes, density kicked, wall friction, every wall's load kept: after the steps the
// grains' momentum balances the weight and the loads they put on the walls and the leg (Eq.
// 3.24–3.25), Σ m_i a_i = M g − F_leg − F_box, up to the rounding of the pair sums (the granular
// pairs cancel in exact arithmetic, Newton's third law of Eq. 2.45's symmetric form).
void run_gather_scene() {
  terrasph::ModelParams<2> params = scene_params();
  params.numerics.wall_friction_coefficient = 0.4;
  const double dx = params.numerics.spacing;
  terrasph::Simulation<2> sim = make_simulation(params, bed_with_leg(dx));
  add_leg(sim, dx);
  sim.track_wall_loads(Vec2::Zero());
  check(sim.advance(1.0, steps) == steps, "gather scene: every step taken");
  const auto& g = sim.granular();
  Vec2 momentum_rate = Vec2::Zero(), weight = Vec2::Zero();
  for (Index i = 0; i < g.size(); ++i) {
    momentum_rate += g.mass[i] * terrasph::row_vec<2>(g.acceleration, i);
    weight += g.mass[i] * params.domain.gravity;
  }
  Vec2 loads = sim.bodies()[0].force;
  for (const auto& load : sim.wall_loads()) loads += load.force;
  const Vec2 imbalance = momentum_rate - (weight - loads);
  check(imbalance.norm() <= 1e-9 * weight.norm(), "gather scene: momentum balance");
  check(sim.bodies()[0].force.norm() > 0.0, "gather scene: the leg carries a load");
  std::printf("gather scene: %lld steps, t = %.4g s, imbalance %.3g of the weight\n",
              static_cast<long long>(sim.counters().step), sim.counters().time, imbalance.norm() / weight.norm());
}

// Each pair once in cell order, the density advanced in the ∇v pass, the hypoelastic stress and
// the active domain about the leg: the code paths the gather scene does not take.
void run_pairs_once_scene() {
  terrasph::ModelParams<2> params = scene_params();
  params.numerics.symmetric_pairs = true;
  params.numerics.cell_order = true;
  params.numerics.symplectic_density = true;
  params.numerics.freeze_speed = 0.05;
  params.numerics.freeze_steps = 5;
  params.numerics.active_radius = 0.02;
  params.numerics.shepard_interval = 7;
  const double dx = params.numerics.spacing;
  terrasph::Simulation<2> sim = make_simulation(params, bed_with_leg(dx));
  add_leg(sim, dx);
  check(sim.advance(1.0, steps) == steps, "pairs-once scene: every step taken");
  std::printf("pairs-once scene: %lld steps, t = %.4g s\n", static_cast<long long>(sim.counters().step),
              sim.counters().time);
}

}  // namespace

int main() {
  check_pair_terms();
  try {
    run_gather_scene();
    run_pairs_once_scene();
  } catch (const std::exception& e) {
    std::printf("FAIL %s\n", e.what());
    ++failures;
  }
  std::printf("%s (%d failed checks)\n", failures == 0 ? "OK" : "FAILED", failures);
  return failures == 0 ? 0 : 1;
}
