// Resistive force theory in 3D: see terrasph/rft3d.hpp and the Python module terrasph.rft3d, whose
// docstring gives the law (after Treers, Cao & Stuart 2021, IEEE RA-L 6:1887).
#include "terrasph/rft3d.hpp"

#include <algorithm>
#include <cmath>

namespace terrasph::rft {

namespace {

/// |(x, y)|: no overflow guard (std::hypot's costs several times a square root; the speeds and unit
/// vectors here are far from overflow)
inline double norm2(double x, double y) { return std::sqrt(x * x + y * y); }

/// The planar law (rft.cpp, Li et al. 2013 Eq. 1) in the vertical plane of a unit horizontal
/// direction d, given the normal's and the velocity's components there, n_r = n·d, n_z, v_r = v·d,
/// v_z: P = P_r d + P_z ẑ before the blends and the ramp, and, for the Jacobian, its derivatives in
/// (v_r, v_z) at fixed d and in n_r.
struct PlaneLoad {
  double fr = 0.0, fz = 0.0;
  double dr_dvr = 0.0, dr_dvz = 0.0, dz_dvr = 0.0, dz_dvz = 0.0;
  double dr_dnr = 0.0, dz_dnr = 0.0;
  Vec3 vector(const Vec3& d) const { return {fr * d[0], fr * d[1], fz}; }
};

template <bool Jacobian>
PlaneLoad plane_load(double n_r, double n_z, double v_r, double v_z, double weight, const Coefficients& table) {
  PlaneLoad p;
  const double facing2 = n_r * n_r + n_z * n_z;  // |(n_r, n_z)|²: the area's share facing the plane of motion
  const double speed2 = v_r * v_r + v_z * v_z;
  if (!(facing2 > 0.0 && speed2 > 0.0)) return p;
  const double sign = v_r < 0.0 ? -1.0 : 1.0;  // a face moving backward in the plane is mirrored (as in 2D)
  const double inv_speed = 1.0 / std::sqrt(speed2), inv_facing2 = 1.0 / facing2;
  const double cosg = sign * v_r * inv_speed, sing = -v_z * inv_speed;  // γ: the velocity's angle below r̂
  // β of the face's tangent (cos β, sin β) = (n_z, −s n_r)/|(n_r, n_z)| (up to sign): 2β's cosine and sine
  const double cos2b = (n_z * n_z - n_r * n_r) * inv_facing2, sin2b = -2.0 * sign * n_z * n_r * inv_facing2;
  const AlphaHat a = alpha_hat(table, cos2b, sin2b, cosg, sing);
  const double facing = std::sqrt(facing2);
  const double scale = table.zeta * weight * facing;  // ζ d A |(n_r, n_z)|
  p.fr = -sign * a.ax * scale;  // σ = (−s α_x, α_z) d on the projected area
  p.fz = a.az * scale;
  if constexpr (!Jacobian) return p;
  // through γ: ∂γ/∂(v_r, v_z) = s (v_z, −v_r)/|v|² (as in rft.cpp)
  const double g_r = sign * v_z * inv_speed * inv_speed, g_z = -sign * v_r * inv_speed * inv_speed;
  p.dr_dvr = -sign * a.dax * scale * g_r;
  p.dr_dvz = -sign * a.dax * scale * g_z;
  p.dz_dvr = a.daz * scale * g_r;
  p.dz_dvz = a.daz * scale * g_z;
  // through β = atan2(−s n_r, n_z): ∂β/∂n_r = −s n_z/|n|²
  const double dbeta = -sign * n_z * inv_facing2;
  const double dax = a.dax_dbeta * dbeta, daz = a.daz_dbeta * dbeta;
  const double dscale = table.zeta * weight * n_r / facing;  // ∂(ζ d A |(n_r, n_z)|)/∂n_r
  p.dr_dnr = -sign * (dax * scale + a.ax * dscale);
  p.dz_dnr = daz * scale + a.az * dscale;
  return p;
}

/// plane_load() in the plane of the unit horizontal `d`.
template <bool Jacobian>
PlaneLoad plane_load(const Vec3& d, const Vec3& n, const Vec3& v, double weight, const Coefficients& table) {
  return plane_load<Jacobian>(n[0] * d[0] + n[1] * d[1], n[2], v[0] * d[0] + v[1] * d[1], v[2], weight, table);
}

using Matrix3 = std::array<double, 9>;  // row-major

/// J += c (a ⊗ b).
inline void add_outer(Matrix3& j, double c, const Vec3& a, const Vec3& b) {
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t s = 0; s < 3; ++s) j[3 * r + s] += c * a[r] * b[s];
}

/// J += c (a ⊗ b) for a horizontal b (b_z = 0).
inline void add_outer_horizontal(Matrix3& j, double c, const Vec3& a, const Vec3& b) {
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t s = 0; s < 2; ++s) j[3 * r + s] += c * a[r] * b[s];
}

