// Resistive force theory in the plane: see terrasph/rft.hpp and the Python module terrasph.rft.
#include "terrasph/rft.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace terrasph::rft {

namespace {

/// The walls of one pocket below the surface: their length times the leading weight min(1, n·v / v_ε)
/// (0 trailing) and that sum's derivative in the body's (v_x, v_z, ω).
struct PocketWalls {
  double leading = 0.0;
  std::array<double, 3> d_leading{};
};

/// The grains in the pockets below the surface ride with the body where its walls lead (the SPH's
/// reversed C-leg carries the grains of its cup: docs/rft.md, "Carried grains"): each pocket adds its
/// weight times the walls' leading fraction, at the cells' lever arms.
void add_carried_grains(const std::vector<PocketWalls>& walls, const Immersion& immersion, bool jacobian,
                        BodyLoad& load) {
  for (std::size_t p = 0; p < walls.size(); ++p) {
    if (!(walls[p].leading > 0.0)) continue;
    const double length = immersion.wall_length[p], weight = immersion.pocket_weight[p];
    const double moment = immersion.pocket_moment[p];
    const double fraction = walls[p].leading / length;
    load.fz -= fraction * weight;
    load.torque += fraction * moment;  // (r × F)_y = −r_x F_z
    if (!jacobian) continue;
    for (int j = 0; j < 3; ++j) {
      const double d_fraction = walls[p].d_leading[static_cast<std::size_t>(j)] / length;
      load.jacobian[static_cast<std::size_t>(3 + j)] -= d_fraction * weight;
      load.jacobian[static_cast<std::size_t>(6 + j)] += d_fraction * moment;
    }
  }
}

/// Each pocket's grains below the surface: ρ0 g A w per cell times the fraction of the cell's own
/// height below it, and their moment about the frame origin.
void weigh_pockets(const ElementsView& elements, double c, double s, const PlanarMotion& pose, double surface,
                   double unit_weight, Immersion& out) {
  const PocketsView& pockets = elements.pockets;
  if (pockets.cells == 0) return;
  // a cell whose centre lies half the largest cell's height above the surface holds none below it
  const double reach = 0.5 * std::sqrt(*std::max_element(pockets.cell_area, pockets.cell_area + pockets.cells));
  for (std::size_t k = 0; k < pockets.cells; ++k) {
    const double px = pockets.cell_centre[2 * k], pz = pockets.cell_centre[2 * k + 1];
    const double rx = c * px + s * pz, rz = -s * px + c * pz;
    if (surface - pose.z - rz <= -reach) continue;
    const double size = std::sqrt(pockets.cell_area[k]);
    const double below = std::clamp((surface - pose.z - rz) / size + 0.5, 0.0, 1.0);
    if (below <= 0.0) continue;
    const double w = unit_weight * pockets.cell_area[k] * elements.width * below;
    const auto p = static_cast<std::size_t>(pockets.cell_pocket[k]);
    out.pocket_weight[p] += w;
    out.pocket_moment[p] += rx * w;
  }
}

}  // namespace

void immerse(const ElementsView& elements, const PlanarMotion& pose, double surface, const Coefficients& table,
             Immersion& out) {
  const double c = std::cos(pose.angle), s = std::sin(pose.angle);  // clockwise rotation [[c, s], [−s, c]]
  const PocketsView& pockets = elements.pockets;
  const bool carries = pockets.pockets > 0 && table.unit_weight > 0.0;
  const std::size_t pocket_count = carries ? static_cast<std::size_t>(pockets.pockets) : 0;
  out.elements.clear();
  out.wall_length.assign(pocket_count, 0.0);
  out.pocket_weight.assign(pocket_count, 0.0);
  out.pocket_moment.assign(pocket_count, 0.0);
  for (std::size_t e = 0; e < elements.count; ++e) {
    const double px = elements.centre[2 * e], pz = elements.centre[2 * e + 1];
    const double rx = c * px + s * pz, rz = -s * px + c * pz;  // the arm r from the frame origin
    const double depth = surface - rz - pose.z;
    if (!(depth > 0.0)) continue;
    const double qx = elements.normal[2 * e], qz = elements.normal[2 * e + 1];
    const double nx = c * qx + s * qz, nz = -s * qx + c * qz;
    const int pocket = carries ? pockets.wall_pocket[e] : -1;
    if (pocket >= 0) out.wall_length[static_cast<std::size_t>(pocket)] += elements.length[e];
    out.elements.push_back({rx, rz, nx, nz, table.zeta * depth * elements.length[e] * elements.width,
                            elements.length[e], pocket});
  }
  if (carries) weigh_pockets(elements, c, s, pose, surface, table.unit_weight, out);
}

