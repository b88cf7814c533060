// The one place that owns threading for per-particle loops. Every loop is a gather: particle i
// writes only its own entries, so results do not depend on the number of threads.
#pragma once

#include "terrasph/math.hpp"

namespace terrasph {

template <class Body> void for_each_particle(Index n, Body&& body) {
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) body(i);
}

}  // namespace terrasph
