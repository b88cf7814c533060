// The one place that owns threading for particle loops. Every loop is a gather: particle i writes
// only its own entries, and reductions combine per-thread partials only with operations whose
// result does not depend on the grouping (max, min, integer sums), so results do not depend on the
// number of threads. No floating-point atomics, no floating-point sums across threads.
#pragma once

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <vector>

#include "terrasph/math.hpp"

namespace terrasph {

// How a loop deals its particles to the threads. 0: one contiguous block per thread (each thread
// meets the same particles, and their neighbours, in every pass). A positive chunk: chunks of that
// many dealt in turn, which stays balanced when the work is clustered in space, as with the active
// domain's frozen regions (one block per thread gives one thread the moving grains and the other
// the frozen ones). Either assignment is fixed for a given n and thread count.
inline constexpr Index balanced_chunk = 256;

// The fewest particles a loop gives each thread: below it the team's join costs more than the
// share of the work, so a small loop runs on fewer threads or on one. With idle threads that
// stay awake between loops (terrasph.threads.LONG_SPIN) a join costs a few µs, and a loop of 1 000
// walls (the rotating leg's) is worth splitting: it also keeps the second thread from sleeping
// through it and paying a wake-up at the next loop (docs/speed_history.md, sixth round). 2 000
// while idle threads slept at once. A process-wide setting, like the OpenMP thread count it
// refines; tests set 1 so that their small scenes still split across 2 and 3 threads.
inline constexpr Index default_particles_per_thread = 500;

inline std::atomic<Index>& particles_per_thread() {
  static std::atomic<Index> value{default_particles_per_thread};
  return value;
}

// Threads for a loop over n particles: n / particles_per_thread(), within [1, the thread count].
inline int team_size(Index n) {
  const Index per_thread = particles_per_thread().load(std::memory_order_relaxed);
  return static_cast<int>(std::clamp<Index>(n / per_thread, 1, omp_get_max_threads()));
}

inline Index chunk_size(Index n, Index chunk, int team) {
  if (chunk > 0) return chunk;
  return std::max<Index>(1, (n + team - 1) / team);
}

// body(i) for i in [0, n), in blocks or (chunk > 0) balanced chunks.
template <class Body> void for_each_particle(Index n, Body&& body, Index chunk = 0) {
  const int team = team_size(n);
  const Index size = chunk_size(n, chunk, team);
#pragma omp parallel for schedule(static, size) num_threads(team)
  for (Index i = 0; i < n; ++i) body(i);
}

// body(i, partial) for i in [0, n) on a per-thread partial that starts at `identity`; the partials
// are then merged with merge(total, partial). merge must be exact under regrouping (max, min,
// integer counts); a floating-point sum would make the result depend on the thread count.
template <class Partial, class Body, class Merge>
Partial reduce_over_particles(Index n, const Partial& identity, Body&& body, Merge&& merge, Index chunk = 0) {
  const int team = team_size(n);
  const Index size = chunk_size(n, chunk, team);
  // sized before the region, so the only barrier is the region's end, as with OpenMP's own
  // reduction clause
  std::vector<Partial> partials(static_cast<std::size_t>(team), identity);
#pragma omp parallel num_threads(team)
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
