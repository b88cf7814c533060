// Streaming step of terrasph::lstm::Stream<float> against RTNeural's compile-time LSTM
// (ModelT<LSTMLayerT, DenseT>, Eigen backend): same weights (read from one .tslstm file), same
// compiler flags, one program, timings interleaved. RTNeural is not part of terrasph: this file
// is compiled by benchmarks/peers/bench_lstm_rtneural.py against a checkout the user supplies.
//
//   lstm_vs_rtneural STEPS REPEATS H16.tslstm H32.tslstm H64.tslstm H128.tslstm
//
// Both sides do the same work per step: normalise the 4 raw inputs, one LSTM layer, the dense
// head to 2 outputs, de-normalise. Prints one line per hidden size: ns per step of each (best
// of REPEATS timings of STEPS steps) and the largest output difference over the timed inputs.
// RTNeural's Eigen backend knows alignments 8, 16 and 32 only (RTNeural/common.h; its CMake
// option RTNEURAL_USE_AVX sets 32): with AVX-512, too, it is built with 32 (Eigen then loads its
// 64-byte packets unaligned where it cannot prove more; its own fixed-size members are aligned to
// 64 anyway).
#if !defined(RTNEURAL_DEFAULT_ALIGNMENT)
#if defined(__AVX__)
#define RTNEURAL_DEFAULT_ALIGNMENT 32
#else
#define RTNEURAL_DEFAULT_ALIGNMENT 16
#endif
#endif
#define RTNEURAL_USE_EIGEN 1
#define EIGEN_STACK_ALLOCATION_LIMIT 0  // RTNeural's fixed-size H = 128 weights exceed 128 KB
#include <RTNeural/RTNeural.h>
#include <terrasph/lstm.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

namespace {

constexpr int kIn = 4, kOut = 2;

template <int H>
using RtModel = RTNeural::ModelT<float, kIn, kOut, RTNeural::LSTMLayerT<float, kIn, H>,
                                 RTNeural::DenseT<float, H, kOut>>;

// Columns of a row-major (rows x cols) float64 matrix as rows: RTNeural's [in][4H] layout.
std::vector<std::vector<float>> transposed(const std::vector<double>& m, int rows, int cols) {
  std::vector<std::vector<float>> t(static_cast<std::size_t>(cols),
                                    std::vector<float>(static_cast<std::size_t>(rows)));
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      t[static_cast<std::size_t>(c)][static_cast<std::size_t>(r)] =
          static_cast<float>(m[static_cast<std::size_t>(r * cols + c)]);
  return t;
}

template <int H>
void load_rtneural(const terrasph::lstm::ModelData& d, RtModel<H>& rt) {
  const auto& L = d.layers.at(0);
  auto& lstm = rt.template get<0>();
  lstm.setWVals(transposed(L.w_ih, 4 * H, kIn));  // RTNeural's torch_helpers::loadLSTM
  lstm.setUVals(transposed(L.w_hh, 4 * H, H));
  lstm.setBVals(std::vector<float>(L.bias.begin(), L.bias.end()));
  std::vector<std::vector<float>> w(kOut, std::vector<float>(H));
  for (int o = 0; o < kOut; ++o)
    for (int k = 0; k < H; ++k) w[o][k] = static_cast<float>(d.w_out[static_cast<std::size_t>(o * H + k)]);
  auto& dense = rt.template get<1>();
  dense.setWeights(w);
  std::vector<float> b(d.b_out.begin(), d.b_out.end());
  dense.setBias(b.data());
  rt.reset();
}

template <typename F>
double seconds(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <int H>
void bench(const char* path, int steps, int repeats) {
  const terrasph::lstm::ModelData d = terrasph::lstm::read_model_file(path);
  if (d.layers.size() != 1 || d.layers[0].hidden_size != H || d.input_size != kIn ||
      d.output_size != kOut || d.cell != terrasph::lstm::CellType::Standard) {
    std::fprintf(stderr, "%s: expected a 1-layer standard LSTM, %d -> %d -> %d\n", path, kIn, H,
                 kOut);
    std::exit(1);
  }
  auto model = std::make_shared<const terrasph::lstm::Model<float>>(d);
  terrasph::lstm::Stream<float> ts(model);
  auto rt = std::make_unique<RtModel<H>>();  // aligned members: heap, not stack
  load_rtneural<H>(d, *rt);

  std::mt19937 rng(H);
  std::normal_distribution<float> normal;
  std::vector<float> x(static_cast<std::size_t>(steps * kIn));
  for (auto& v : x) v = normal(rng);
  std::vector<float> y_ts(static_cast<std::size_t>(steps * kOut)),
      y_rt(static_cast<std::size_t>(steps * kOut));
  float mean_in[kIn], scale_in[kIn], mean_out[kOut], scale_out[kOut];
  for (int j = 0; j < kIn; ++j) {
    mean_in[j] = static_cast<float>(d.input_mean[j]);
    scale_in[j] = static_cast<float>(d.input_scale[j]);
  }
  for (int o = 0; o < kOut; ++o) {
    mean_out[o] = static_cast<float>(d.output_mean[o]);
    scale_out[o] = static_cast<float>(d.output_scale[o]);
  }

  auto run_terrasph = [&] {
    ts.reset();
    for (int t = 0; t < steps; ++t) ts.step(&x[t * kIn], &y_ts[t * kOut]);
  };
  auto run_rtneural = [&] {
    rt->reset();
    alignas(64) float xn[kIn];
    for (int t = 0; t < steps; ++t) {
      for (int j = 0; j < kIn; ++j) xn[j] = (x[t * kIn + j] - mean_in[j]) / scale_in[j];
      rt->forward(xn);
      const float* out = rt->getOutputs();
      for (int o = 0; o < kOut; ++o) y_rt[t * kOut + o] = out[o] * scale_out[o] + mean_out[o];
    }
  };
  double best_ts = 1e30, best_rt = 1e30;
  for (int r = 0; r < repeats; ++r) {  // interleaved A/B
    best_ts = std::min(best_ts, seconds(run_terrasph));
    best_rt = std::min(best_rt, seconds(run_rtneural));
  }
  double diff = 0;
  for (std::size_t k = 0; k < y_ts.size(); ++k)
    diff = std::max(diff, static_cast<double>(std::abs(y_ts[k] - y_rt[k])));
  std::printf("%d %.1f %.1f %.3g %s\n", H, best_ts / steps * 1e9, best_rt / steps * 1e9, diff,
              model->kernel_isa());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 7) {
    std::fprintf(stderr, "usage: %s STEPS REPEATS H16 H32 H64 H128 (.tslstm files)\n", argv[0]);
    return 1;
  }
  const int steps = std::atoi(argv[1]), repeats = std::atoi(argv[2]);
  bench<16>(argv[3], steps, repeats);
  bench<32>(argv[4], steps, repeats);
  bench<64>(argv[5], steps, repeats);
  bench<128>(argv[6], steps, repeats);
  return 0;
}
