// terrasph LSTM inference engine: header-only, C++17, Eigen only (no Python, no PyTorch).
//
// Usage from robot code:
//
//   #include <terrasph/lstm.hpp>
//   auto model = terrasph::lstm::Model<float>::load("wheel.tslstm");   // shared, immutable
//   terrasph::lstm::Stream<float> stream(model);                      // owns the state
//   float x[NI], y[NO];
//   stream.step(x, y);            // one time step: raw features in, raw targets out
//   stream.reset();               // start a new sequence
//   terrasph::lstm::Batch<float> batch(model, 64);   // 64 sequences advanced together
//   batch.step(x64, y64);         // x64 (64, NI) row-major -> y64 (64, NO)
//
// Model holds the constants (weights, normalisation) and Stream/Batch the state (h, c and work
// buffers, allocated once), so one model can serve many independent streams. A step performs
// no heap allocation. Whole-sequence prediction runs the very same step, so it is bit-for-bit
// equal to streaming, and a batch is bit-for-bit equal to its sequences run one by one
// (lstm_kernels.hpp says why). The file format is documented in docs/lstm_format.md.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "terrasph/lstm_format.hpp"
#include "terrasph/lstm_kernels.hpp"

namespace terrasph {
namespace lstm {

/// One recurrent layer in the working precision.
template <typename Scalar>
struct Layer {
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor>;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  Eigen::Index input_size = 0;
  Eigen::Index hidden_size = 0;
  Matrix w;     // (4H, in + H) = [W_ih | W_hh], gate rows in PyTorch order i, f, g, o
  Vector bias;  // (4H,) = b_ih + b_hh
  Matrix w_ci, w_cf, w_co;  // (H, H) peephole matrices (Eq. 4.9, 4.10, 4.12); empty if standard
  // The same matrices in the kernels' panel layout (detail::Packed): w, [W_ci; W_cf] stacked
  // (both act on c_{t-1}), W_co.
  detail::Packed<Scalar> w_packed, w_cif_packed, w_co_packed;
};

/// Immutable model: cell type, layer weights, dense head and normalisation.
template <typename Scalar>
class Model {
 public:
  using Matrix = typename Layer<Scalar>::Matrix;
  using Vector = typename Layer<Scalar>::Vector;

  /// Build from parsed file data (float64), converting to Scalar.
  explicit Model(const ModelData& d)
      : cell_(d.cell),
        input_size_(static_cast<Eigen::Index>(d.input_size)),
        output_size_(static_cast<Eigen::Index>(d.output_size)),
        feature_names_(d.feature_names),
        target_names_(d.target_names),
        metadata_(d.metadata) {
    if (d.layers.empty()) throw std::invalid_argument("LSTM model: num_layers must be >= 1");
    in_mean_ = to_vector(d.input_mean, input_size_, "input_mean");
    in_scale_ = to_vector(d.input_scale, input_size_, "input_scale");
    in_inv_scale_ = in_scale_;  // 1 / scale in double, rounded once: the step multiplies
    for (Eigen::Index j = 0; j < input_size_; ++j)
      in_inv_scale_[j] = static_cast<Scalar>(1.0 / d.input_scale[static_cast<std::size_t>(j)]);
    out_mean_ = to_vector(d.output_mean, output_size_, "output_mean");
    out_scale_ = to_vector(d.output_scale, output_size_, "output_scale");
    const Eigen::Index panel = detail::panel_rows_for<Scalar>(isa_);  // the chosen kernels' layout
    Eigen::Index in = input_size_;
    for (const LayerData& ld : d.layers) {
      Layer<Scalar> L;
      const Eigen::Index H = static_cast<Eigen::Index>(ld.hidden_size);
      if (static_cast<Eigen::Index>(ld.input_size) != in || H < 1) {
        throw std::invalid_argument("LSTM model: layer input_size must equal the previous "
                                    "layer's hidden_size");
      }
      L.input_size = in;
      L.hidden_size = H;
      L.w.resize(4 * H, in + H);
      L.w.leftCols(in) = to_matrix(ld.w_ih, 4 * H, in, "weight_ih");
      L.w.rightCols(H) = to_matrix(ld.w_hh, 4 * H, H, "weight_hh");
      L.bias = to_vector(ld.bias, 4 * H, "bias");
      if (cell_ == CellType::Peephole) {
        L.w_ci = to_matrix(ld.w_ci, H, H, "weight_ci");
        L.w_cf = to_matrix(ld.w_cf, H, H, "weight_cf");
        L.w_co = to_matrix(ld.w_co, H, H, "weight_co");
        Matrix cif(2 * H, H);
        cif << L.w_ci, L.w_cf;
        L.w_cif_packed = detail::Packed<Scalar>::pack(cif, panel);
        L.w_co_packed = detail::Packed<Scalar>::pack(L.w_co, panel);
      }
      L.w_packed = detail::Packed<Scalar>::pack(L.w, panel);
      layers_.push_back(std::move(L));
      in = H;
    }
    w_out_ = to_matrix(d.w_out, output_size_, in, "head weight");
    b_out_ = to_vector(d.b_out, output_size_, "head bias");
    for (double v : d.w_out) w_out_rows_.push_back(static_cast<Scalar>(v));  // row-major (O, H)
  }

