// Compute kernels of the terrasph LSTM engine (included by terrasph/lstm.hpp): packed weight
// panels, the register-tiled matrix products, the gate nonlinearities and the cell updates.
//
// One arithmetic for one sequence and for a batch. Every matrix product (gates, peepholes)
// computes each output element as  y = y0 + w_0 z_0 + w_1 z_1 + ... + w_{K-1} z_{K-1},  summed
// in that order, one multiply-add per term, whatever the register tile (one sequence: 8 vectors
// of rows; a batch: kBatchRowVecs vectors of rows times up to kBatchTile sequences). The dense
// head (head_dot) and the element-wise code run the same instructions on every sequence and every
// element (vector lanes compute what any other lane computes; a row's last partial vector is
// zero-padded). A batch of B sequences therefore gives, bit for bit, the results of B single
// sequences (tests/test_lstm_batch.py).
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

namespace terrasph {
namespace lstm {
namespace detail {

using Index = Eigen::Index;

// The kernels are written with GNU vector extensions (one source for SSE, AVX2 and AVX-512).
#if !defined(__GNUC__)
#error "terrasph/lstm.hpp needs GNU vector extensions (GCC, Clang or Intel icx)"
#endif
#define TERRASPH_LSTM_INLINE inline __attribute__((always_inline))
#define TERRASPH_LSTM_PRAGMA(x) _Pragma(#x)
#if defined(__clang__)
#define TERRASPH_LSTM_UNROLL TERRASPH_LSTM_PRAGMA(unroll)
#define TERRASPH_LSTM_UNROLL_4 TERRASPH_LSTM_PRAGMA(unroll 4)
#define TERRASPH_LSTM_UNROLL_64 TERRASPH_LSTM_PRAGMA(unroll 64)
#else
#define TERRASPH_LSTM_UNROLL TERRASPH_LSTM_PRAGMA(GCC unroll 16)
#define TERRASPH_LSTM_UNROLL_4 TERRASPH_LSTM_PRAGMA(GCC unroll 4)
#define TERRASPH_LSTM_UNROLL_64 TERRASPH_LSTM_PRAGMA(GCC unroll 64)
#endif

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__AVX2__) && \
    !defined(TERRASPH_LSTM_NO_DISPATCH)
// A build for baseline x86-64 (like a Python wheel) also compiles the step for AVX2 + FMA and for
// AVX-512 (F, with AVX2 + FMA) and chooses at run time the widest the CPU has
// (terrasph::lstm::detail::advance).
#define TERRASPH_LSTM_AVX2_DISPATCH 1
#endif

/// Kernel variants: Generic (the build's own flags) and, in a dispatching build, AVX2 + FMA and
/// AVX-512.
enum class KernelIsa { Generic = 0, Avx2 = 1, Avx512 = 2 };

/// The variant models loaded in this process run (fixed per Model, so its results are
/// reproducible): the widest the CPU supports, at most the one the environment variable
/// TERRASPH_LSTM_ISA names (generic, avx2 or avx512; for comparisons and tests).
inline KernelIsa default_isa() {
#ifdef TERRASPH_LSTM_AVX2_DISPATCH
  __builtin_cpu_init();
  KernelIsa isa = KernelIsa::Generic;
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
    isa = __builtin_cpu_supports("avx512f") ? KernelIsa::Avx512 : KernelIsa::Avx2;
  }
  if (const char* cap = std::getenv("TERRASPH_LSTM_ISA")) {
    const std::string c(cap);
    if (c == "generic") isa = KernelIsa::Generic;
    if (c == "avx2" && isa == KernelIsa::Avx512) isa = KernelIsa::Avx2;
  }
  return isa;
#else
  return KernelIsa::Generic;
#endif
}

// Width of the vectors of the Generic kernels: the widest the build targets, or AVX2 in a
// dispatching build (whose Generic variant then runs 32-byte vectors as pairs of SSE2 ones).
#if defined(__AVX512F__)
constexpr int kSimdBytes = 64;
#elif defined(__AVX__) || defined(TERRASPH_LSTM_AVX2_DISPATCH)
constexpr int kSimdBytes = 32;
#else
constexpr int kSimdBytes = 16;
#endif

/// Allocator of memory aligned to a cache line (64 bytes): the kernels' vectors then sit at the
/// same offsets in every process. With malloc's 16-byte alignment, how far a buffer lies from a
/// cache line depended on earlier allocations, and a hidden-16 step took 15 % longer in some
/// processes than in others (e.g. with a longer model file path).
template <typename T>
struct CacheAligned {
  using value_type = T;
  static constexpr std::align_val_t kAlign{64};
  CacheAligned() = default;
  template <typename U>
  CacheAligned(const CacheAligned<U>&) {}
  T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), kAlign)); }
  void deallocate(T* p, std::size_t) { ::operator delete(p, kAlign); }
  template <typename U>
  bool operator==(const CacheAligned<U>&) const { return true; }
  template <typename U>
  bool operator!=(const CacheAligned<U>&) const { return false; }
};
template <typename S>
using AlignedVector = std::vector<S, CacheAligned<S>>;

