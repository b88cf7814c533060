// Bindings of the LSTM inference engine (cpp/lstm/include/terrasph/lstm.hpp) as the submodule
// terrasph._core.lstm: Model32/Model64 (immutable weights) and Stream32/Stream64 (state of a
// batch of sequences advanced together one step at a time). numpy in, numpy out, C-contiguous rows.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "terrasph/lstm.hpp"

namespace py = pybind11;
namespace tl = terrasph::lstm;

namespace {

template <typename Scalar>
using CArray = py::array_t<Scalar, py::array::c_style | py::array::forcecast>;

std::string shape_str(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/// A batch of independent streams sharing one model, advanced together (tl::Batch): the Python
/// streaming object.
template <typename Scalar>
class BatchStream {
 public:
  BatchStream(std::shared_ptr<const tl::Model<Scalar>> model, py::ssize_t batch)
      : batch_(std::move(model), checked_batch(batch)) {}

  py::ssize_t batch() const { return batch_.batch(); }
  const tl::Model<Scalar>& model() const { return batch_.model(); }

  void reset() { batch_.reset(); }

  /// x: (I,) when batch == 1 or (B, I); returns (O,) or (B, O).
  py::array_t<Scalar> step(const CArray<Scalar>& x) {
    const py::ssize_t no = model().output_size();
    const bool flat = x.ndim() == 1;
    check_input(x);
    py::array_t<Scalar> y = flat ? py::array_t<Scalar>({no}) : py::array_t<Scalar>({batch(), no});
    batch_.step(x.data(), y.mutable_data());
    return y;
  }

  /// Same as step() but writes into a preallocated C-contiguous out array (no allocation).
  void step_into(const CArray<Scalar>& x, py::array_t<Scalar, py::array::c_style> out) {
    const py::ssize_t no = model().output_size();
    check_input(x);
    if (out.size() != batch() * no) {
      throw py::value_error("out must hold batch*output_size = " + std::to_string(batch() * no) +
                            " values, got shape " + shape_str(out));
    }
    batch_.step(x.data(), out.mutable_data());
  }

  /// Hidden state of layer l, shape (B, H_l).
  py::array_t<Scalar> hidden(py::ssize_t l) const { return state(l, true); }
  /// Cell state of layer l, shape (B, H_l).
  py::array_t<Scalar> cell(py::ssize_t l) const { return state(l, false); }

  /// Mean wall time of one step over n steps (seconds), measured inside C++ (benchmarks).
  double time_steps(const CArray<Scalar>& x, py::ssize_t n) {
    check_input(x);
    if (n < 1) throw py::value_error("n must be >= 1, got " + std::to_string(n));
    std::vector<Scalar> y(static_cast<std::size_t>(batch() * model().output_size()));
    py::gil_scoped_release release;
    const auto t0 = std::chrono::steady_clock::now();
    for (py::ssize_t k = 0; k < n; ++k) batch_.step(x.data(), y.data());
    const auto t1 = std::chrono::steady_clock::now();
    return std::chrono::duration<double>(t1 - t0).count() / static_cast<double>(n);
  }

 private:
  static py::ssize_t checked_batch(py::ssize_t batch) {
    if (batch < 1 || batch > tl::Batch<Scalar>::kMaxBatch) {
      throw py::value_error("batch must be in [1, " + std::to_string(tl::Batch<Scalar>::kMaxBatch) +
                            "], got " + std::to_string(batch));
    }
    return batch;
  }
  void check_input(const CArray<Scalar>& x) const {
    const py::ssize_t ni = model().input_size();
    const bool ok = (x.ndim() == 1 && batch() == 1 && x.shape(0) == ni) ||
                    (x.ndim() == 2 && x.shape(0) == batch() && x.shape(1) == ni);
    if (!ok) {
      throw py::value_error("x must have shape (input_size,) = (" + std::to_string(ni) +
                            ",) for batch 1 or (batch, input_size) = (" +
                            std::to_string(batch()) + ", " + std::to_string(ni) + "), got " +
                            shape_str(x));
    }
    // Reject non-finite input for the whole batch before any state changes.
    const Scalar* p = x.data();
    for (py::ssize_t k = 0; k < x.size(); ++k) {
      if (!std::isfinite(p[k])) {
        throw py::value_error("x contains a non-finite value at flat index " + std::to_string(k) +
                              "; inputs must be finite numbers");
      }
    }
  }
  py::array_t<Scalar> state(py::ssize_t l, bool hidden_state) const {
    const auto& m = model();
    if (l < 0 || l >= m.num_layers()) {
      throw py::index_error("layer must be in [0, " + std::to_string(m.num_layers() - 1) +
                            "], got " + std::to_string(l));
    }
    const py::ssize_t H = m.layers()[static_cast<std::size_t>(l)].hidden_size;
    py::array_t<Scalar> out({batch(), H});
    auto o = out.template mutable_unchecked<2>();
    for (py::ssize_t b = 0; b < batch(); ++b) {
      const Scalar* v = hidden_state ? batch_.hidden(b, l) : batch_.cell(b, l);
      for (py::ssize_t k = 0; k < H; ++k) o(b, k) = v[k];
    }
    return out;
  }

  tl::Batch<Scalar> batch_;
};

/// Whole-sequence prediction: x (T, I) -> (T, O) or (B, T, I) -> (B, T, O), each sequence from a
/// zero state; a batch is advanced together (tl::predict_batch), with results equal bit for bit
/// to predicting each sequence alone. The GIL is released while computing.
template <typename Scalar>
py::array_t<Scalar> predict(const std::shared_ptr<const tl::Model<Scalar>>& model,
                            const CArray<Scalar>& x) {
  const py::ssize_t ni = model->input_size(), no = model->output_size();
  if ((x.ndim() != 2 && x.ndim() != 3) || x.shape(x.ndim() - 1) != ni) {
    throw py::value_error("x must have shape (T, input_size) or (batch, T, input_size) with "
                          "input_size = " + std::to_string(ni) + ", got " + shape_str(x));
  }
  const py::ssize_t B = x.ndim() == 3 ? x.shape(0) : 1;
  const py::ssize_t T = x.shape(x.ndim() - 2);
  py::array_t<Scalar> y = x.ndim() == 3 ? py::array_t<Scalar>({B, T, no})
                                        : py::array_t<Scalar>({T, no});
  const Scalar* px = x.data();
  Scalar* py_out = y.mutable_data();
  for (py::ssize_t k = 0; k < x.size(); ++k) {
    if (!std::isfinite(px[k])) {
      const py::ssize_t t = (k / ni) % (T > 0 ? T : 1), j = k % ni;
      throw py::value_error("x contains a non-finite value at time step " + std::to_string(t) +
                            ", feature " + std::to_string(j) + " ('" +
                            model->feature_names()[static_cast<std::size_t>(j)] +
                            "'); inputs must be finite numbers");
    }
  }
  {
    py::gil_scoped_release release;
    tl::predict_batch<Scalar>(model, px, B, T, py_out);
  }
  return y;
}

template <typename Scalar>
void bind_precision(py::module_& m, const std::string& suffix) {
  using ModelT = tl::Model<Scalar>;
  using StreamT = BatchStream<Scalar>;
  const std::string dtype = sizeof(Scalar) == 4 ? "float32" : "float64";

  py::class_<ModelT, std::shared_ptr<ModelT>>(
      m, ("Model" + suffix).c_str(),
      ("LSTM surrogate model in " + dtype + " (immutable; load with Model" + suffix +
       "(path) or Model" + suffix + ".from_bytes(data)).").c_str())
      .def(py::init([](const std::string& path) {
             return std::const_pointer_cast<ModelT>(ModelT::load(path));
           }),
           py::arg("path"), "Load a model file (docs/lstm_format.md); raises LstmFormatError.")
      .def_static(
          "from_bytes",
          [](const py::bytes& data) {
            const std::string s = data;
            return std::const_pointer_cast<ModelT>(
                ModelT::from_bytes(reinterpret_cast<const unsigned char*>(s.data()), s.size()));
          },
          py::arg("data"), "Load a model from the bytes of a model file.")
      .def_property_readonly("cell_type",
                             [](const ModelT& mm) { return tl::cell_type_name(mm.cell_type()); })
      .def_property_readonly("input_size", &ModelT::input_size)
      .def_property_readonly("output_size", &ModelT::output_size)
      .def_property_readonly("num_layers", &ModelT::num_layers)
      .def_property_readonly("hidden_sizes",
                             [](const ModelT& mm) {
                               std::vector<Eigen::Index> h;
                               for (const auto& L : mm.layers()) h.push_back(L.hidden_size);
                               return h;
                             })
      .def_property_readonly("feature_names", &ModelT::feature_names)
      .def_property_readonly("target_names", &ModelT::target_names)
      .def_property_readonly("metadata", &ModelT::metadata, "Metadata JSON text.")
      .def_property_readonly("dtype", [dtype](const ModelT&) { return dtype; })
      .def_property_readonly("uses_avx2", &ModelT::uses_avx2,
                             "True if the kernels run their AVX2+FMA variant, chosen at run time.")
      .def_property_readonly("kernel_isa", &ModelT::kernel_isa,
                             "The kernel variant the model runs: 'generic' (the build's own flags), "
                             "or, chosen at run time by a baseline build, 'avx2' or 'avx512' (at "
                             "most the one the environment variable TERRASPH_LSTM_ISA names).")
      .def(
          "predict",
          [](const std::shared_ptr<ModelT>& self, const CArray<Scalar>& x) {
            return predict<Scalar>(self, x);
          },
          py::arg("x"),
          "Predict whole sequences from a zero state: x (T, I) -> (T, O), or (B, T, I) -> "
          "(B, T, O). Raw (unnormalised) features in, raw targets out.")
      .def(
          "stream",
          [](const std::shared_ptr<ModelT>& self, py::ssize_t batch) {
            return StreamT(self, batch);
          },
          py::arg("batch") = 1, "Create a streaming state for `batch` independent sequences.");

  py::class_<StreamT>(m, ("Stream" + suffix).c_str(),
                      ("Streaming LSTM state (" + dtype +
                       "): one time step per call, state kept between calls.")
                          .c_str())
      .def(py::init([](const std::shared_ptr<ModelT>& model, py::ssize_t batch) {
             return StreamT(model, batch);
           }),
           py::arg("model"), py::arg("batch") = 1)
      .def_property_readonly("batch", &StreamT::batch)
      .def("reset", &StreamT::reset, "Zero the state of every sequence (new sequences).")
      .def("step", &StreamT::step, py::arg("x"),
           "Advance one step: x (I,) for batch 1 or (B, I) -> y (O,) or (B, O).")
      .def("step_into", &StreamT::step_into, py::arg("x"), py::arg("out"),
           "Advance one step writing the targets into `out` (no allocation).")
      .def("hidden", &StreamT::hidden, py::arg("layer"), "Hidden state h of a layer, (B, H).")
      .def("cell", &StreamT::cell, py::arg("layer"), "Cell state c of a layer, (B, H).")
      .def("time_steps", &StreamT::time_steps, py::arg("x"), py::arg("n"),
           "Benchmark helper: advance n steps with input x, timed in C++; returns seconds per "
           "step. Changes the state.");
}

}  // namespace

void bind_lstm(py::module_& m) {
  py::module_ sub = m.def_submodule(
      "lstm", "LSTM surrogate inference (C++/Eigen): whole sequences, batches and streaming.");
  py::register_exception<tl::FormatError>(sub, "LstmFormatError", PyExc_ValueError);
  sub.attr("FORMAT_VERSION") = tl::kFormatVersion;
  bind_precision<float>(sub, "32");
  bind_precision<double>(sub, "64");
}
