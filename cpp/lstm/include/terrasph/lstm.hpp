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
//
// Model holds the constants (weights, normalisation) and Stream the state (h, c and work
// buffers, allocated once), so one model can serve many independent streams. A step performs
// no heap allocation. Whole-sequence prediction runs the very same step, so it is bit-for-bit
// equal to streaming. The file format is documented in docs/lstm_format.md.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "terrasph/lstm_format.hpp"

namespace terrasph {
namespace lstm {

namespace detail {

/// Rows per register block of the gate product: 8 AVX registers of accumulators.
template <typename Scalar>
constexpr int big_block() {
  return 256 / static_cast<int>(sizeof(Scalar));
}

/// Copy the leading whole row blocks of big_block() rows into the layout the kernel streams
/// through: block after block, within a block column after column (B values each).
template <typename Scalar, typename Mat>
std::vector<Scalar> pack_blocks(const Mat& w) {
  constexpr Eigen::Index kBig = big_block<Scalar>();
  std::vector<Scalar> out;
  out.reserve(static_cast<std::size_t>(w.rows() / kBig * kBig * w.cols()));
  for (Eigen::Index r = 0; r + kBig <= w.rows(); r += kBig)
    for (Eigen::Index j = 0; j < w.cols(); ++j)
      for (Eigen::Index k = 0; k < kBig; ++k) out.push_back(w(r + k, j));
  return out;
}

// y[r0, r0+B) += W_block z: B accumulators stay in registers across all columns and the block's
// weights are read once, sequentially.
template <int B, typename Scalar>
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline void gemv_rows(const Scalar* blk, Eigen::Index r0, Eigen::Index cols, const Scalar* z,
                      Scalar* y) {
  Scalar acc[B];
  for (int k = 0; k < B; ++k) acc[k] = y[r0 + k];
  for (Eigen::Index j = 0; j < cols; ++j) {
    const Scalar zj = z[j];
    const Scalar* col = blk + j * B;
    for (int k = 0; k < B; ++k) acc[k] += col[k] * zj;
  }
  for (int k = 0; k < B; ++k) y[r0 + k] = acc[k];
}

// y[0, n_blocks * B) += W z for the packed leading row blocks of W (pack_blocks).
template <typename Scalar>
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline void gemv_body(const Scalar* packed, Eigen::Index n_blocks, Eigen::Index cols,
                      const Scalar* z, Scalar* y) {
  constexpr int kBig = big_block<Scalar>();
  for (Eigen::Index b = 0; b < n_blocks; ++b)
    gemv_rows<kBig>(packed + b * kBig * cols, b * kBig, cols, z, y);
}

template <typename Scalar>
void gemv_generic(const Scalar* packed, Eigen::Index rows, Eigen::Index cols, const Scalar* z,
                  Scalar* y) {
  gemv_body(packed, rows, cols, z, y);
}

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__AVX2__) && \
    !defined(TERRASPH_LSTM_NO_DISPATCH)
#define TERRASPH_LSTM_AVX2_DISPATCH 1
// Same kernel compiled for AVX2 + FMA, chosen at run time when the CPU has them, so a build
// for baseline x86-64 (like a Python wheel) still uses 256-bit vectors.
template <typename Scalar>
__attribute__((target("avx2,fma"))) void gemv_avx2(const Scalar* packed, Eigen::Index rows,
                                                   Eigen::Index cols, const Scalar* z,
                                                   Scalar* y) {
  gemv_body(packed, rows, cols, z, y);
}
inline bool cpu_has_avx2_fma() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}
#endif

/// y += W z: the packed kernel (chosen for this CPU once per Model, so results are
/// reproducible) for the leading whole blocks of rows, Eigen's product for the remaining rows
/// (all rows when the matrix is smaller than one block).
template <typename Scalar, typename Mat>
inline void gemv(bool use_avx2, const std::vector<Scalar>& packed, const Mat& w,
                 const Scalar* z, Scalar* y) {
  using Vec = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  const Eigen::Index rows = w.rows(), cols = w.cols();
  const Eigen::Index n_blocks = rows / big_block<Scalar>();
  const Eigen::Index done = n_blocks * big_block<Scalar>();
  if (n_blocks > 0) {
#ifdef TERRASPH_LSTM_AVX2_DISPATCH
    if (use_avx2) {
      gemv_avx2(packed.data(), n_blocks, cols, z, y);
    } else {
      gemv_generic(packed.data(), n_blocks, cols, z, y);
    }
#else
    (void)use_avx2;
    gemv_generic(packed.data(), n_blocks, cols, z, y);
#endif
  }
  if (done < rows) {
    Eigen::Map<Vec> tail(y + done, rows - done);
    tail.noalias() += w.bottomRows(rows - done) * Eigen::Map<const Vec>(z, cols);
  }
}

inline bool default_use_avx2() {
#ifdef TERRASPH_LSTM_AVX2_DISPATCH
  return cpu_has_avx2_fma();
#else
  return false;
#endif
}

}  // namespace detail

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
  // The same matrices in the kernel's blocked layout (detail::pack_blocks).
  std::vector<Scalar> w_packed, w_ci_packed, w_cf_packed, w_co_packed;
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
    out_mean_ = to_vector(d.output_mean, output_size_, "output_mean");
    out_scale_ = to_vector(d.output_scale, output_size_, "output_scale");
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
        L.w_ci_packed = detail::pack_blocks<Scalar>(L.w_ci);
        L.w_cf_packed = detail::pack_blocks<Scalar>(L.w_cf);
        L.w_co_packed = detail::pack_blocks<Scalar>(L.w_co);
      }
      L.w_packed = detail::pack_blocks<Scalar>(L.w);
      layers_.push_back(std::move(L));
      in = H;
    }
    w_out_ = to_matrix(d.w_out, output_size_, in, "head weight");
    b_out_ = to_vector(d.b_out, output_size_, "head bias");
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
  const Vector& output_mean() const { return out_mean_; }
  const Vector& output_scale() const { return out_scale_; }
  const Matrix& head_weight() const { return w_out_; }
  const Vector& head_bias() const { return b_out_; }
  /// True if the gate products use the run-time selected AVX2/FMA kernel.
  bool uses_avx2() const { return use_avx2_; }

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
  Vector in_mean_, in_scale_, out_mean_, out_scale_;
  std::vector<Layer<Scalar>> layers_;
  Matrix w_out_;
  Vector b_out_;
  bool use_avx2_ = detail::default_use_avx2();
};

