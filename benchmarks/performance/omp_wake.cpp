// What an idle OpenMP thread costs on this machine (libgomp): how long the second thread of a team
// takes to start a parallel region that follows a serial gap of the master's, and how long it
// spins after a region before it sleeps, for the GOMP_SPINCOUNT or OMP_WAIT_POLICY in the
// environment. The figures behind terrasph.threads.LONG_SPIN / SHORT_SPIN (docs/speed_history.md,
// sixth round of the speed levers).
//
//   g++ -std=c++17 -O2 -fopenmp benchmarks/performance/omp_wake.cpp -o omp_wake
//   for s in 0 1000 30000; do GOMP_SPINCOUNT=$s ./omp_wake; done
//
// * start delay: the master spins for the gap (µs), then opens a region of two threads that each
//   busy-wait 20 µs; the delay is the worker's first clock reading less the master's at the
//   region's start. Median and 90th percentile of 400 regions per gap.
// * spin after a region: 200 regions of two threads, each followed by 5 ms of the master asleep;
//   the process's CPU time per region, less what one region of work costs, is the worker's spin
//   (its sleep and wake-up system calls included).
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <vector>

namespace {

void busy_wait_us(double us) {
  const double start = omp_get_wtime();
  while ((omp_get_wtime() - start) * 1e6 < us) {
  }
}

void start_delay(double gap_us) {
  constexpr int regions = 400;
  std::vector<double> delays;
  for (int r = 0; r < regions; ++r) {
    busy_wait_us(gap_us);
    const double opened = omp_get_wtime();
    double worker_started = opened;
#pragma omp parallel num_threads(2)
    {
      if (omp_get_thread_num() == 1) worker_started = omp_get_wtime();
      busy_wait_us(20.0);
    }
    delays.push_back((worker_started - opened) * 1e6);
  }
  std::sort(delays.begin(), delays.end());
  std::printf("gap %6.0f us: the worker starts after %7.1f us (median), %7.1f us (90 %%)\n", gap_us,
              delays[regions / 2], delays[regions * 9 / 10]);
}

void spin_after_region() {
  constexpr int regions = 200;
  const std::clock_t start = std::clock();
  for (int r = 0; r < regions; ++r) {
#pragma omp parallel num_threads(2)
    busy_wait_us(1.0);
    usleep(5000);
  }
  const double cpu_us = 1e6 * static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC / regions;
  std::printf("CPU per region followed by 5 ms of sleep: %.0f us (2 us of it the region's work)\n", cpu_us);
}

}  // namespace

int main() {
  for (double gap : {1.0, 20.0, 100.0, 300.0}) start_delay(gap);
  spin_after_region();
  return 0;
}
