// Wendland C2 smoothing kernel with support 2h (dissertation Eq. 2.36; Wendland 1995).
#pragma once

#include <cmath>

namespace terrasph {

template <int D> struct WendlandC2 {
  double h;
  double alpha;  // α_d = 7/(4πh²) in 2D, 21/(16πh³) in 3D
  double inv_h;
  double gradient_coefficient;  // −5α/h² times gradient_scale
  double support2;              // (2h)²

  // gradient_scale multiplies every ∇W (1: the kernel's own gradient; see lattice_gradient_moment).
  explicit WendlandC2(double smoothing_length, double gradient_scale = 1.0)
      : h(smoothing_length), alpha(normalisation(smoothing_length)), inv_h(1.0 / smoothing_length),
        gradient_coefficient(-5.0 * alpha / (smoothing_length * smoothing_length) * gradient_scale),
        support2(4.0 * smoothing_length * smoothing_length) {}

  static double normalisation(double hh) {
    static_assert(D == 2 || D == 3, "Wendland C2 is defined here for 2D and 3D");
    constexpr double pi = 3.14159265358979323846;
    if constexpr (D == 2) return 7.0 / (4.0 * pi * hh * hh);
    return 21.0 / (16.0 * pi * hh * hh * hh);
  }

  // s = Σ_j V_j (x_j − x_i)_z ∂W_ij/∂z_i on a full square (cubic) lattice of spacing Δx around i,
  // h = h_factor·Δx: the discrete gradient of a linear field on the lattice is s times the exact
  // one (s = 1 for the kernel's integral; the lattice sum is 0.974 at h_factor 1.3 in 2D, 0.979 in
  // 3D, 0.997 and 1.001 at 1.5). Independent of Δx (∂W/∂z scales as Δx^−D−1).
  static double lattice_gradient_moment(double h_factor) {
    const WendlandC2 unit(h_factor);  // Δx = 1, V_j = 1
    const int reach = static_cast<int>(std::ceil(2.0 * h_factor));
    double sum = 0.0;
    int offset[3] = {0, 0, 0};  // lattice offsets x_j − x_i, the last component z
    const int cells = 2 * reach + 1;
    const int count = D == 2 ? cells * cells : cells * cells * cells;
    for (int n = 0; n < count; ++n) {
      int rest = n;
      double r2 = 0.0;
      for (int k = 0; k < D; ++k) {
        offset[k] = rest % cells - reach;
        rest /= cells;
        r2 += static_cast<double>(offset[k] * offset[k]);
      }
      const double z = offset[D - 1];  // ∂W_ij/∂z_i = (z_i − z_j) F = −z F
      sum += -z * z * unit.gradient_factor(std::sqrt(r2));
    }
    return sum;
  }

  double support_radius() const { return 2.0 * h; }

  // W(r) = α (1 − q/2)^4 (2q + 1), q = r/h ≤ 2.
  double value(double r) const {
    const double q = r * inv_h;
    if (q >= 2.0) return 0.0;
    const double s = 1.0 - 0.5 * q;
    const double s2 = s * s;
    return alpha * s2 * s2 * (2.0 * q + 1.0);
  }

  // (dW/dr)/r = −5α(1 − q/2)³/h², finite at r = 0; ∇_i W_ij = x_ij · gradient_factor(r).
  double gradient_factor(double r) const {
    const double q = r * inv_h;
    if (q >= 2.0) return 0.0;
    const double s = 1.0 - 0.5 * q;
    return gradient_coefficient * s * s * s;
  }

  // W alone from r², without a branch; rounds exactly as value(√r²).
  double pair_value(double r2) const {
    const double q = std::sqrt(r2) * inv_h;
    const double s = cut_off(r2, 1.0 - 0.5 * q);
    const double s2 = s * s;
    return alpha * s2 * s2 * (2.0 * q + 1.0);
  }

  // W(r) and (dW/dr)/r of a pair from r² = |x_ij|², sharing (1 − q/2), without a branch: both are
  // 0 for r² ≥ (2h)² (selects compile to blends: pairs in a neighbour-list skin cost no mispredicted
  // jump).
  void pair_value_and_gradient_factor(double r2, double& w, double& gradient) const {
    const double q = std::sqrt(r2) * inv_h;
    const double s = cut_off(r2, 1.0 - 0.5 * q);
    const double s3 = s * s * s;
    w = alpha * s3 * s * (2.0 * q + 1.0);
    gradient = gradient_coefficient * s3;
  }

  // The gradient of pair_value_and_gradient_factor alone, rounded exactly as there (for the passes
  // that do not need W).
  double pair_gradient_factor_without_value(double r2) const {
    const double q = std::sqrt(r2) * inv_h;
    const double s = cut_off(r2, 1.0 - 0.5 * q);
    const double s3 = s * s * s;
    return gradient_coefficient * s3;
  }

  // (dW/dr)/r alone from r², without a branch; rounds exactly as gradient_factor(√r²).
  double pair_gradient_factor(double r2) const {
    const double q = std::sqrt(r2) * inv_h;
    const double s = cut_off(r2, 1.0 - 0.5 * q);
    return gradient_coefficient * s * s * s;
  }

  double self_value() const { return alpha; }

 private:
  // s = 1 − q/2 inside the support, else 0 (also where rounding makes q ≥ 2 for r² < (2h)²);
  // plain selects on values, which the vectoriser turns into masks.
  double cut_off(double r2, double s) const {
    const double positive = s > 0.0 ? s : 0.0;
    return r2 < support2 ? positive : 0.0;
  }
};

}  // namespace terrasph