/// Recurrent state of one sequence plus preallocated work buffers.
///
/// step() performs no heap allocation. Not thread-safe: use one Stream per thread/sequence.
template <typename Scalar>
class Stream {
 public:
  using Vector = typename Model<Scalar>::Vector;

  explicit Stream(std::shared_ptr<const Model<Scalar>> model) : model_(std::move(model)) {
    if (!model_) throw std::invalid_argument("LSTM stream: model must not be null");
    for (const auto& L : model_->layers()) {
      z_.push_back(Vector::Zero(L.input_size + L.hidden_size));
      c_.push_back(Vector::Zero(L.hidden_size));
      gates_.push_back(Vector::Zero(4 * L.hidden_size));
    }
    head_ = Vector::Zero(model_->output_size());
  }

  const Model<Scalar>& model() const { return *model_; }
  Eigen::Index input_size() const { return model_->input_size(); }
  Eigen::Index output_size() const { return model_->output_size(); }

  /// Zero the hidden and cell state of every layer (start of a new sequence).
  void reset() {
    for (auto& z : z_) z.setZero();
    for (auto& c : c_) c.setZero();
  }

  /// Hidden state h of layer l (size H_l).
  Eigen::Ref<const Vector> hidden(Eigen::Index l) const {
    const auto& L = model_->layers().at(static_cast<std::size_t>(l));
    return z_[static_cast<std::size_t>(l)].tail(L.hidden_size);
  }
  /// Cell state c of layer l (size H_l).
  const Vector& cell(Eigen::Index l) const { return c_.at(static_cast<std::size_t>(l)); }