  /// Load a model file; throws FormatError on any malformed content.
  static std::shared_ptr<const Model> load(const std::string& path) {
    return std::make_shared<const Model>(read_model_file(path));
  }
  /// Load from bytes in memory; throws FormatError on any malformed content.
  static std::shared_ptr<const Model> from_bytes(const unsigned char* data, std::size_t size) {
    return std::make_shared<const Model>(parse_model(data, size));
  }

  CellType cell_type() const { return cell_; }
  Eigen::Index input_size() const { return input_size_; }
  Eigen::Index output_size() const { return output_size_; }
  Eigen::Index num_layers() const { return static_cast<Eigen::Index>(layers_.size()); }
  const std::vector<Layer<Scalar>>& layers() const { return layers_; }
  const std::vector<std::string>& feature_names() const { return feature_names_; }
  const std::vector<std::string>& target_names() const { return target_names_; }
  const std::string& metadata() const { return metadata_; }
  const Vector& input_mean() const { return in_mean_; }
  const Vector& input_scale() const { return in_scale_; }
  /// 1 / input_scale (the step normalises as x_n = (x - mean) * (1 / scale)).
  const Vector& input_inv_scale() const { return in_inv_scale_; }
  const Vector& output_mean() const { return out_mean_; }
  const Vector& output_scale() const { return out_scale_; }
  const Matrix& head_weight() const { return w_out_; }
  const Vector& head_bias() const { return b_out_; }
  /// The head weight row-major (O rows of H_last), as detail::head_dot reads it.
  const std::vector<Scalar>& head_weight_rows() const { return w_out_rows_; }
  /// True if the kernels run the variant compiled for AVX2 + FMA, chosen at run time.
  bool uses_avx2() const { return isa_ == detail::KernelIsa::Avx2; }
  /// The kernel variant this model runs: "generic" (the build's own flags), or, chosen at run
  /// time by a baseline build, "avx2" (AVX2 + FMA) or "avx512" (AVX-512 F).
  const char* kernel_isa() const {
    return isa_ == detail::KernelIsa::Avx512 ? "avx512"
           : isa_ == detail::KernelIsa::Avx2 ? "avx2"
                                             : "generic";
  }
  detail::KernelIsa isa() const { return isa_; }

 private:
  static Vector to_vector(const std::vector<double>& v, Eigen::Index n, const char* what) {
    if (static_cast<Eigen::Index>(v.size()) != n) {
      throw std::invalid_argument(std::string("LSTM model: '") + what + "' has " +
                                  std::to_string(v.size()) + " values, expected " +
                                  std::to_string(n));
    }
    return Eigen::Map<const Eigen::VectorXd>(v.data(), n).template cast<Scalar>();
  }
  static Matrix to_matrix(const std::vector<double>& v, Eigen::Index rows, Eigen::Index cols,
                          const char* what) {
    if (static_cast<Eigen::Index>(v.size()) != rows * cols) {
      throw std::invalid_argument(std::string("LSTM model: '") + what + "' has " +
                                  std::to_string(v.size()) + " values, expected " +
                                  std::to_string(rows) + "x" + std::to_string(cols));
    }
    using RowMajorXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    return Eigen::Map<const RowMajorXd>(v.data(), rows, cols).template cast<Scalar>();
  }