/// A weight matrix (rows x cols) in the layout the products stream through: panels of
/// `panel` rows (Simd<Bytes>::panel_rows() of the kernels that read it; the last one zero-padded),
/// within a panel column after column.
template <typename S>
struct Packed {
  Index rows = 0, cols = 0, panel = 0;
  AlignedVector<S> data;

  template <typename Mat>
  static Packed pack(const Mat& w, Index R) {
    Packed p;
    p.panel = R;
    p.rows = w.rows();
    p.cols = w.cols();
    const Index n_panels = (p.rows + R - 1) / R;
    p.data.assign(static_cast<std::size_t>(n_panels * R * p.cols), S(0));
    for (Index r = 0; r < p.rows; ++r)
      for (Index j = 0; j < p.cols; ++j)
        p.data[static_cast<std::size_t>((r / R) * R * p.cols + j * R + r % R)] =
            static_cast<S>(w(r, j));
    return p;
  }
};

/// Sequences per register tile of the batched product (Simd<Bytes>::kBatchRowVecs below).
constexpr int kBatchTile = 6;

/// Size of the scratch buffer product_body needs for B sequences and K columns.
inline Index product_scratch(Index B, Index K) {
  return (B + kBatchTile - 1) / kBatchTile * kBatchTile * K;
}