  /// Advance one time step: x holds input_size() raw features, y receives output_size() raw
  /// targets. Throws std::invalid_argument (state untouched) if x is not finite.
  void step(const Scalar* x, Scalar* y) {
    const Model<Scalar>& m = *model_;
    const Eigen::Index ni = m.input_size();
    for (Eigen::Index j = 0; j < ni; ++j) {
      if (!std::isfinite(x[j])) {
        throw std::invalid_argument("LSTM input x[" + std::to_string(j) + "] ('" +
                                    m.feature_names()[static_cast<std::size_t>(j)] +
                                    "') is not finite; inputs must be finite numbers");
      }
    }
    const Eigen::Map<const Vector> xv(x, ni);
    z_[0].head(ni) = (xv - m.input_mean()).cwiseQuotient(m.input_scale());
    const std::size_t n_layers = m.layers().size();
    for (std::size_t l = 0; l < n_layers; ++l) {
      step_layer(m.layers()[l], m.cell_type(), m.uses_avx2(), z_[l], c_[l], gates_[l]);
      const Eigen::Index H = m.layers()[l].hidden_size;
      if (l + 1 < n_layers) z_[l + 1].head(H) = z_[l].tail(H);
    }
    const Layer<Scalar>& last = m.layers().back();
    head_.noalias() = m.head_weight() * z_.back().tail(last.hidden_size);
    head_ += m.head_bias();
    Eigen::Map<Vector> yv(y, m.output_size());
    yv = head_.cwiseProduct(m.output_scale()) + m.output_mean();
  }

  /// Run a whole sequence of T steps from the current state: x is (T, input_size) row-major,
  /// y is (T, output_size) row-major. Same arithmetic as step(), hence identical results.
  void run(const Scalar* x, Eigen::Index T, Scalar* y) {
    const Eigen::Index ni = input_size(), no = output_size();
    check_finite(x, T, ni);
    for (Eigen::Index t = 0; t < T; ++t) step(x + t * ni, y + t * no);
  }

 private:
  void check_finite(const Scalar* x, Eigen::Index T, Eigen::Index ni) const {
    for (Eigen::Index t = 0; t < T; ++t)
      for (Eigen::Index j = 0; j < ni; ++j)
        if (!std::isfinite(x[t * ni + j])) {
          throw std::invalid_argument(
              "LSTM input x[" + std::to_string(t) + ", " + std::to_string(j) + "] ('" +
              model_->feature_names()[static_cast<std::size_t>(j)] +
              "') is not finite; inputs must be finite numbers");
        }
  }

  // One cell update. z = [u_t ; h_{t-1}] on entry, z.tail(H) = h_t on exit; c is updated in
  // place. Gate blocks of g are PyTorch's i, f, g (cell candidate), o.
  static void step_layer(const Layer<Scalar>& L, CellType cell, bool avx2, Vector& z,
                         Vector& c, Vector& g) {
    const Eigen::Index H = L.hidden_size;
    g = L.bias;
    // W_u* u_t + W_h* h_{t-1} + b_*, all four gates at once
    detail::gemv(avx2, L.w_packed, L.w, z.data(), g.data());
    if (cell == CellType::Peephole) {
      detail::gemv(avx2, L.w_ci_packed, L.w_ci, c.data(), g.data());      // + W_ci c_{t-1} (4.9)
      detail::gemv(avx2, L.w_cf_packed, L.w_cf, c.data(), g.data() + H);  // + W_cf c_{t-1} (4.10)
    }
    g.head(2 * H) = g.head(2 * H).array().logistic();        // i, f gates (Eq. 4.9, 4.10)
    g.segment(2 * H, H) = g.segment(2 * H, H).array().tanh();  // cell candidate
    c.array() = g.segment(H, H).array() * c.array() +
                g.segment(0, H).array() * g.segment(2 * H, H).array();  // c_t (Eq. 4.11)
    if (cell == CellType::Peephole) {
      detail::gemv(avx2, L.w_co_packed, L.w_co, c.data(), g.data() + 3 * H);  // + W_co c_t (4.12)
    }
    g.segment(3 * H, H) = g.segment(3 * H, H).array().logistic();  // o gate (Eq. 4.12)
    z.tail(H).array() = g.segment(3 * H, H).array() * c.array().tanh();  // h_t (Eq. 4.13)
  }

  std::shared_ptr<const Model<Scalar>> model_;
  std::vector<Vector> z_;      // per layer [input ; h_{t-1}]
  std::vector<Vector> c_;      // per layer cell state
  std::vector<Vector> gates_;  // per layer gate pre-activations (4H)
  Vector head_;                // normalised head output
};

/// Predict one whole sequence from a zero state: x (T, input_size) -> y (T, output_size),
/// row-major. Equal bit for bit to stepping a fresh Stream T times.
template <typename Scalar>
void predict_sequence(const std::shared_ptr<const Model<Scalar>>& model, const Scalar* x,
                      Eigen::Index T, Scalar* y) {
  Stream<Scalar> s(model);
  s.run(x, T, y);
}

}  // namespace lstm
}  // namespace terrasph
