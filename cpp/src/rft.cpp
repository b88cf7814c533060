// Resistive force theory in the plane: see terrasph/rft.hpp and the Python module terrasph.rft.
#include "terrasph/rft.hpp"

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <vector>

namespace terrasph::rft {

// The multiples of the angles by angle addition.
AlphaHat alpha_hat(const Coefficients& table, double cos2b, double sin2b, double cosg, double sing) {
  std::array<double, kMaxOrder + 1> cb{}, sb{}, cg{}, sg{};  // cos, sin of 2mβ and nγ, m, n = 0 … the table's order
  cb[0] = cg[0] = 1.0;
  for (std::size_t k = 1; k <= static_cast<std::size_t>(table.order_beta); ++k) {
    cb[k] = cb[k - 1] * cos2b - sb[k - 1] * sin2b;
    sb[k] = sb[k - 1] * cos2b + cb[k - 1] * sin2b;
  }
  for (std::size_t k = 1; k <= static_cast<std::size_t>(table.order_gamma); ++k) {
    cg[k] = cg[k - 1] * cosg - sg[k - 1] * sing;
    sg[k] = sg[k - 1] * cosg + cg[k - 1] * sing;
  }
  AlphaHat out{};
  for (const Term& t : table.terms) {
    const std::size_t m = static_cast<std::size_t>(std::abs(t.m)), n = static_cast<std::size_t>(t.n);
    const double cm = cb[m], sm = t.m < 0 ? -sb[m] : sb[m];
    const double cos_arg = cm * cg[n] - sm * sg[n], sin_arg = sm * cg[n] + cm * sg[n];  // of 2mβ + nγ
    const double rate_z = t.z_sin * cos_arg - t.z_cos * sin_arg;  // ∂/∂(2mβ + nγ)
    const double rate_x = t.x_sin * cos_arg - t.x_cos * sin_arg;
    out.az += t.z_cos * cos_arg + t.z_sin * sin_arg;
    out.ax += t.x_cos * cos_arg + t.x_sin * sin_arg;
    out.daz += t.n * rate_z;
    out.dax += t.n * rate_x;
    out.daz_dbeta += 2 * t.m * rate_z;
    out.dax_dbeta += 2 * t.m * rate_x;
  }
  return out;
}

namespace {

/// The walls of one pocket below the surface: their length L, their length times the leading weight
/// min(1, n·v / v_ε) (0 trailing) and that sum's derivative in the body's (v_x, v_z, ω).
struct PocketWalls {
  double length = 0.0, leading = 0.0;
  std::array<double, 3> d_leading{};
};

/// The grains in the pockets below the surface ride with the body where its walls lead (the SPH's
/// reversed C-leg carries the grains of its cup: docs/rft.md, "Carried grains"): each pocket adds its
/// weight (pocket_weights) times the walls' leading fraction, at the cells' lever arms.
void add_carried_grains(const std::vector<PocketWalls>& walls, const PocketWeights& weights, bool jacobian,
                        BodyLoad& load) {
  for (std::size_t p = 0; p < walls.size(); ++p) {
    if (!(walls[p].leading > 0.0)) continue;
    const double fraction = walls[p].leading / walls[p].length;
    load.fz -= fraction * weights.weight[p];
    load.torque += fraction * weights.moment[p];  // (r × F)_y = −r_x F_z
    if (!jacobian) continue;
    for (int j = 0; j < 3; ++j) {
      const double d_fraction = walls[p].d_leading[static_cast<std::size_t>(j)] / walls[p].length;
      load.jacobian[static_cast<std::size_t>(3 + j)] -= d_fraction * weights.weight[p];
      load.jacobian[static_cast<std::size_t>(6 + j)] += d_fraction * weights.moment[p];
    }
  }
}

}  // namespace

PocketWeights pocket_weights(const ElementsView& elements, const PlanarMotion& motion, double surface,
                             double unit_weight) {
  const PocketsView& pockets = elements.pockets;
  PocketWeights out{std::vector<double>(static_cast<std::size_t>(pockets.pockets), 0.0),
                    std::vector<double>(static_cast<std::size_t>(pockets.pockets), 0.0)};
  const double c = std::cos(motion.angle), s = std::sin(motion.angle);
  for (std::size_t k = 0; k < pockets.cells; ++k) {
    const double px = pockets.cell_centre[2 * k], pz = pockets.cell_centre[2 * k + 1];
    const double rx = c * px + s * pz, rz = -s * px + c * pz;
    const double size = std::sqrt(pockets.cell_area[k]);
    const double below = std::clamp((surface - motion.z - rz) / size + 0.5, 0.0, 1.0);
    if (below <= 0.0) continue;
    const double w = unit_weight * pockets.cell_area[k] * elements.width * below;
    const auto p = static_cast<std::size_t>(pockets.cell_pocket[k]);
    out.weight[p] += w;
    out.moment[p] += rx * w;
  }
  return out;
}

BodyLoad body_load(const ElementsView& elements, const PlanarMotion& motion, double surface,
                   const Coefficients& table, double regularisation, bool jacobian, const PocketWeights* weights) {
  BodyLoad load{};
  const double c = std::cos(motion.angle), s = std::sin(motion.angle);  // clockwise rotation [[c, s], [−s, c]]
  const PocketsView& pockets = elements.pockets;
  const bool carries = pockets.pockets > 0 && table.unit_weight > 0.0;
  std::vector<PocketWalls> walls(carries ? static_cast<std::size_t>(pockets.pockets) : 0);
  for (std::size_t e = 0; e < elements.count; ++e) {
    const double px = elements.centre[2 * e], pz = elements.centre[2 * e + 1];
    const double rx = c * px + s * pz, rz = -s * px + c * pz;  // the arm r from the frame origin
    const double depth = surface - rz - motion.z;
    if (!(depth > 0.0)) continue;
    const double qx = elements.normal[2 * e], qz = elements.normal[2 * e + 1];
    const double nx = c * qx + s * qz, nz = -s * qx + c * qz;
    const double vx = motion.vx + motion.omega * rz;  // v + ω (r_z, −r_x)
    const double vz = motion.vz - motion.omega * rx;
    const double normal_speed = nx * vx + nz * vz;
    PocketWalls* wall = carries && pockets.wall_pocket[e] >= 0
                            ? &walls[static_cast<std::size_t>(pockets.wall_pocket[e])] : nullptr;
    if (wall != nullptr) wall->length += elements.length[e];
    if (!(normal_speed > 0.0)) continue;  // a trailing face leaves a cavity
    const double sign = vx < 0.0 ? -1.0 : 1.0;  // a face moving backward is mirrored x → −x
    const double speed = std::sqrt(vx * vx + vz * vz);  // std::hypot costs several square roots; no overflow at m/s
    const double cosg = sign * vx / speed, sing = -vz / speed;
    const double tx = nz, tz = -sign * nx;  // the face's tangent (cos β, sin β) up to sign
    const double cos2b = tx * tx - tz * tz, sin2b = 2.0 * tx * tz;
    const AlphaHat a = alpha_hat(table, cos2b, sin2b, cosg, sing);
    const double weight = table.zeta * depth * elements.length[e] * elements.width;
    const double raw_x = -sign * a.ax * weight, raw_z = a.az * weight;  // σ ℓ w of the bare map (Li et al. Eq. 1)
    const bool ramp = regularisation > 0.0 && normal_speed < regularisation;
    const double fade = ramp ? normal_speed / regularisation : 1.0;
    const double fx = raw_x * fade, fz = raw_z * fade;
    if (wall != nullptr) {
      wall->leading += elements.length[e] * fade;
      if (ramp && jacobian) {  // ∂fade/∂ξ = Tᵀ n / v_ε, T the element's velocity map below
        wall->d_leading[0] += elements.length[e] * nx / regularisation;
        wall->d_leading[1] += elements.length[e] * nz / regularisation;
        wall->d_leading[2] += elements.length[e] * (rz * nx - rx * nz) / regularisation;
      }
    }
    load.fx += fx;
    load.fz += fz;
    load.torque += rz * fx - rx * fz;  // (r × F)_y
    if (!jacobian) continue;
    // ∂F/∂v of the element: through γ (∂γ/∂v = s (v_z, −v_x)/|v|²) and through the ramp (n / v_ε)
    const double g0 = sign * vz / (speed * speed), g1 = -sign * vx / (speed * speed);
    const double draw_x = -sign * a.dax * weight, draw_z = a.daz * weight;
    const double f0 = ramp ? nx / regularisation : 0.0, f1 = ramp ? nz / regularisation : 0.0;
    const double e00 = draw_x * g0 * fade + raw_x * f0, e01 = draw_x * g1 * fade + raw_x * f1;
    const double e10 = draw_z * g0 * fade + raw_z * f0, e11 = draw_z * g1 * fade + raw_z * f1;
    // the element's velocity is T ξ, ξ = (v_x, v_z, ω), T = [[1, 0, r_z], [0, 1, −r_x]]: J += Tᵀ E T
    const double t[2][3] = {{1.0, 0.0, rz}, {0.0, 1.0, -rx}};
    const double el[2][2] = {{e00, e01}, {e10, e11}};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        double sum = 0.0;
        for (int p = 0; p < 2; ++p)
          for (int q = 0; q < 2; ++q) sum += t[p][i] * el[p][q] * t[q][j];
        load.jacobian[static_cast<std::size_t>(3 * i + j)] += sum;
      }
    }
  }
  if (carries) {
    const bool leading = std::any_of(walls.begin(), walls.end(), [](const PocketWalls& w) { return w.leading > 0.0; });
    if (leading && weights != nullptr) add_carried_grains(walls, *weights, jacobian, load);
    if (leading && weights == nullptr)
      add_carried_grains(walls, pocket_weights(elements, motion, surface, table.unit_weight), jacobian, load);
  }
  return load;
}

}  // namespace terrasph::rft
