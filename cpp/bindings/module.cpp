// The terrasph._core extension module: each part registers its own bindings.
#include <pybind11/pybind11.h>

namespace py = pybind11;

void bind_params(py::module_& m);  // bind_params.cpp: model constants
void bind_sph(py::module_& m);     // bind_sph.cpp: SPH simulation
void bind_lstm(py::module_& m);    // bind_lstm.cpp: LSTM inference
void bind_rft(py::module_& m);     // bind_rft.cpp: resistive force theory

PYBIND11_MODULE(_core, m) {
  m.doc() = "terrasph C++ core: SPH for granular media, resistive force theory and LSTM inference";
  bind_params(m);
  bind_sph(m);
  bind_lstm(m);
  bind_rft(m);
}