/// The kernels for vectors of Bytes bytes (16: SSE2, 32: AVX2, 64: AVX-512), instantiated inside the
/// functions compiled for that instruction set (Generic, Avx2, Avx512 below).
template <int Bytes>
struct Simd {
template <typename S>
static constexpr int lanes() {
  return Bytes / static_cast<int>(sizeof(S));
}
/// Rows of one packed panel: 8 vector registers of accumulators for one sequence, enough
/// independent multiply-add chains to hide the FMA latency.
template <typename S>
static constexpr int panel_rows() {
  return 8 * lanes<S>();
}
/// Register tile of the batched product: kBatchRowVecs vectors of rows x kBatchTile sequences of
/// accumulators, 2 x 6 = 12 of the 16 AVX2 registers, 4 x 6 = 24 of the 32 AVX-512 ones. Per
/// column a tile loads kBatchRowVecs weight vectors and broadcasts kBatchTile inputs for
/// kBatchRowVecs x kBatchTile multiply-adds; on AVX-512 4 x 6 (10 loads per 24 FMAs) was 3-7 %
/// faster at hidden 64/128 than 2 x 12 (14 loads), docs/lstm.md §7.
static constexpr int kBatchRowVecs = Bytes == 64 ? 4 : 2;

/// A vector of lanes<S>() values.
template <typename S>
struct Vec {
  typedef S type __attribute__((vector_size(Bytes)));
};
template <typename S>
using vec_t = typename Vec<S>::type;
template <typename S>
static TERRASPH_LSTM_INLINE void vload(vec_t<S>& v, const S* p) {
  std::memcpy(&v, p, sizeof v);
}
template <typename S>
static TERRASPH_LSTM_INLINE void vstore(S* p, const vec_t<S>& v) {
  std::memcpy(p, &v, sizeof v);
}

/// Register tile: for NB sequences b and the NV * lanes rows r of a panel slice w (column j at
/// w + j * ldw), g[b * ldg + r] = y0[b * ld0 + r] + sum_j w(r, j) z[j * kz + b], in column
/// order (y0 may be g itself; ld0 = 0 starts every sequence from the same y0, e.g. a bias).
/// Only the first n_rows rows are read and written.
template <int NV, int NB, typename S>
static TERRASPH_LSTM_INLINE void tile(const S* w, Index ldw, Index K, const S* z, Index kz,
                               const S* y0, Index ld0, S* g, Index ldg, Index n_rows) {
  constexpr int L = lanes<S>();
  constexpr int R = NV * L;
  S edge[NB][R];  // rows beyond n_rows of a partial slice: computed, never stored
  const bool full = n_rows == R;
  if (!full) {
    for (int b = 0; b < NB; ++b)
      for (int r = 0; r < R; ++r) edge[b][r] = r < n_rows ? y0[b * ld0 + r] : S(0);
  }
  vec_t<S> acc[NB][NV];
  TERRASPH_LSTM_UNROLL
  for (int b = 0; b < NB; ++b) {
    TERRASPH_LSTM_UNROLL
    for (int v = 0; v < NV; ++v) vload<S>(acc[b][v], full ? y0 + b * ld0 + v * L : &edge[b][v * L]);
  }
  TERRASPH_LSTM_UNROLL_4  // fewer loop instructions per column; the same sum order
  for (Index j = 0; j < K; ++j) {
    const S* col = w + j * ldw;
    TERRASPH_LSTM_UNROLL
    for (int b = 0; b < NB; ++b) {
      const S zb = z[j * kz + b];
      TERRASPH_LSTM_UNROLL
      for (int v = 0; v < NV; ++v) {
        vec_t<S> wv;
        vload<S>(wv, col + v * L);
        acc[b][v] += wv * zb;
      }
    }
  }
  TERRASPH_LSTM_UNROLL
  for (int b = 0; b < NB; ++b) {
    TERRASPH_LSTM_UNROLL
    for (int v = 0; v < NV; ++v) vstore<S>(full ? g + b * ldg + v * L : &edge[b][v * L], acc[b][v]);
  }
  if (!full) {
    for (int b = 0; b < NB; ++b)
      for (int r = 0; r < n_rows; ++r) g[b * ldg + r] = edge[b][r];
  }
}

// tile<NV, nb> for a run-time nb in [1, NB].
template <int NV, int NB, typename S>
static TERRASPH_LSTM_INLINE void tile_nb(int nb, const S* w, Index ldw, Index K, const S* z, Index kz,
                                  const S* y0, Index ld0, S* g, Index ldg, Index n_rows) {
  if (nb == NB) {
    tile<NV, NB>(w, ldw, K, z, kz, y0, ld0, g, ldg, n_rows);
  } else if constexpr (NB > 1) {
    tile_nb<NV, NB - 1>(nb, w, ldw, K, z, kz, y0, ld0, g, ldg, n_rows);
  }
}

// tile<nv, nb> for a run-time nv in [1, NV] and nb in [1, NB].
template <int NV, int NB, typename S>
static TERRASPH_LSTM_INLINE void tile_nv_nb(int nv, int nb, const S* w, Index ldw, Index K, const S* z,
                                     Index kz, const S* y0, Index ld0, S* g, Index ldg,
                                     Index n_rows) {
  if (nv == NV) {
    tile_nb<NV, NB>(nb, w, ldw, K, z, kz, y0, ld0, g, ldg, n_rows);
  } else if constexpr (NV > 1) {
    tile_nv_nb<NV - 1, NB>(nv, nb, w, ldw, K, z, kz, y0, ld0, g, ldg, n_rows);
  }
}

// tile<nv, 1> for a run-time nv in [1, NV].
template <int NV, typename S>
static TERRASPH_LSTM_INLINE void tile_nv(int nv, const S* w, Index ldw, Index K, const S* z,
                                  const S* y0, S* g, Index n_rows) {
  if (nv == NV) {
    tile<NV, 1>(w, ldw, K, z, 1, y0, 0, g, 0, n_rows);
  } else if constexpr (NV > 1) {
    tile_nv<NV - 1>(nv, w, ldw, K, z, y0, g, n_rows);
  }
}

/// Whether a single sequence's step is compiled with the hidden size H as a constant (the
/// step's loops unrolled, no partial vectors), as RTNeural compiles every size: for the small
/// sizes, where loop bookkeeping is a large part of a step, and only for whole vectors.
template <typename S>
static constexpr bool fixed_hidden(Index H) {
  return (H == 16 || H == 32) && H % lanes<S>() == 0;
}

/// tile<NV, 1> on whole vectors for one sequence whose last KH columns are the hidden state:
/// g = y0 + sum_j w(:, j) z_j over the K0 input columns, then over the KH hidden columns
/// (fully unrolled). The same sums in the same order as tile.
template <int NV, int KH, typename S>
static TERRASPH_LSTM_INLINE void tile_fixed(const S* w, Index K0, const S* z, const S* y0, S* g) {
  constexpr int L = lanes<S>();
  constexpr Index R = panel_rows<S>();
  vec_t<S> acc[NV];
  TERRASPH_LSTM_UNROLL
  for (int v = 0; v < NV; ++v) vload<S>(acc[v], y0 + v * L);
  TERRASPH_LSTM_UNROLL_4
  for (Index j = 0; j < K0; ++j) {
    const S zj = z[j];
    TERRASPH_LSTM_UNROLL
    for (int v = 0; v < NV; ++v) {
      vec_t<S> wv;
      vload<S>(wv, w + j * R + v * L);
      acc[v] += wv * zj;
    }
  }
  const S* wh = w + K0 * R;
  const S* zh = z + K0;
  TERRASPH_LSTM_UNROLL_64
  for (int j = 0; j < KH; ++j) {
    const S zj = zh[j];
    TERRASPH_LSTM_UNROLL
    for (int v = 0; v < NV; ++v) {
      vec_t<S> wv;
      vload<S>(wv, wh + j * R + v * L);
      acc[v] += wv * zj;
    }
  }
  TERRASPH_LSTM_UNROLL
  for (int v = 0; v < NV; ++v) vstore<S>(g + v * L, acc[v]);
}

/// product_body for one sequence of a layer with the hidden size HC fixed (fixed_hidden):
/// g[:4 HC] = y0 + W z, z = [u_t ; h_{t-1}], panel P and the following ones.
template <int HC, int P = 0, typename S>
static TERRASPH_LSTM_INLINE void product_fixed(const Packed<S>& W, const S* z, const S* y0, S* g) {
  constexpr int n_vec = 4 * HC / lanes<S>();
  constexpr Index R = panel_rows<S>();
  tile_fixed<std::min(8, n_vec - 8 * P), HC>(W.data.data() + P * R * W.cols, W.cols - HC, z,
                                               y0 + P * R, g + P * R);
  if constexpr (8 * (P + 1) < n_vec) product_fixed<HC, P + 1>(W, z, y0, g);
}


/// G[b, :rows] = Y0[b, :rows] + W Z[b, :cols] for b < B (Z, Y0 and G row-major with leading
/// dimensions ldz, ld0 and ldg; Y0 may be G, ld0 = 0 gives every sequence the same start, e.g.
/// the bias, which thus costs no separate copy). One sequence: whole panels, 8 vectors of rows
/// per pass over the weights. Several:
/// Z is first copied into `scratch` (product_scratch(B, cols) values) in blocks of kBatchTile
/// sequences, column after column, so a tile reads it sequentially; then slices of
/// kBatchRowVecs vectors of rows meet each block, so every weight loaded serves kBatchTile
/// sequences.
template <typename S>
static TERRASPH_LSTM_INLINE void product_body(const Packed<S>& W, Index B, const S* Z, Index ldz,
                                       const S* Y0, Index ld0, S* G, Index ldg, S* scratch) {
  constexpr int L = lanes<S>();
  constexpr Index R = panel_rows<S>();
  const Index K = W.cols;
  if (B == 1) {
    for (Index r0 = 0; r0 < W.rows; r0 += R) {
      const Index n_rows = std::min(R, W.rows - r0);
      tile_nv<8>(static_cast<int>((n_rows + L - 1) / L), W.data.data() + r0 * K, R, K, Z,
                 Y0 + r0, G + r0, n_rows);
    }
    return;
  }
  constexpr Index NB = kBatchTile;
  for (Index b0 = 0; b0 < B; b0 += NB) {
    S* blk = scratch + b0 * K;
    for (Index j = 0; j < K; ++j)
      for (Index b = 0; b < NB; ++b) blk[j * NB + b] = b0 + b < B ? Z[(b0 + b) * ldz + j] : S(0);
  }
  for (Index r0 = 0; r0 < W.rows; r0 += R) {
    const S* panel = W.data.data() + r0 * K;
    const Index n_rows = std::min(R, W.rows - r0);
    constexpr Index RS = kBatchRowVecs * L;  // rows of a slice
    for (Index s = 0; s < n_rows; s += RS) {
      const Index rows_s = std::min<Index>(RS, n_rows - s);
      const int nv = static_cast<int>((rows_s + L - 1) / L);
      for (Index b0 = 0; b0 < B; b0 += NB) {
        const int nb = static_cast<int>(std::min<Index>(NB, B - b0));
        const S* y0 = Y0 + b0 * ld0 + r0 + s;
        S* g = G + b0 * ldg + r0 + s;
        tile_nv_nb<kBatchRowVecs, NB>(nv, nb, panel + s, R, K, scratch + b0 * K, NB, y0, ld0, g, ldg,
                                      rows_s);
      }
    }
  }
}

// ---- gate nonlinearities and cell updates, on whole vectors --------------------------------
// Every element goes through the same vector instructions: a row's last partial vector is
// loaded zero-padded and only its valid lanes are stored, so results do not depend on where an
// element sits in a row (or in a batch).

/// v = the n <= lanes values at p, zero-padded.
template <typename S>
static TERRASPH_LSTM_INLINE void load_part(vec_t<S>& v, const S* p, Index n) {
  if (n == lanes<S>()) {
    vload<S>(v, p);
    return;
  }
  S tmp[lanes<S>()] = {};
  std::copy(p, p + n, tmp);
  vload<S>(v, tmp);
}
/// The first n <= lanes values of v to p.
template <typename S>
static TERRASPH_LSTM_INLINE void store_part(S* p, const vec_t<S>& v, Index n) {
  if (n == lanes<S>()) {
    vstore<S>(p, v);
    return;
  }
  S tmp[lanes<S>()];
  vstore<S>(tmp, v);
  std::copy(tmp, tmp + n, p);
}

/// Eigen's rational approximation of tanh in float (Eigen 3.4 MathFunctionsImpl.h,
/// generic_fast_tanh_float; max error a few ulp), lane-wise, clamped where it reaches +-1.
/// (Eigen also returns a itself for |a| < 4e-4, a relative refinement of < 2e-7 dropped here.)
static TERRASPH_LSTM_INLINE void tanh_v(vec_t<float>& a) {
  using V = vec_t<float>;
  const V lim = V{} + 7.90531110763549805f;
  V x = a > lim ? lim : a;
  x = x < -lim ? -lim : x;
  const V x2 = x * x;
  V p = x2 * -2.76076847742355e-16f + 2.00018790482477e-13f;
  p = x2 * p + -8.60467152213735e-11f;
  p = x2 * p + 5.12229709037114e-08f;
  p = x2 * p + 1.48572235717979e-05f;
  p = x2 * p + 6.37261928875436e-04f;
  p = x2 * p + 4.89352455891786e-03f;
  p = x * p;
  V q = x2 * 1.19825839466702e-06f + 1.18534705686654e-04f;
  q = x2 * q + 2.26843463243900e-03f;
  q = x2 * q + 4.89352518554385e-03f;
  a = p / q;
}
/// Logistic sigma(a) = (1 + tanh(a/2)) / 2 in float, lane-wise (absolute error ~1e-7).
static TERRASPH_LSTM_INLINE void sigmoid_v(vec_t<float>& a) {
  a *= 0.5f;
  tanh_v(a);
  a = 0.5f + 0.5f * a;
}
/// tanh and logistic in double, lane-wise: the C library's functions.
static TERRASPH_LSTM_INLINE void tanh_v(vec_t<double>& a) {
  for (int k = 0; k < lanes<double>(); ++k) a[k] = std::tanh(a[k]);
}
static TERRASPH_LSTM_INLINE void sigmoid_v(vec_t<double>& a) {
  for (int k = 0; k < lanes<double>(); ++k) a[k] = 1.0 / (1.0 + std::exp(-a[k]));
}

/// Sum of the N values at p (N a power of two) as a tree: the upper half added to the lower one,
/// lane-wise on a vector of N / 2, until two values are left.
template <typename S, int N>
static TERRASPH_LSTM_INLINE S lane_sum(const S* p) {
  if constexpr (N == 1) {
    return p[0];
  } else if constexpr (N == 2) {
    return p[0] + p[1];
  } else {
    typedef S half __attribute__((vector_size(N / 2 * sizeof(S))));
    half lo, hi;
    std::memcpy(&lo, p, sizeof lo);
    std::memcpy(&hi, p + N / 2, sizeof hi);
    lo += hi;
    S t[N / 2];
    std::memcpy(t, &lo, sizeof lo);
    return lane_sum<S, N / 2>(t);
  }
}

/// y[o] = y0[o] + sum_j w[o * ldw + j] h[j] for o < O (the dense head of one sequence): 4 vector
/// accumulators over consecutive chunks of h (chunk c into accumulator c mod 4, the last chunk
/// zero-padded), added as (a0 + a1) + (a2 + a3), then the lanes pairwise (halves, quarters, ...)
/// and the bias. A fixed order, the
/// same for every sequence of a batch; short dependency chains instead of one of length H.
template <typename S>
static TERRASPH_LSTM_INLINE void head_dot(const S* w, Index ldw, Index O, Index H, const S* h,
                                   const S* y0, S* y) {
  constexpr int L = lanes<S>();
  for (Index o = 0; o < O; ++o) {
    const S* row = w + o * ldw;
    vec_t<S> acc[4] = {};
    Index j = 0;
    for (; j + 4 * L <= H; j += 4 * L) {  // whole groups of 4 chunks
      TERRASPH_LSTM_UNROLL
      for (int a = 0; a < 4; ++a) {
        vec_t<S> wv, hv;
        vload<S>(wv, row + j + a * L);
        vload<S>(hv, h + j + a * L);
        acc[a] += wv * hv;
      }
    }
    // the last 1-4 chunks (fewer than 4 L values are left), the very last zero-padded; a 4th
    // chunk (H mod 4 L > 3 L, e.g. H = 13 in double with AVX2) was once dropped
    TERRASPH_LSTM_UNROLL
    for (int a = 0; a < 4; ++a) {
      if (j >= H) break;
      const Index n = std::min<Index>(L, H - j);
      vec_t<S> wv, hv;
      load_part<S>(wv, row + j, n);
      load_part<S>(hv, h + j, n);
      acc[a] += wv * hv;
      j += L;
    }
    S lane[L];
    vstore<S>(lane, (acc[0] + acc[1]) + (acc[2] + acc[3]));
    y[o] = y0[o] + lane_sum<S, L>(lane);
  }
}

// Cell updates of one sequence; g holds the 4H gate pre-activations (blocks i, f, g, o).

/// standard_cell on the n values of one vector (n = lanes, a compile-time constant for whole
/// vectors, or fewer in a row's zero-padded last vector).
template <typename S>
static TERRASPH_LSTM_INLINE void standard_cell_vec(Index H, const S* g, S* c, S* h, Index n) {
  vec_t<S> i, f, cand, o, cv;
  load_part<S>(i, g, n);
  load_part<S>(f, g + H, n);
  load_part<S>(cand, g + 2 * H, n);
  load_part<S>(o, g + 3 * H, n);
  load_part<S>(cv, c, n);
  sigmoid_v(i);
  sigmoid_v(f);
  tanh_v(cand);
  sigmoid_v(o);
  cv = f * cv + i * cand;
  store_part<S>(c, cv, n);
  tanh_v(cv);
  store_part<S>(h, o * cv, n);
}
/// Standard cell (torch.nn.LSTM): c_t = f c_{t-1} + i g,  h_t = o tanh(c_t).
template <typename S>
static TERRASPH_LSTM_INLINE void standard_cell(Index H, const S* g, S* c, S* h) {
  constexpr Index L = lanes<S>();
  Index k = 0;
  for (; k + L <= H; k += L) standard_cell_vec(H, g + k, c + k, h + k, L);
  if (k < H) standard_cell_vec(H, g + k, c + k, h + k, H - k);
}
/// Peephole cell, first half: i and f (Eq. 4.9, 4.10; peephole terms already in g), then
/// c_t = f c_{t-1} + i tanh(g) (Eq. 4.11).
template <typename S>
static TERRASPH_LSTM_INLINE void peephole_cell_state(Index H, const S* g, S* c) {
  for (Index k = 0; k < H; k += lanes<S>()) {
    const Index n = std::min<Index>(lanes<S>(), H - k);
    vec_t<S> i, f, cand, cv;
    load_part<S>(i, g + k, n);
    load_part<S>(f, g + H + k, n);
    load_part<S>(cand, g + 2 * H + k, n);
    load_part<S>(cv, c + k, n);
    sigmoid_v(i);
    sigmoid_v(f);
    tanh_v(cand);
    store_part<S>(c + k, f * cv + i * cand, n);
  }
}
/// Peephole cell, second half: o = sigma(g_o + W_co c_t) (Eq. 4.12, W_co c_t already in g_o),
/// h_t = o tanh(c_t) (Eq. 4.13).
template <typename S>
static TERRASPH_LSTM_INLINE void peephole_output(Index H, const S* g_o, const S* c, S* h) {
  for (Index k = 0; k < H; k += lanes<S>()) {
    const Index n = std::min<Index>(lanes<S>(), H - k);
    vec_t<S> o, cv;
    load_part<S>(o, g_o + k, n);
    load_part<S>(cv, c + k, n);
    sigmoid_v(o);
    tanh_v(cv);
    store_part<S>(h + k, o * cv, n);
  }
}

};  // struct Simd