  CellType cell_;
  Eigen::Index input_size_, output_size_;
  std::vector<std::string> feature_names_, target_names_;
  std::string metadata_;
  Vector in_mean_, in_scale_, in_inv_scale_, out_mean_, out_scale_;
  std::vector<Layer<Scalar>> layers_;
  Matrix w_out_;
  Vector b_out_;
  std::vector<Scalar> w_out_rows_;
  detail::KernelIsa isa_ = detail::default_isa();
};

namespace detail {

/// State and work buffers of B sequences, row-major (one row per sequence): per layer
/// z = [u_t ; h_{t-1}] (in + H), c (H) and the gate pre-activations g (4H).
template <typename S>
struct Workspace {
  Index batch = 0;
  std::vector<AlignedVector<S>> z, c, g;
  AlignedVector<S> scratch;  // inputs of a batched product in tile order (product_body)

  Workspace(const Model<S>& m, Index B) : batch(B) {
    Index k_max = 0;
    for (const auto& L : m.layers()) {
      k_max = std::max(k_max, L.input_size + L.hidden_size);
      const auto H = static_cast<std::size_t>(L.hidden_size);
      z.emplace_back(static_cast<std::size_t>(B) * (static_cast<std::size_t>(L.input_size) + H));
      c.emplace_back(static_cast<std::size_t>(B) * H);
      g.emplace_back(static_cast<std::size_t>(B) * 4 * H);
    }
    if (B > 1) scratch.resize(static_cast<std::size_t>(product_scratch(B, k_max)));
  }
  void reset() {
    for (auto& v : z) std::fill(v.begin(), v.end(), S(0));
    for (auto& v : c) std::fill(v.begin(), v.end(), S(0));
  }
};

/// One standard layer of one sequence with the hidden size HC fixed at compile time
/// (fixed_hidden): the arithmetic of layer_step, unrolled.
template <typename K, int HC, typename S>
TERRASPH_LSTM_INLINE void standard_layer_fixed(const Layer<S>& L, S* z, S* c, S* g) {
  K::template product_fixed<HC>(L.w_packed, z, L.bias.data(), g);
  K::standard_cell(HC, g, c, z + L.input_size);
}

/// One recurrent layer for all B sequences: gates, cell update, h_t into z's tail.
template <typename Isa, int kBatch, typename S>
TERRASPH_LSTM_INLINE void layer_step(const Layer<S>& L, CellType cell, Index B, S* z, S* c,
                                     S* g, S* scratch) {
  using K = Simd<Isa::bytes>;
  const Index H = L.hidden_size, ldz = L.input_size + H;
  if constexpr (kBatch == 1) {
    if (cell == CellType::Standard && K::template fixed_hidden<S>(H)) {
      if (H == 16) {
        standard_layer_fixed<K, 16>(L, z, c, g);
      } else {
        standard_layer_fixed<K, 32>(L, z, c, g);
      }
      return;
    }
  }
  // g = b + W_ih u_t + W_hh h_{t-1}, all four gates
  product(Isa{}, L.w_packed, B, z, ldz, L.bias.data(), 0, g, 4 * H, scratch);
  if (cell == CellType::Standard) {
    for (Index b = 0; b < B; ++b)
      K::standard_cell(H, g + b * 4 * H, c + b * H, z + b * ldz + ldz - H);
    return;
  }
  // + W_ci c_{t-1} (4.9), + W_cf c_{t-1} (4.10)
  product(Isa{}, L.w_cif_packed, B, c, H, g, 4 * H, g, 4 * H, scratch);
  for (Index b = 0; b < B; ++b) K::peephole_cell_state(H, g + b * 4 * H, c + b * H);
  // + W_co c_t (4.12)
  product(Isa{}, L.w_co_packed, B, c, H, g + 3 * H, 4 * H, g + 3 * H, 4 * H, scratch);
  for (Index b = 0; b < B; ++b)
    K::peephole_output(H, g + b * 4 * H + 3 * H, c + b * H, z + b * ldz + ldz - H);
}

/// One time step of B sequences: x (B rows of I raw features, leading dimension ldx) ->
/// y (B rows of O raw targets, leading dimension ldy). kBatch = 1 compiles the loops over the
/// sequences away for a single stream (the same arithmetic); kBatch = 0 takes B from ws.
template <typename Isa, int kBatch, typename S>
TERRASPH_LSTM_INLINE void advance_body(const Model<S>& m, Workspace<S>& ws, const S* x,
                                       Index ldx, S* y, Index ldy) {
  using K = Simd<Isa::bytes>;
  const Index B = kBatch > 0 ? kBatch : ws.batch, ni = m.input_size(), no = m.output_size();
  const std::size_t n_layers = m.layers().size();
  {
    const Index ldz = ni + m.layers()[0].hidden_size;
    const S *mean = m.input_mean().data(), *inv_scale = m.input_inv_scale().data();
    S* z = ws.z[0].data();
    for (Index b = 0; b < B; ++b)
      for (Index j = 0; j < ni; ++j) z[b * ldz + j] = (x[b * ldx + j] - mean[j]) * inv_scale[j];
  }
  for (std::size_t l = 0; l < n_layers; ++l) {
    const Layer<S>& L = m.layers()[l];
    layer_step<Isa, kBatch>(L, m.cell_type(), B, ws.z[l].data(), ws.c[l].data(), ws.g[l].data(),
                    ws.scratch.data());
    if (l + 1 < n_layers) {  // h_t of layer l is the input of layer l + 1
      const Index H = L.hidden_size, ldz = L.input_size + H, ldz_next = H + m.layers()[l + 1].hidden_size;
      for (Index b = 0; b < B; ++b)
        std::copy(ws.z[l].data() + b * ldz + L.input_size, ws.z[l].data() + (b + 1) * ldz,
                  ws.z[l + 1].data() + b * ldz_next);
    }
  }
  const Layer<S>& last = m.layers().back();
  const Index ldz = last.input_size + last.hidden_size;
  const S* h_last = ws.z.back().data() + last.input_size;
  const S *mean = m.output_mean().data(), *scale = m.output_scale().data();
  const Index H = last.hidden_size;
  for (Index b = 0; b < B; ++b) {  // y = (b_out + W_out h_t) * scale + mean
    S* yb = y + b * ldy;
    const S *w_out = m.head_weight_rows().data(), *b_out = m.head_bias().data();
    if (kBatch == 1 && H == 16 && K::template fixed_hidden<S>(16)) {  // the same sums, unrolled
      K::head_dot(w_out, 16, no, 16, h_last, b_out, yb);
    } else if (kBatch == 1 && H == 32 && K::template fixed_hidden<S>(32)) {
      K::head_dot(w_out, 32, no, 32, h_last, b_out, yb);
    } else {
      K::head_dot(w_out, H, no, H, h_last + b * ldz, b_out, yb);
    }
    for (Index k = 0; k < no; ++k) yb[k] = yb[k] * scale[k] + mean[k];
  }
}

template <typename S>
void advance_generic(const Model<S>& m, Workspace<S>& ws, const S* x, Index ldx, S* y,
                     Index ldy) {
  if (ws.batch == 1) {
    advance_body<Generic, 1>(m, ws, x, ldx, y, ldy);
  } else {
    advance_body<Generic, 0>(m, ws, x, ldx, y, ldy);
  }
}

#ifdef TERRASPH_LSTM_AVX2_DISPATCH
// The same step compiled for AVX2 + FMA (lstm_kernels.hpp), chosen per Model at run time.
template <typename S>
__attribute__((target("avx2,fma"))) void advance_avx2(const Model<S>& m, Workspace<S>& ws,
                                                      const S* x, Index ldx, S* y, Index ldy) {
  if (ws.batch == 1) {
    advance_body<Avx2, 1>(m, ws, x, ldx, y, ldy);
  } else {
    advance_body<Avx2, 0>(m, ws, x, ldx, y, ldy);
  }
}
// And for AVX-512 (F, with AVX2 + FMA): vectors of 16 floats, panels of 128 rows.
template <typename S>
__attribute__((target("avx512f,avx2,fma"))) void advance_avx512(const Model<S>& m,
                                                                Workspace<S>& ws, const S* x,
                                                                Index ldx, S* y, Index ldy) {
  if (ws.batch == 1) {
    advance_body<Avx512, 1>(m, ws, x, ldx, y, ldy);
  } else {
    advance_body<Avx512, 0>(m, ws, x, ldx, y, ldy);
  }
}
#endif

/// One time step with the kernel variant the model chose for this CPU.
template <typename S>
inline void advance(const Model<S>& m, Workspace<S>& ws, const S* x, Index ldx, S* y,
                    Index ldy) {
#ifdef TERRASPH_LSTM_AVX2_DISPATCH
  if (m.isa() == KernelIsa::Avx512) {
    advance_avx512(m, ws, x, ldx, y, ldy);
    return;
  }
  if (m.isa() == KernelIsa::Avx2) {
    advance_avx2(m, ws, x, ldx, y, ldy);
    return;
  }
#endif
  advance_generic(m, ws, x, ldx, y, ldy);
}

}  // namespace detail

/// Recurrent state of B independent sequences advanced together, plus preallocated work
/// buffers. Each step runs one matrix-matrix product per weight matrix for all B sequences;
/// results equal those of B single Streams bit for bit (see lstm_kernels.hpp).
///
/// step() and run() perform no heap allocation. Not thread-safe: one Batch per thread.
template <typename Scalar>
class Batch {
 public:
  using Vector = typename Model<Scalar>::Vector;
  static constexpr Eigen::Index kMaxBatch = 1 << 20;