/// J += c ∂P/∂v at fixed d: d ⊗ ∂P_r/∂v + ẑ ⊗ ∂P_z/∂v, with ∂v_r/∂v = d and ∂v_z/∂v = ẑ (d horizontal).
inline void add_fixed_plane(Matrix3& j, double c, const PlaneLoad& p, const Vec3& d) {
  for (std::size_t r = 0; r < 2; ++r) {
    for (std::size_t s = 0; s < 2; ++s) j[3 * r + s] += c * p.dr_dvr * d[r] * d[s];
    j[3 * r + 2] += c * p.dr_dvz * d[r];
  }
  for (std::size_t s = 0; s < 2; ++s) j[6 + s] += c * p.dz_dvr * d[s];
  j[8] += c * p.dz_dvz;
}

/// element_force()'s law: false for an unloaded element (force and Jacobian 0, not written); else
/// `force` and, with `Jacobian`, `j` are set. Inlined into body_wrench()'s loop.
template <bool Jacobian>
inline bool element_load(const Vec3& n, const Vec3& v, double depth, double area, const Coefficients& table,
                         double regularisation, Vec3& force, Matrix3& j) {
  const double normal_speed = n[0] * v[0] + n[1] * v[1] + n[2] * v[2];
  if (!(depth > 0.0 && normal_speed > 0.0)) return false;  // above the surface, or a trailing face
  const double weight = depth * area;
  const double horizontal = norm2(v[0], v[1]);
  // r̂ of the plane of motion; of the normal's plane, blended in below |v_h| = v_ε (terrasph.rft3d)
  const double inv_horizontal = horizontal > 0.0 ? 1.0 / horizontal : 0.0;
  const Vec3 plane = horizontal > 0.0 ? Vec3{v[0] * inv_horizontal, v[1] * inv_horizontal, 0.0} : Vec3{1.0, 0.0, 0.0};
  const double blend = regularisation > 0.0 ? std::clamp(horizontal / regularisation, 0.0, 1.0)
                                            : (horizontal > 0.0 ? 1.0 : 0.0);
  // in the plane of motion v_r = |v_h| and n_r = n·v_h/|v_h|
  const PlaneLoad moving = horizontal > 0.0 ? plane_load<Jacobian>((n[0] * v[0] + n[1] * v[1]) * inv_horizontal, n[2],
                                                                   horizontal, v[2], weight, table)
                                            : plane_load<Jacobian>(plane, n, v, weight, table);
  const Vec3 p_moving = moving.vector(plane);
  Vec3 own_plane = plane, p_own{};
  double fallback = 0.0;  // |n_h|
  PlaneLoad own;
  if (blend < 1.0) {
    fallback = norm2(n[0], n[1]);
    if (fallback > 0.0) own_plane = {n[0] / fallback, n[1] / fallback, 0.0};
    own = fallback > 0.0 ? plane_load<Jacobian>(fallback, n[2], v[0] * own_plane[0] + v[1] * own_plane[1], v[2], weight, table)
                         : moving;  // a flat face's own plane is that of motion
    p_own = own.vector(own_plane);
  }
  Vec3 inner{};  // b P(r̂) + (1 − b) P(n̂_h)
  for (std::size_t i = 0; i < 3; ++i) {
    inner[i] = blend * p_moving[i];
    if (blend < 1.0) inner[i] += (1.0 - blend) * p_own[i];
  }
  const bool ramp = regularisation > 0.0 && normal_speed < regularisation;
  const double fade = ramp ? normal_speed / regularisation : 1.0;  // min(1, n·v / v_ε), continuous in v
  for (std::size_t i = 0; i < 3; ++i) force[i] = regularisation > 0.0 ? inner[i] * fade : inner[i];
  if constexpr (!Jacobian) return true;

  j.fill(0.0);
  // a plane turning with v, r̂ = v_h/|v_h|: ∂r̂/∂v = t tᵀ/|v_h| with t = ẑ × r̂, so ∂n_r/∂v = (n·t) tᵀ/|v_h|
  // and ∂(P_r r̂)/∂v ∋ P_r t tᵀ/|v_h| (v_r = |v_h| does not change with r̂: v·t = 0)
  const auto add_turning_plane = [&](double c, const PlaneLoad& p) {
    add_fixed_plane(j, c, p, plane);
    const Vec3 t{-plane[1], plane[0], 0.0};
    const double n_t = n[0] * t[0] + n[1] * t[1], turn = c * inv_horizontal;
    const Vec3 row{turn * (n_t * p.dr_dnr * plane[0] + p.fr * t[0]), turn * (n_t * p.dr_dnr * plane[1] + p.fr * t[1]),
                   turn * n_t * p.dz_dnr};  // (n_t ∂P_r/∂n_r r̂ + n_t ∂P_z/∂n_r ẑ + P_r t)/|v_h| ⊗ t
    add_outer_horizontal(j, 1.0, row, t);
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
      add_outer_horizontal(j, fade / regularisation, jump, plane);
    } else if (regularisation > 0.0) {  // at v_h = 0, one-sided in +v_x and +v_y: the plane is that axis
      for (std::size_t axis = 0; axis < 2; ++axis) {
        Vec3 e{};
        e[axis] = 1.0;
        const Vec3 p_axis = plane_load<false>(e, n, v, weight, table).vector(e);
        for (std::size_t r = 0; r < 3; ++r) j[3 * r + axis] += fade * (p_axis[r] - p_own[r]) / regularisation;
      }
    }
  }
  if (ramp) add_outer(j, 1.0 / regularisation, inner, n);  // ∂fade/∂v = n/v_ε
  return true;
}

