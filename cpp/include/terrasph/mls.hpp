// Moving-least-squares (MLS) regularisation of a per-particle field, linear basis (dissertation
// Eq. 3.26–3.30; Dilts 1999, Colagrossi & Landrini 2003 for the density):
//   f̃_i = Σ_j f_j W^MLS_ij V_j,   W^MLS_ij = β_i · p(x_i − x_j) W_ij,   p(r) = (1, r),
//   β_i = A_i⁻¹ (1, 0, …)ᵀ,        A_i = Σ_j W_ij V_j p(x_i − x_j) p(x_i − x_j)ᵀ,
// sums over the granular neighbours within 2h and i itself. A linear field is reproduced exactly
// wherever A_i is invertible, in the bulk and next to a wall alike (the sums need no complete
// support). A particle whose A_i is nearly singular (too few neighbours, e.g. an isolated grain)
// keeps its value. Each row is gathered from its own neighbours in list order, so the result is
// the same for any thread count.
#pragma once

#include <Eigen/Dense>
#include <cmath>

#include "terrasph/kernel.hpp"
#include "terrasph/math.hpp"
#include "terrasph/neighbours.hpp"
#include "terrasph/parallel.hpp"

namespace terrasph {

// The MLS-regularised copy of `field` (rows in storage order, any number of columns).
// `list` holds each particle's granular neighbours; volume = m/ρ.
template <int D, class Field>
Field mls_regularised(const VecArray<D>& position, const ScalarArray& volume, const NeighbourList& list,
                      const WendlandC2<D>& kernel, const Field& field) {
  using Basis = Eigen::Matrix<double, D + 1, 1>;
  using Moment = Eigen::Matrix<double, D + 1, D + 1>;
  const double support2 = 4.0 * kernel.h * kernel.h;
  const Index n = position.rows();
  Field out = field;
  for_each_particle(n, [&](Index i) {
    const Vec<D> xi = row_vec<D>(position, i);
    // p(x_i − x_j) with the offset in units of h, so that A_i's entries share one scale (the
    // result does not depend on the units of the basis)
    auto basis = [&](const Vec<D>& offset) {
      Basis p;
      p[0] = 1.0;
      p.template tail<D>() = offset / kernel.h;
      return p;
    };
    // A_i (Eq. 3.28), self term first, then the neighbours in list order
    const Basis self = basis(Vec<D>::Zero());
    Moment moment = (kernel.self_value() * volume[i]) * self * self.transpose();
    for (Index s = list.offsets[i]; s < list.offsets[i + 1]; ++s) {
      const std::int32_t j = list.indices[s];
      const Vec<D> offset = xi - row_vec<D>(position, j);
      const double r2 = offset.squaredNorm();
      if (r2 >= support2) continue;
      const Basis p = basis(offset);
      moment.noalias() += (kernel.value(std::sqrt(r2)) * volume[j]) * p * p.transpose();
    }
    // β_i = A_i⁻¹ e_0 (Eq. 3.29); a nearly singular A_i keeps f_i
    Eigen::FullPivLU<Moment> lu(moment);
    lu.setThreshold(1e-6);
    if (!lu.isInvertible()) return;
    const Basis beta = lu.solve(Basis::Unit(0));
    // f̃_i = Σ_j f_j β_i·p_ij W_ij V_j (Eq. 3.26, 3.30)
    auto row = out.row(i);
    row = (beta.dot(self) * kernel.self_value() * volume[i]) * field.row(i);
    for (Index s = list.offsets[i]; s < list.offsets[i + 1]; ++s) {
      const std::int32_t j = list.indices[s];
      const Vec<D> offset = xi - row_vec<D>(position, j);
      const double r2 = offset.squaredNorm();
      if (r2 >= support2) continue;
      row += (beta.dot(basis(offset)) * kernel.value(std::sqrt(r2)) * volume[j]) * field.row(j);
    }
  });
  return out;
}

}  // namespace terrasph
