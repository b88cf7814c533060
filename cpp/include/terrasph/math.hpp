// Small fixed-size vector/tensor types and row-major particle arrays shared by the core.
#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace terrasph {

template <int D> using Vec = Eigen::Matrix<double, D, 1>;
template <int D> using Mat = Eigen::Matrix<double, D, D, Eigen::RowMajor>;

// (N, D) row-major per-particle vectors and (N, D*D) per-particle tensors (numpy's (N, D) and
// (N, D, D) layouts), and per-particle scalars, ids and flags.
template <int D> using VecArray = Eigen::Matrix<double, Eigen::Dynamic, D, Eigen::RowMajor>;
template <int D> using MatArray = Eigen::Matrix<double, Eigen::Dynamic, D * D, Eigen::RowMajor>;
using ScalarArray = Eigen::VectorXd;
using IdArray = Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>;
using Int32Array = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1>;
using FlagArray = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 1>;
using Index = std::int64_t;

template <int D> inline Eigen::Map<Vec<D>> row_vec(VecArray<D>& a, Index i) {
  return Eigen::Map<Vec<D>>(a.data() + D * i);
}
template <int D> inline Eigen::Map<const Vec<D>> row_vec(const VecArray<D>& a, Index i) {
  return Eigen::Map<const Vec<D>>(a.data() + D * i);
}
template <int D> inline Eigen::Map<Mat<D>> row_mat(MatArray<D>& a, Index i) {
  return Eigen::Map<Mat<D>>(a.data() + D * D * i);
}
template <int D> inline Eigen::Map<const Mat<D>> row_mat(const MatArray<D>& a, Index i) {
  return Eigen::Map<const Mat<D>>(a.data() + D * D * i);
}

// Positive integer power by repeated squaring; used for the EOS exponent γ = 7.
inline double int_pow(double base, int exponent) {
  double result = 1.0;
  while (exponent > 0) {
    if (exponent & 1) result *= base;
    base *= base;
    exponent >>= 1;
  }
  return result;
}

}  // namespace terrasph
