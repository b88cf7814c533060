// The core's clock and float multiply-add peak, measured: the roofline figures docs/lstm.md §7
// compares the LSTM steps with. x86-64 with GCC or Clang only.
//
//   g++ -std=c++17 -O2 -march=native benchmarks/performance/fma_peak.cpp -o fma_peak && ./fma_peak
//
// * clock: a chain of dependent register-register integer adds (1 cycle each on every x86-64
//   core of the last decade; not adds of an immediate, which recent Intel cores fold at
//   renaming, several per cycle), timed; cycles per ns = adds per ns.
// * peak: 12 independent chains of vector multiply-adds (more than latency x throughput on any
//   core: 4 cycles x 2 units = 8) over 8-lane (AVX2) and, if compiled for it, 16-lane (AVX-512)
//   float vectors; float FMAs per ns, and per cycle with the clock above.
// Best of 60 short timings, single-threaded: on a shared machine run it beside the benchmark it
// qualifies and state the load (timings longer than a time slice would all include other
// processes' turns and understate both figures).
#if !defined(__AVX2__) || !defined(__FMA__)
#error "fma_peak.cpp needs AVX2 and FMA: build with -march=native on a CPU that has them"
#endif
#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

namespace {

template <typename F>
double best_seconds(F&& f, int repeats = 60) {
  double best = 1e30;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

// ~4 ms per timing (4 M cycles): short against the scheduler's time slice, so that on a loaded
// machine some timings run without being descheduled (the best is kept).
constexpr long kIters = 2'000'000;

// kIters x 8 dependent adds.
__attribute__((noinline)) long add_chain(long n, long one) {
  long x = 0;
  for (long i = 0; i < n; ++i) {
    asm volatile(
        "add %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\t"
        "add %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\tadd %1, %0"
        : "+r"(x)
        : "r"(one));
  }
  return x;
}

// 12 accumulators of V, one multiply-add each per iteration, kept in registers (named, the loop
// over them unrolled by hand; an empty asm per accumulator stops any reassociation or hoisting).
#define TERRASPH_FMA12(FMA)                                                                     \
  a0 = FMA(a0, b, c); a1 = FMA(a1, b, c); a2 = FMA(a2, b, c); a3 = FMA(a3, b, c);               \
  a4 = FMA(a4, b, c); a5 = FMA(a5, b, c); a6 = FMA(a6, b, c); a7 = FMA(a7, b, c);               \
  a8 = FMA(a8, b, c); a9 = FMA(a9, b, c); a10 = FMA(a10, b, c); a11 = FMA(a11, b, c);           \
  asm volatile("" : "+x"(a0), "+x"(a1), "+x"(a2), "+x"(a3), "+x"(a4), "+x"(a5), "+x"(a6),      \
               "+x"(a7), "+x"(a8), "+x"(a9), "+x"(a10), "+x"(a11))

__attribute__((noinline)) __m256 fma_chains_256(long n, __m256 c, __m256 b) {
  __m256 a0 = c, a1 = c, a2 = c, a3 = c, a4 = c, a5 = c, a6 = c, a7 = c, a8 = c, a9 = c,
         a10 = c, a11 = c;
  for (long i = 0; i < n; ++i) {
    TERRASPH_FMA12(_mm256_fmadd_ps);
  }
  return ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7)) + ((a8 + a9) + (a10 + a11));
}

#if defined(__AVX512F__)
__attribute__((noinline)) __m512 fma_chains_512(long n, __m512 c, __m512 b) {
  __m512 a0 = c, a1 = c, a2 = c, a3 = c, a4 = c, a5 = c, a6 = c, a7 = c, a8 = c, a9 = c,
         a10 = c, a11 = c;
  for (long i = 0; i < n; ++i) {
    TERRASPH_FMA12(_mm512_fmadd_ps);
  }
  return ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7)) + ((a8 + a9) + (a10 + a11));
}
#endif

double clock_ghz() { return 8.0 * kIters / best_seconds([] { add_chain(kIters, 1); }) * 1e-9; }

}  // namespace

int main() {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(500)) add_chain(kIters / 10, 1);
  const double ghz = clock_ghz();
  std::printf("clock (dependent adds): %.2f GHz\n", ghz);
  const long n = kIters / 2;
  {
    const __m256 c = _mm256_set1_ps(1e-3f), b = _mm256_set1_ps(0.999f);
    const double t = best_seconds([&] {
      volatile __m256 s = fma_chains_256(n, c, b);
      (void)s;
    });
    const double per_ns = 12.0 * 8 * n / t * 1e-9;
    std::printf("AVX2    (8 floats):  %.1f float FMA/ns = %.1f per cycle\n", per_ns, per_ns / ghz);
  }
#if defined(__AVX512F__)
  {
    const __m512 c = _mm512_set1_ps(1e-3f), b = _mm512_set1_ps(0.999f);
    const double t = best_seconds([&] {
      volatile __m512 s = fma_chains_512(n, c, b);
      (void)s;
    });
    const double per_ns = 12.0 * 16 * n / t * 1e-9;
    std::printf("AVX-512 (16 floats): %.1f float FMA/ns = %.1f per cycle\n", per_ns, per_ns / ghz);
  }
#else
  std::printf("AVX-512: not compiled for it (build with -march=native on an AVX-512 CPU)\n");
#endif
  std::printf("clock again (dependent adds): %.2f GHz\n", clock_ghz());
  return 0;
}
