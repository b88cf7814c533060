// Resistive force theory in the plane (Li, Zhang & Goldman 2013, Science 339:1408): the load of a
// flat granular surface on a body's surface elements, and its derivative in the body's velocity.
// The conventions (angles β, γ, the leading-face rule, the regularisation) are those of the Python
// module terrasph.rft, which documents them and calls body_load() below.
#pragma once

#include <array>
#include <cstdlib>
#include <cstddef>
#include <vector>

namespace terrasph::rft {

/// The largest multiple m of 2β and n of γ a map's series may hold.
constexpr int kMaxOrder = 4;

/// The terms of the map's Fourier series (terrasph.rft) of one multiple (m, n): α̂_z gets z_cos cos
/// + z_sin sin(2mβ + nγ), α̂_x x_cos cos + x_sin sin (the letters A, B, C, D of one multiple share its
/// angle). Li et al.'s nine coefficients are the terms with |m| ≤ 1, n ≤ 1.
struct Term {
  int m = 0, n = 0;  ///< |m|, n ≤ kMaxOrder (checked by the caller)
  double z_cos = 0.0, z_sin = 0.0, x_cos = 0.0, x_sin = 0.0;
};

/// α = ζ α̂(β, γ): the series' terms (dimensionless, α̂_z(0, π/2) = 1) and the scale ζ (N/m³); the
/// medium's unit weight ρ0 g (N/m³), with which the grains a body carries in its pockets load it.
struct Coefficients {
  std::vector<Term> terms;
  double zeta = 0.0;
  double unit_weight = 0.0;
  int order_beta = kMaxOrder, order_gamma = kMaxOrder;  ///< the largest |m|, n of the terms (≤ kMaxOrder)
};

/// α̂_x, α̂_z and their derivatives in γ (dax, daz) and in β (dax_dbeta, daz_dbeta) of a map: Σ value ·
/// cos or sin(2mβ + nγ) over its terms (Li et al. 2013, supplementary Eq. S2, extended to higher
/// orders), from cos 2β, sin 2β, cos γ, sin γ.
struct AlphaHat {
  double ax, az, dax, daz, dax_dbeta, daz_dbeta;
};

/// The multiples of the angles by angle addition; inline: the loads' innermost loop.
inline AlphaHat alpha_hat(const Coefficients& table, double cos2b, double sin2b, double cosg, double sing) {
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

/// A body's pockets, borrowed: the regions between its outline and its convex hull (terrasph.rft.
/// SurfaceElements), as cells of `cell_area` (m²) at `cell_centre` ((cells, 2), own frame, m), each
/// in pocket `cell_pocket` (0 … pockets − 1); `wall_pocket` (one per element) is the pocket an element
/// faces, or −1. No pockets: cells = pockets = 0.
struct PocketsView {
  const int* wall_pocket = nullptr;
  const double* cell_centre = nullptr;
  const double* cell_area = nullptr;
  const int* cell_pocket = nullptr;
  std::size_t cells = 0;
  int pockets = 0;
};

/// A body's surface elements in its own frame, borrowed (the owner keeps the arrays alive):
/// `centre` and `normal` are (count, 2) row-major (x, z), `length` (count,), all in m.
struct ElementsView {
  const double* centre = nullptr;
  const double* normal = nullptr;
  const double* length = nullptr;
  std::size_t count = 0;
  double width = 0.0;  ///< out-of-plane width (m)
  PocketsView pockets{};
};

/// A body's pose and motion in the x–z plane: clockwise `angle` (rad), frame origin (x, z) (m), its
/// velocity (v_x, v_z) (m/s) and clockwise spin ω (rad/s).
struct PlanarMotion {
  double angle = 0.0, x = 0.0, z = 0.0, vx = 0.0, vz = 0.0, omega = 0.0;
};

/// The RFT load: force (F_x, F_z) N, clockwise torque N·m about the frame origin and, if asked
/// for, ∂(F_x, F_z, τ)/∂(v_x, v_z, ω) (row-major 3 × 3, SI units) at fixed pose.
struct BodyLoad {
  double fx = 0.0, fz = 0.0, torque = 0.0;
  std::array<double, 9> jacobian{};
};

/// What of a body's load depends on its pose alone, found once per pose (a step's Newton iterations
/// keep the pose and change the velocities only; MuJoCo's position stage before its velocity stage):
/// the elements below a flat free surface, each with its arm r (m) from the frame origin, outward
/// normal n, ζ d ℓ w (N/m: the map's scale times depth, length and width) and the pocket it faces
/// (−1: none, or the grains are not carried); per pocket, its walls' length below the surface (m) and
/// the weight ρ0 g A w (N) of its grains below the surface with their moment Σ r_x ρ0 g A w (N·m) about
/// the frame origin (a cell's share fades over its own height).
struct Immersion {
  struct Element {
    double rx, rz, nx, nz, scaled_depth, length;
    int pocket;
  };
  std::vector<Element> elements;
  std::vector<double> wall_length, pocket_weight, pocket_moment;
};

/// Fills `out` (its storage reused) for the elements at `pose` (its velocities unused) under the
/// surface at z = `surface`; the grains are carried if the body has pockets and `table.unit_weight` > 0.
void immerse(const ElementsView& elements, const PlanarMotion& pose, double surface, const Coefficients& table,
             Immersion& out);

/// The load of the surface on an immersed body moving at `motion` (its pose that of the immersion;
/// terrasph.rft.body_load): each element whose outward normal leads (n·v > 0) takes σ ℓ w,
/// σ = (−s α_x, α_z) d, times min(1, n·v / `regularisation`) (0: the bare map); and each pocket whose
/// walls lead carries its grains below the surface: their weight times the walls' leading fraction.
BodyLoad body_load(const Immersion& immersion, const PlanarMotion& motion, const Coefficients& table,
                   double regularisation, bool jacobian);

/// Both stages at once: immerse() at `motion`'s pose, then body_load().
BodyLoad body_load(const ElementsView& elements, const PlanarMotion& motion, double surface,
                   const Coefficients& table, double regularisation, bool jacobian);

}  // namespace terrasph::rft