  Batch(std::shared_ptr<const Model<Scalar>> model, Eigen::Index batch)
      : model_(checked(std::move(model), batch)), ws_(*model_, batch) {}

  const Model<Scalar>& model() const { return *model_; }
  Eigen::Index batch() const { return ws_.batch; }
  Eigen::Index input_size() const { return model_->input_size(); }
  Eigen::Index output_size() const { return model_->output_size(); }

  /// Zero the hidden and cell state of every sequence and layer (start new sequences).
  void reset() { ws_.reset(); }

  /// Hidden state h of sequence b in layer l (H_l values).
  const Scalar* hidden(Eigen::Index b, Eigen::Index l) const {
    const auto& L = layer(l);
    const Eigen::Index ldz = L.input_size + L.hidden_size;
    return ws_.z[static_cast<std::size_t>(l)].data() + row(b) * ldz + L.input_size;
  }
  /// Cell state c of sequence b in layer l (H_l values).
  const Scalar* cell(Eigen::Index b, Eigen::Index l) const {
    return ws_.c[static_cast<std::size_t>(l)].data() + row(b) * layer(l).hidden_size;
  }

  /// Advance all sequences one time step: x is (batch, input_size) row-major raw features,
  /// y receives (batch, output_size) raw targets. Throws std::invalid_argument (state
  /// untouched) if x is not finite.
  void step(const Scalar* x, Scalar* y) {
    check_finite(x, 1);
    detail::advance(*model_, ws_, x, input_size(), y, output_size());
  }

