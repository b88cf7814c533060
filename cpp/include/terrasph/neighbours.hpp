// Cell-linked list (cell size ≥ search radius) and compressed neighbour lists.
// Lists are built in a fixed order (cells in lexicographic order, particles by index inside a
// cell), so the summation order, and hence every result, is independent of the thread count.
#pragma once

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "terrasph/math.hpp"
#include "terrasph/parallel.hpp"

namespace terrasph {

// Compressed sparse rows: the neighbours of query i are indices[offsets[i] .. offsets[i+1]).
struct NeighbourList {
  std::vector<Index> offsets{0};
  std::vector<std::int32_t> indices;

  Index count(Index i) const { return offsets[i + 1] - offsets[i]; }
  Index total() const { return static_cast<Index>(indices.size()); }
};

template <int D> class CellGrid {
 public:
  // Bins `points` into cells of edge `cell_size` over the box [lower, upper].
  void build(const VecArray<D>& points, const Vec<D>& lower, const Vec<D>& upper, double cell_size) {
    lower_ = lower;
    cell_size_ = cell_size;
    Index n_cells = 1;
    for (int k = 0; k < D; ++k) {
      dims_[k] = std::max<Index>(1, static_cast<Index>(std::floor((upper[k] - lower[k]) / cell_size)) + 1);
      n_cells *= dims_[k];
    }
    const Index n = points.rows();
    cell_of_.resize(static_cast<size_t>(n));
    for_each_point(n, [&](Index i) { cell_of_[i] = cell_index(cell_coords(row_vec<D>(points, i))); });
    // Counting sort, stable in the particle index.
    cell_start_.assign(static_cast<size_t>(n_cells + 1), 0);
    for (Index i = 0; i < n; ++i) ++cell_start_[cell_of_[i] + 1];
    for (Index c = 0; c < n_cells; ++c) cell_start_[c + 1] += cell_start_[c];
    sorted_.resize(static_cast<size_t>(n));
    std::vector<Index> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (Index i = 0; i < n; ++i) sorted_[fill[cell_of_[i]]++] = static_cast<std::int32_t>(i);
  }

  // The binned points cell by cell (cells in lexicographic order, by index inside a cell).
  const std::vector<std::int32_t>& cell_order() const { return sorted_; }

  // Calls visit(j) for every binned point j in the cells around p (3^D block).
  template <class Visit> void for_each_candidate(const Vec<D>& p, Visit&& visit) const {
    const std::array<Index, D> c = cell_coords(p);
    std::array<Index, D> lo, hi;
    for (int k = 0; k < D; ++k) {
      lo[k] = std::max<Index>(0, c[k] - 1);
      hi[k] = std::min<Index>(dims_[k] - 1, c[k] + 1);
    }
    if constexpr (D == 2) {
      for (Index y = lo[1]; y <= hi[1]; ++y) {
        // cells lo[0]..hi[0] of row y are contiguous in the sorted array
        const Index first = cell_start_[lo[0] + dims_[0] * y];
        const Index last = cell_start_[hi[0] + dims_[0] * y + 1];
        for (Index s = first; s < last; ++s) visit(sorted_[s]);
      }
    } else {
      for (Index z = lo[2]; z <= hi[2]; ++z)
        for (Index y = lo[1]; y <= hi[1]; ++y) {
          const Index base = dims_[0] * (y + dims_[1] * z);
          const Index first = cell_start_[lo[0] + base];
          const Index last = cell_start_[hi[0] + base + 1];
          for (Index s = first; s < last; ++s) visit(sorted_[s]);
        }
    }
  }

 private:
  template <class F> static void for_each_point(Index n, F&& f) {
#pragma omp parallel for schedule(static) num_threads(team_size(n))
    for (Index i = 0; i < n; ++i) f(i);
  }

  std::array<Index, D> cell_coords(const Eigen::Ref<const Vec<D>>& p) const {
    std::array<Index, D> c;
    for (int k = 0; k < D; ++k) {
      const Index ck = static_cast<Index>(std::floor((p[k] - lower_[k]) / cell_size_));
      c[k] = std::clamp<Index>(ck, 0, dims_[k] - 1);
    }
    return c;
  }
  Index cell_index(const std::array<Index, D>& c) const {
    Index idx = c[D - 1];
    for (int k = D - 2; k >= 0; --k) idx = idx * dims_[k] + c[k];
    return idx;
  }

  Vec<D> lower_ = Vec<D>::Zero();
  double cell_size_ = 1.0;
  std::array<Index, D> dims_{};
  std::vector<Index> cell_of_;
  std::vector<Index> cell_start_;
  std::vector<std::int32_t> sorted_;
};

// Neighbours within `radius` of every query point among the points binned in `grid`.
// With `exclude_same_index`, query i does not list source i (query and source sets equal).
template <int D>
void build_neighbour_list(const VecArray<D>& queries, const VecArray<D>& sources,
                          const CellGrid<D>& grid, double radius, bool exclude_same_index,
                          NeighbourList& out) {
  const Index n = queries.rows();
  const double r2max = radius * radius;
  out.offsets.assign(static_cast<size_t>(n + 1), 0);
  std::vector<std::vector<std::int32_t>> chunk_lists;
#pragma omp parallel num_threads(team_size(n))
  {
    const int n_threads = omp_get_num_threads();
    const int thread = omp_get_thread_num();
#pragma omp single
    chunk_lists.resize(static_cast<size_t>(n_threads));
    // implicit barrier: chunk_lists is sized
    const Index begin = n * thread / n_threads;
    const Index end = n * (thread + 1) / n_threads;
    std::vector<std::int32_t>& local = chunk_lists[static_cast<size_t>(thread)];
    for (Index i = begin; i < end; ++i) {
      const Vec<D> xi = row_vec<D>(queries, i);
      grid.for_each_candidate(xi, [&](std::int32_t j) {
        if (exclude_same_index && j == i) return;
        if ((xi - row_vec<D>(sources, j)).squaredNorm() < r2max) local.push_back(j);
      });
      out.offsets[i + 1] = static_cast<Index>(local.size());  // chunk-local end, fixed below
    }
#pragma omp barrier
#pragma omp single
    {
      Index total = 0;
      for (auto& l : chunk_lists) total += static_cast<Index>(l.size());
      out.indices.resize(static_cast<size_t>(total));
    }
    Index chunk_start = 0;
    for (int t = 0; t < thread; ++t) chunk_start += static_cast<Index>(chunk_lists[t].size());
    std::copy(local.begin(), local.end(), out.indices.begin() + chunk_start);
    for (Index i = begin; i < end; ++i) out.offsets[i + 1] += chunk_start;
  }
}

// Bounding box of one or two point sets, padded by `pad`.
template <int D>
void bounding_box(const VecArray<D>& a, const VecArray<D>& b, double pad, Vec<D>& lower, Vec<D>& upper) {
  lower = Vec<D>::Constant(std::numeric_limits<double>::max());
  upper = Vec<D>::Constant(std::numeric_limits<double>::lowest());
  if (a.rows() > 0) {
    lower = lower.cwiseMin(a.colwise().minCoeff().transpose());
    upper = upper.cwiseMax(a.colwise().maxCoeff().transpose());
  }
  if (b.rows() > 0) {
    lower = lower.cwiseMin(b.colwise().minCoeff().transpose());
    upper = upper.cwiseMax(b.colwise().maxCoeff().transpose());
  }
  if (a.rows() == 0 && b.rows() == 0) {
    lower.setZero();
    upper.setZero();
  }
  lower.array() -= pad;
  upper.array() += pad;
}

}  // namespace terrasph
