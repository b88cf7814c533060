// Resistive force theory in the plane (Li, Zhang & Goldman 2013, Science 339:1408): the load of a
// flat granular surface on a body's surface elements, and its derivative in the body's velocity.
// The conventions (angles β, γ, the leading-face rule, the regularisation) are those of the Python
// module terrasph.rft, which documents them and calls body_load() below.
#pragma once

#include <array>
#include <cstddef>

namespace terrasph::rft {

/// α = ζ α̂(β, γ): Li et al.'s nine Fourier coefficients (A00, A10, B11, B01, B−11, C11, C01, C−11,
/// D10; dimensionless, α̂_z(0, π/2) = 1) and the scale ζ (N/m³).
struct Coefficients {
  std::array<double, 9> c{};
  double zeta = 0.0;
};

/// α̂_x, α̂_z and their derivatives in γ (Li et al. 2013, supplementary Eq. S2, with the sums of
/// angles expanded: sin(2β ± γ) = sin 2β cos γ ± cos 2β sin γ, ...).
struct AlphaHat {
  double ax, az, dax, daz;
};

inline AlphaHat alpha_hat(const std::array<double, 9>& k, double cos2b, double sin2b, double cosg, double sing) {
  const double a00 = k[0], a10 = k[1], b11 = k[2], b01 = k[3], bm11 = k[4];
  const double c11 = k[5], c01 = k[6], cm11 = k[7], d10 = k[8];
  AlphaHat out{};
  out.az = a00 + a10 * cos2b + (b11 - bm11) * sin2b * cosg + (b11 + bm11) * cos2b * sing + b01 * sing;
  out.daz = -(b11 - bm11) * sin2b * sing + (b11 + bm11) * cos2b * cosg + b01 * cosg;
  out.ax = (c11 + cm11) * cos2b * cosg + (cm11 - c11) * sin2b * sing + c01 * cosg + d10 * sin2b;
  out.dax = -(c11 + cm11) * cos2b * sing + (cm11 - c11) * sin2b * cosg - c01 * sing;
  return out;
}

/// A body's surface elements in its own frame, borrowed (the owner keeps the arrays alive):
/// `centre` and `normal` are (count, 2) row-major (x, z), `length` (count,), all in m.
struct ElementsView {
  const double* centre = nullptr;
  const double* normal = nullptr;
  const double* length = nullptr;
  std::size_t count = 0;
  double width = 0.0;  ///< out-of-plane width (m)
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
/// times min(1, n·v / `regularisation`) (0: the bare map).
BodyLoad body_load(const ElementsView& elements, const PlanarMotion& motion, double surface,
                   const Coefficients& table, double regularisation, bool jacobian);

}  // namespace terrasph::rft