  /// Run T steps of every sequence from the current state: x is (batch, T, input_size)
  /// row-major, y is (batch, T, output_size). Same arithmetic as step(), hence identical
  /// results. Throws std::invalid_argument (state untouched) if x is not finite.
  void run(const Scalar* x, Eigen::Index T, Scalar* y) {
    check_finite(x, T);
    const Eigen::Index ni = input_size(), no = output_size();
    for (Eigen::Index t = 0; t < T; ++t)
      detail::advance(*model_, ws_, x + t * ni, T * ni, y + t * no, T * no);
  }

 private:
  static std::shared_ptr<const Model<Scalar>> checked(std::shared_ptr<const Model<Scalar>> m,
                                                      Eigen::Index batch) {
    if (!m) throw std::invalid_argument("LSTM batch: model must not be null");
    if (batch < 1 || batch > kMaxBatch) {
      throw std::invalid_argument("LSTM batch: batch must be in [1, " +
                                  std::to_string(kMaxBatch) + "], got " +
                                  std::to_string(batch));
    }
    return m;
  }
  const Layer<Scalar>& layer(Eigen::Index l) const {
    if (l < 0 || l >= model_->num_layers()) {
      throw std::out_of_range("LSTM state: layer must be in [0, " +
                              std::to_string(model_->num_layers() - 1) + "], got " +
                              std::to_string(l));
    }
    return model_->layers()[static_cast<std::size_t>(l)];
  }
  Eigen::Index row(Eigen::Index b) const {
    if (b < 0 || b >= batch()) {
      throw std::out_of_range("LSTM state: sequence must be in [0, " +
                              std::to_string(batch() - 1) + "], got " + std::to_string(b));
    }
    return b;
  }
  // x holds batch() rows of T * input_size values: a branch-free scan, then the first value
  // that is not finite is located only if there is one.
  void check_finite(const Scalar* x, Eigen::Index T) const {
    const Eigen::Index n = batch() * T * input_size();
    bool finite = true;
    for (Eigen::Index k = 0; k < n; ++k) finite &= std::isfinite(x[k]);
    if (!finite) throw_not_finite(x, T);
  }
  [[noreturn]] __attribute__((noinline, cold)) void throw_not_finite(const Scalar* x,
                                                                     Eigen::Index T) const {
    const Eigen::Index ni = input_size();
    for (Eigen::Index k = 0;; ++k) {
      if (!std::isfinite(x[k])) {
        const Eigen::Index j = k % ni, t = (k / ni) % T, b = k / (ni * T);
        throw std::invalid_argument(
            "LSTM input x[sequence " + std::to_string(b) + ", step " + std::to_string(t) +
            ", feature " + std::to_string(j) + "] ('" +
            model_->feature_names()[static_cast<std::size_t>(j)] +
            "') is not finite; inputs must be finite numbers");
      }
    }
  }

