// The one place that owns threading for particle loops. Every loop is a gather: particle i writes
// only its own entries, and reductions combine per-thread partials only with operations whose
// result does not depend on the grouping (max, min, integer sums), so results do not depend on the
// number of threads. No floating-point atomics, no floating-point sums across threads.
#pragma once

#include <omp.h>

#include <algorithm>
#include <vector>

#include "terrasph/math.hpp"

namespace terrasph {

// How a loop deals its particles to the threads. 0: one contiguous block per thread (each thread
// meets the same particles, and their neighbours, in every pass). A positive chunk: chunks of that
// many dealt in turn, which stays balanced when the work is clustered in space, as with the active
// domain's frozen regions (one block per thread gives one thread the moving grains and the other
// the frozen ones). Either assignment is fixed for a given n and thread count.
inline constexpr Index balanced_chunk = 256;

inline Index chunk_size(Index n, Index chunk) {
  if (chunk > 0) return chunk;
  const Index threads = omp_get_max_threads();
  return std::max<Index>(1, (n + threads - 1) / threads);
}

// body(i) for i in [0, n), in blocks or (chunk > 0) balanced chunks.
template <class Body> void for_each_particle(Index n, Body&& body, Index chunk = 0) {
  const Index size = chunk_size(n, chunk);
#pragma omp parallel for schedule(static, size)
  for (Index i = 0; i < n; ++i) body(i);
}

// body(i, partial) for i in [0, n) on a per-thread partial that starts at `identity`; the partials
// are then merged with merge(total, partial). merge must be exact under regrouping (max, min,
// integer counts); a floating-point sum would make the result depend on the thread count.
template <class Partial, class Body, class Merge>
Partial reduce_over_particles(Index n, const Partial& identity, Body&& body, Merge&& merge, Index chunk = 0) {
  const Index size = chunk_size(n, chunk);
  // sized before the region (a team never exceeds omp_get_max_threads()), so the only barrier is
  // the region's end, as with OpenMP's own reduction clause
  std::vector<Partial> partials(static_cast<std::size_t>(omp_get_max_threads()), identity);
#pragma omp parallel
  {
    Partial local = identity;
#pragma omp for schedule(static, size) nowait
    for (Index i = 0; i < n; ++i) body(i, local);
    partials[static_cast<std::size_t>(omp_get_thread_num())] = local;
  }
  Partial total = identity;
  for (const Partial& p : partials) merge(total, p);
  return total;
}

// Largest value of f(i) over [0, n), and `floor` for an empty range.
template <class F> double max_over_particles(Index n, double floor, F&& f, Index chunk = 0) {
  return reduce_over_particles(
      n, floor, [&](Index i, double& m) { m = std::max(m, f(i)); },
      [](double& total, double p) { total = std::max(total, p); }, chunk);
}

}  // namespace terrasph
