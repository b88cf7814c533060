// Resistive force theory in the plane (Li, Zhang & Goldman 2013, Science 339:1408): the load of a
// flat granular surface on a body's surface elements, and its derivative in the body's velocity.
// The conventions (angles β, γ, the leading-face rule, the regularisation) are those of the Python
// module terrasph.rft, which documents them and calls body_load() below.
#pragma once

#include <array>
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

AlphaHat alpha_hat(const Coefficients& table, double cos2b, double sin2b, double cosg, double sing);

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

/// The load of a flat free surface at z = `surface` on the elements at `motion` (terrasph.rft.body_load):
/// each element below it whose outward normal leads (n·v > 0) takes σ ℓ w, σ = (−s α_x, α_z) d,
/// times min(1, n·v / `regularisation`) (0: the bare map); and each pocket whose walls lead carries
/// its grains below the surface: their weight ρ0 g A w times the walls' leading fraction.
/// The weight ρ0 g A w (N) of the grains below the surface in each pocket at a pose, and its moment
/// Σ r_x ρ0 g A w (N·m) about the frame origin (a cell's share fades over its own height): they depend
/// on the pose alone, so a step whose Newton iterations keep the pose computes them once.
struct PocketWeights {
  std::vector<double> weight, moment;
};

PocketWeights pocket_weights(const ElementsView& elements, const PlanarMotion& motion, double surface,
                             double unit_weight);

/// `weights`: pocket_weights() at this pose, or nullptr to compute them here.
BodyLoad body_load(const ElementsView& elements, const PlanarMotion& motion, double surface,
                   const Coefficients& table, double regularisation, bool jacobian,
                   const PocketWeights* weights = nullptr);

}  // namespace terrasph::rft