/// Instruction sets the kernels are compiled for, with their vector width in bytes: Generic
/// (the build's flags) and, when dispatching, Avx2 (AVX2 + FMA) and Avx512.
struct Generic {
  static constexpr int bytes = kSimdBytes;
};
struct Avx2 {
  static constexpr int bytes = 32;
};
struct Avx512 {
  static constexpr int bytes = 64;
};

/// Rows of a packed panel for the kernels of `isa`.
template <typename S>
inline Index panel_rows_for(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::Avx2:
      return Simd<Avx2::bytes>::panel_rows<S>();
    case KernelIsa::Avx512:
      return Simd<Avx512::bytes>::panel_rows<S>();
    default:
      return Simd<Generic::bytes>::panel_rows<S>();
  }
}

// product_body compiled once per instruction set (not inlined: it holds all the tile variants).
template <typename S>
__attribute__((noinline)) void product(Generic, const Packed<S>& W, Index B, const S* Z,
                                       Index ldz, const S* Y0, Index ld0, S* G, Index ldg,
                                       S* scratch) {
  Simd<Generic::bytes>::product_body(W, B, Z, ldz, Y0, ld0, G, ldg, scratch);
}
#ifdef TERRASPH_LSTM_AVX2_DISPATCH
template <typename S>
__attribute__((noinline, target("avx2,fma"))) void product(Avx2, const Packed<S>& W, Index B,
                                                           const S* Z, Index ldz, const S* Y0,
                                                           Index ld0, S* G, Index ldg,
                                                           S* scratch) {
  Simd<Avx2::bytes>::product_body(W, B, Z, ldz, Y0, ld0, G, ldg, scratch);
}
template <typename S>
__attribute__((noinline, target("avx512f,avx2,fma"))) void product(Avx512, const Packed<S>& W,
                                                                   Index B, const S* Z,
                                                                   Index ldz, const S* Y0,
                                                                   Index ld0, S* G, Index ldg,
                                                                   S* scratch) {
  Simd<Avx512::bytes>::product_body(W, B, Z, ldz, Y0, ld0, G, ldg, scratch);
}
#endif

}  // namespace detail
}  // namespace lstm
}  // namespace terrasph