/// r × a.
inline Vec3 cross(const Vec3& r, const Vec3& a) {
  return {r[1] * a[2] - r[2] * a[1], r[2] * a[0] - r[0] * a[2], r[0] * a[1] - r[1] * a[0]};
}

}  // namespace

ElementLoad element_force(const Vec3& normal, const Vec3& velocity, double depth, double area,
                          const Coefficients& table, double regularisation, bool jacobian) {
  ElementLoad out;
  if (jacobian)
    element_load<true>(normal, velocity, depth, area, table, regularisation, out.force, out.jacobian);
  else
    element_load<false>(normal, velocity, depth, area, table, regularisation, out.force, out.jacobian);
  return out;
}

namespace {

template <bool Jacobian>
BodyWrench body_wrench(const SubmergedElements& elements, const Vec3& velocity, const Vec3& spin,
                       const Coefficients& table, double regularisation) {
  BodyWrench out;
  auto& w = out.wrench;
  auto& k = out.jacobian;  // row-major 6 × 6
  for (std::size_t e = 0; e < elements.count; ++e) {
    const Vec3& r = elements.arm[e];
    const Vec3 turn = cross(spin, r);
    const Vec3 v{velocity[0] + turn[0], velocity[1] + turn[1], velocity[2] + turn[2]};  // v = v_ref + ω × r
    Vec3 f;
    Matrix3 j;
    if (!element_load<Jacobian>(elements.normal[e], v, elements.depth[e], elements.area[e], table, regularisation, f, j))
      continue;
    const Vec3 torque = cross(r, f);  // τ = Σ r × F
    for (std::size_t i = 0; i < 3; ++i) {
      w[i] += f[i];
      w[3 + i] += torque[i];
    }
    if constexpr (!Jacobian) continue;
    // v = v_ref − [r]× ω, so ∂F/∂(v_ref, ω) = (E, −E [r]×) and ∂τ/∂(v_ref, ω) = [r]× ∂F/∂(v_ref, ω);
    // a row e of E gives −e [r]× = r × e, a column c of any block gives [r]× c = r × c
    std::array<Vec3, 3> spin_rows;  // rows of −E [r]×
    for (std::size_t i = 0; i < 3; ++i) {
      spin_rows[i] = cross(r, {j[3 * i], j[3 * i + 1], j[3 * i + 2]});
      for (std::size_t c = 0; c < 3; ++c) {
        k[6 * i + c] += j[3 * i + c];
        k[6 * i + 3 + c] += spin_rows[i][c];
      }
    }
    for (std::size_t c = 0; c < 3; ++c) {
      const Vec3 linear = cross(r, {j[c], j[3 + c], j[6 + c]});
      const Vec3 angular = cross(r, {spin_rows[0][c], spin_rows[1][c], spin_rows[2][c]});
      for (std::size_t i = 0; i < 3; ++i) {
        k[6 * (3 + i) + c] += linear[i];
        k[6 * (3 + i) + 3 + c] += angular[i];
      }
    }
  }
  return out;
}

}  // namespace

BodyWrench body_wrench(const SubmergedElements& elements, const Vec3& velocity, const Vec3& spin,
                       const Coefficients& table, double regularisation, bool jacobian) {
  return jacobian ? body_wrench<true>(elements, velocity, spin, table, regularisation)
                  : body_wrench<false>(elements, velocity, spin, table, regularisation);
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