  std::shared_ptr<const Model<Scalar>> model_;
  detail::Workspace<Scalar> ws_;
};

/// Recurrent state of one sequence: a Batch of one, with single-sequence accessors.
///
/// step() performs no heap allocation. Not thread-safe: use one Stream per thread/sequence.
template <typename Scalar>
class Stream {
 public:
  using Vector = typename Model<Scalar>::Vector;

  explicit Stream(std::shared_ptr<const Model<Scalar>> model) : batch_(std::move(model), 1) {}

  const Model<Scalar>& model() const { return batch_.model(); }
  Eigen::Index input_size() const { return batch_.input_size(); }
  Eigen::Index output_size() const { return batch_.output_size(); }

  /// Zero the hidden and cell state of every layer (start of a new sequence).
  void reset() { batch_.reset(); }

  /// Hidden state h of layer l (size H_l).
  Eigen::Map<const Vector> hidden(Eigen::Index l) const {
    return Eigen::Map<const Vector>(batch_.hidden(0, l), hidden_size(l));
  }
  /// Cell state c of layer l (size H_l).
  Eigen::Map<const Vector> cell(Eigen::Index l) const {
    return Eigen::Map<const Vector>(batch_.cell(0, l), hidden_size(l));
  }

  /// Advance one time step: x holds input_size() raw features, y receives output_size() raw
  /// targets. Throws std::invalid_argument (state untouched) if x is not finite.
  void step(const Scalar* x, Scalar* y) { batch_.step(x, y); }

  /// Run a whole sequence of T steps from the current state: x is (T, input_size) row-major,
  /// y is (T, output_size) row-major. Same arithmetic as step(), hence identical results.
  void run(const Scalar* x, Eigen::Index T, Scalar* y) { batch_.run(x, T, y); }

 private:
  Eigen::Index hidden_size(Eigen::Index l) const {
    batch_.cell(0, l);  // validates l
    return model().layers()[static_cast<std::size_t>(l)].hidden_size;
  }

  Batch<Scalar> batch_;
};

/// Predict one whole sequence from a zero state: x (T, input_size) -> y (T, output_size),
/// row-major. Equal bit for bit to stepping a fresh Stream T times.
template <typename Scalar>
void predict_sequence(const std::shared_ptr<const Model<Scalar>>& model, const Scalar* x,
                      Eigen::Index T, Scalar* y) {
  Stream<Scalar> s(model);
  s.run(x, T, y);
}

/// Predict B whole sequences of T steps from a zero state: x (B, T, input_size) ->
/// y (B, T, output_size), row-major, advancing up to `chunk` sequences together. Equal bit for
/// bit to predict_sequence on each sequence.
template <typename Scalar>
void predict_batch(const std::shared_ptr<const Model<Scalar>>& model, const Scalar* x,
                   Eigen::Index B, Eigen::Index T, Scalar* y, Eigen::Index chunk = 256) {
  if (B < 0 || T < 0) {
    throw std::invalid_argument("LSTM predict: batch and T must be >= 0, got batch " +
                                std::to_string(B) + ", T " + std::to_string(T));
  }
  if (B == 0 || T == 0) return;
  const Eigen::Index ni = model->input_size(), no = model->output_size();
  const Eigen::Index n = std::min(B, std::max<Eigen::Index>(chunk, 1));
  Batch<Scalar> full(model, n);
  for (Eigen::Index b0 = 0; b0 < B; b0 += n) {
    const Eigen::Index nb = std::min(n, B - b0);
    if (nb == n) {
      full.reset();
      full.run(x + b0 * T * ni, T, y + b0 * T * no);
    } else {
      Batch<Scalar> rest(model, nb);
      rest.run(x + b0 * T * ni, T, y + b0 * T * no);
    }
  }
}

}  // namespace lstm
}  // namespace terrasph
