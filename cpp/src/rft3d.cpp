// Resistive force theory in 3D: see terrasph/rft3d.hpp and the Python module terrasph.rft3d, whose
// docstring gives the law (after Treers, Cao & Stuart 2021, IEEE RA-L 6:1887).
#include "terrasph/rft3d.hpp"

#include <algorithm>
#include <cmath>

namespace terrasph::rft {

namespace {

constexpr Vec3 kUp{0.0, 0.0, 1.0};

/// The planar law (rft.cpp, Li et al. 2013 Eq. 1) in the vertical plane of the unit horizontal
/// direction d: P = P_r d + P_z ẑ before the blends and the ramp, and, for the Jacobian, its
/// derivatives in (v_r, v_z) = (v·d, v_z) at fixed d and in n_r = n·d.
struct PlaneLoad {
  double fr = 0.0, fz = 0.0;
  double dr_dvr = 0.0, dr_dvz = 0.0, dz_dvr = 0.0, dz_dvz = 0.0;
  double dr_dnr = 0.0, dz_dnr = 0.0;
  Vec3 vector(const Vec3& d) const { return {fr * d[0] + fz * kUp[0], fr * d[1] + fz * kUp[1], fr * d[2] + fz * kUp[2]}; }
};

PlaneLoad plane_load(const Vec3& d, const Vec3& n, const Vec3& v, double weight, const Coefficients& table,
                     bool jacobian) {
  PlaneLoad p;
  const double n_r = n[0] * d[0] + n[1] * d[1] + n[2] * d[2], n_z = n[2];
  const double v_r = v[0] * d[0] + v[1] * d[1] + v[2] * d[2], v_z = v[2];
  const double facing = std::hypot(n_r, n_z);  // |(n_r, n_z)|: the area's share facing the plane of motion
  const double speed = std::hypot(v_r, v_z);
  if (!(facing > 0.0 && speed > 0.0)) return p;
  const double sign = v_r < 0.0 ? -1.0 : 1.0;  // a face moving backward in the plane is mirrored (as in 2D)
  const double cosg = sign * v_r / speed, sing = -v_z / speed;  // γ: the velocity's angle below r̂
  const double tx = n_z / facing, tz = -sign * n_r / facing;  // the face's tangent (cos β, sin β) up to sign
  const double cos2b = tx * tx - tz * tz, sin2b = 2.0 * tx * tz;
  const AlphaHat a = alpha_hat(table.c, cos2b, sin2b, cosg, sing);
  const double scale = table.zeta * weight * facing;  // ζ d A |(n_r, n_z)|
  p.fr = -sign * a.ax * scale;  // σ = (−s α_x, α_z) d on the projected area
  p.fz = a.az * scale;
  if (!jacobian) return p;
  // through γ: ∂γ/∂(v_r, v_z) = s (v_z, −v_r)/|v|² (as in rft.cpp)
  const double g_r = sign * v_z / (speed * speed), g_z = -sign * v_r / (speed * speed);
  p.dr_dvr = -sign * a.dax * scale * g_r;
  p.dr_dvz = -sign * a.dax * scale * g_z;
  p.dz_dvr = a.daz * scale * g_r;
  p.dz_dvz = a.daz * scale * g_z;
  // through β = atan2(−s n_r, n_z): ∂β/∂n_r = −s n_z/|n|², ∂cos 2β = −2 sin 2β ∂β, ∂sin 2β = 2 cos 2β ∂β
  const double dbeta = -sign * n_z / (facing * facing);
  const double dcos2b = -2.0 * sin2b * dbeta, dsin2b = 2.0 * cos2b * dbeta;
  const auto& k = table.c;  // A00, A10, B11, B01, B−11, C11, C01, C−11, D10: α̂ is linear in cos 2β, sin 2β
  const double dax = (k[5] + k[7]) * cosg * dcos2b + ((k[7] - k[5]) * sing + k[8]) * dsin2b;
  const double daz = (k[1] + (k[2] + k[4]) * sing) * dcos2b + (k[2] - k[4]) * cosg * dsin2b;
  const double dscale = table.zeta * weight * n_r / facing;  // ∂(ζ d A |(n_r, n_z)|)/∂n_r
  p.dr_dnr = -sign * (dax * scale + a.ax * dscale);
  p.dz_dnr = daz * scale + a.az * dscale;
  return p;
}

/// J += c (a ⊗ b), row-major 3 × 3.
void add_outer(std::array<double, 9>& j, double c, const Vec3& a, const Vec3& b) {
  for (int r = 0; r < 3; ++r)
    for (int s = 0; s < 3; ++s) j[static_cast<std::size_t>(3 * r + s)] += c * a[static_cast<std::size_t>(r)] * b[static_cast<std::size_t>(s)];
}

/// ∂P/∂v at fixed d: d ⊗ ∂P_r/∂v + ẑ ⊗ ∂P_z/∂v, with ∂v_r/∂v = d and ∂v_z/∂v = ẑ.
void add_fixed_plane(std::array<double, 9>& j, double c, const PlaneLoad& p, const Vec3& d) {
  add_outer(j, c * p.dr_dvr, d, d);
  add_outer(j, c * p.dr_dvz, d, kUp);
  add_outer(j, c * p.dz_dvr, kUp, d);
  add_outer(j, c * p.dz_dvz, kUp, kUp);
}

}  // namespace

ElementLoad element_force(const Vec3& n, const Vec3& v, double depth, double area, const Coefficients& table,
                          double regularisation, bool jacobian) {
  ElementLoad out;
  const double normal_speed = n[0] * v[0] + n[1] * v[1] + n[2] * v[2];
  if (!(depth > 0.0 && normal_speed > 0.0)) return out;  // above the surface, or a trailing face
  const double weight = depth * area;
  const double horizontal = std::hypot(v[0], v[1]), fallback = std::hypot(n[0], n[1]);
  // r̂ of the plane of motion; of the normal's plane, blended in below |v_h| = v_ε (terrasph.rft3d)
  const Vec3 plane = horizontal > 0.0 ? Vec3{v[0] / horizontal, v[1] / horizontal, 0.0} : Vec3{1.0, 0.0, 0.0};
  const double blend = regularisation > 0.0 ? std::clamp(horizontal / regularisation, 0.0, 1.0)
                                            : (horizontal > 0.0 ? 1.0 : 0.0);
  const PlaneLoad moving = plane_load(plane, n, v, weight, table, jacobian);
  const Vec3 p_moving = moving.vector(plane);
  Vec3 own_plane = plane, p_own{};
  PlaneLoad own;
  if (blend < 1.0) {
    if (fallback > 0.0) own_plane = {n[0] / fallback, n[1] / fallback, 0.0};
    own = plane_load(own_plane, n, v, weight, table, jacobian);
    p_own = own.vector(own_plane);
  }
  Vec3 inner{};  // b P(r̂) + (1 − b) P(n̂_h)
  for (std::size_t i = 0; i < 3; ++i) {
    inner[i] = blend * p_moving[i];
    if (blend < 1.0) inner[i] += (1.0 - blend) * p_own[i];
  }
  const bool ramp = regularisation > 0.0 && normal_speed < regularisation;
  const double fade = ramp ? normal_speed / regularisation : 1.0;  // min(1, n·v / v_ε), continuous in v
  for (std::size_t i = 0; i < 3; ++i) out.force[i] = regularisation > 0.0 ? inner[i] * fade : inner[i];
  if (!jacobian) return out;

  std::array<double, 9>& j = out.jacobian;
  // a plane turning with v, r̂ = v_h/|v_h|: ∂r̂/∂v = t tᵀ/|v_h| with t = ẑ × r̂, so ∂n_r/∂v = (n·t) tᵀ/|v_h|
  // and ∂(P_r r̂)/∂v ∋ P_r t tᵀ/|v_h| (v_r = |v_h| does not change with r̂: v·t = 0)
  const auto add_turning_plane = [&](double c, const PlaneLoad& p) {
    add_fixed_plane(j, c, p, plane);
    const Vec3 t{-plane[1], plane[0], 0.0};
    const double n_t = n[0] * t[0] + n[1] * t[1], turn = c / horizontal;
    add_outer(j, turn * n_t * p.dr_dnr, plane, t);
    add_outer(j, turn * n_t * p.dz_dnr, kUp, t);
    add_outer(j, turn * p.fr, t, t);
  };
  if (horizontal > 0.0) add_turning_plane(fade * blend, moving);
  if (blend < 1.0) {
    if (horizontal > 0.0 && !(fallback > 0.0)) {
      add_turning_plane(fade * (1.0 - blend), own);  // a flat face's own plane is that of motion
    } else {
      add_fixed_plane(j, fade * (1.0 - blend), own, own_plane);
    }
    if (regularisation > 0.0 && horizontal > 0.0) {  // ∂b/∂v = r̂/v_ε: (P(r̂) − P(n̂_h)) ⊗ r̂/v_ε
      const Vec3 jump{p_moving[0] - p_own[0], p_moving[1] - p_own[1], p_moving[2] - p_own[2]};
      add_outer(j, fade / regularisation, jump, plane);
    } else if (regularisation > 0.0) {  // at v_h = 0, one-sided in +v_x and +v_y: the plane is that axis
      for (std::size_t axis = 0; axis < 2; ++axis) {
        Vec3 e{};
        e[axis] = 1.0;
        const Vec3 p_axis = plane_load(e, n, v, weight, table, false).vector(e);
        for (std::size_t r = 0; r < 3; ++r) j[3 * r + axis] += fade * (p_axis[r] - p_own[r]) / regularisation;
      }
    }
  }
  if (ramp) add_outer(j, 1.0 / regularisation, inner, n);  // ∂fade/∂v = n/v_ε
  return out;
}

void element_forces(const double* normal, const double* velocity, const double* depth, const double* area,
                    std::size_t count, const Coefficients& table, double regularisation, double* out) {
  for (std::size_t e = 0; e < count; ++e) {
    const Vec3 n{normal[3 * e], normal[3 * e + 1], normal[3 * e + 2]};
    const Vec3 v{velocity[3 * e], velocity[3 * e + 1], velocity[3 * e + 2]};
    const ElementLoad load = element_force(n, v, depth[e], area[e], table, regularisation, false);
    std::copy(load.force.begin(), load.force.end(), out + 3 * e);
  }
}

}  // namespace terrasph::rft