BodyLoad body_load(const Immersion& immersion, const PlanarMotion& motion, const Coefficients& table,
                   double regularisation, bool jacobian) {
  BodyLoad load{};
  std::vector<PocketWalls> walls(immersion.wall_length.size());
  for (const Immersion::Element& element : immersion.elements) {
    const double rx = element.rx, rz = element.rz, nx = element.nx, nz = element.nz;
    const double vx = motion.vx + motion.omega * rz;  // v + ω (r_z, −r_x)
    const double vz = motion.vz - motion.omega * rx;
    const double normal_speed = nx * vx + nz * vz;
    if (!(normal_speed > 0.0)) continue;  // a trailing face leaves a cavity
    const double sign = vx < 0.0 ? -1.0 : 1.0;  // a face moving backward is mirrored x → −x
    const double inv_speed = 1.0 / std::sqrt(vx * vx + vz * vz);  // no overflow guard (std::hypot's) needed at m/s
    const double cosg = sign * vx * inv_speed, sing = -vz * inv_speed;
    const double tx = nz, tz = -sign * nx;  // the face's tangent (cos β, sin β) up to sign
    const double cos2b = tx * tx - tz * tz, sin2b = 2.0 * tx * tz;
    const AlphaHat a = alpha_hat(table, cos2b, sin2b, cosg, sing);
    const double weight = element.scaled_depth;
    const double raw_x = -sign * a.ax * weight, raw_z = a.az * weight;  // σ ℓ w of the bare map (Li et al. Eq. 1)
    const bool ramp = regularisation > 0.0 && normal_speed < regularisation;
    const double fade = ramp ? normal_speed / regularisation : 1.0;
    const double fx = raw_x * fade, fz = raw_z * fade;
    if (element.pocket >= 0) {
      PocketWalls& wall = walls[static_cast<std::size_t>(element.pocket)];
      wall.leading += element.length * fade;
      if (ramp && jacobian) {  // ∂fade/∂ξ = Tᵀ n / v_ε, T the element's velocity map below
        wall.d_leading[0] += element.length * nx / regularisation;
        wall.d_leading[1] += element.length * nz / regularisation;
        wall.d_leading[2] += element.length * (rz * nx - rx * nz) / regularisation;
      }
    }
    load.fx += fx;
    load.fz += fz;
    load.torque += rz * fx - rx * fz;  // (r × F)_y
    if (!jacobian) continue;
    // ∂F/∂v of the element: through γ (∂γ/∂v = s (v_z, −v_x)/|v|²) and through the ramp (n / v_ε)
    const double g0 = sign * vz * inv_speed * inv_speed, g1 = -sign * vx * inv_speed * inv_speed;
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
  add_carried_grains(walls, immersion, jacobian, load);
  return load;
}

BodyLoad body_load(const ElementsView& elements, const PlanarMotion& motion, double surface,
                   const Coefficients& table, double regularisation, bool jacobian) {
  Immersion immersion;
  immerse(elements, motion, surface, table, immersion);
  return body_load(immersion, motion, table, regularisation, jacobian);
}

}  // namespace terrasph::rft
