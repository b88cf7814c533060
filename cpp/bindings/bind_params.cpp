// Bindings of the model constants (cpp/include/terrasph/params.hpp): material, numerics, domain.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>

#include "terrasph/params.hpp"

namespace py = pybind11;
using namespace terrasph;

namespace {
constexpr int Dim = 2;
}  // namespace

void bind_params(py::module_& m) {
  py::class_<MaterialParams>(m, "MaterialParams")
      .def(py::init<>())
      .def_readwrite("grain_density", &MaterialParams::grain_density)
      .def_readwrite("reference_density", &MaterialParams::reference_density)
      .def_readwrite("grain_diameter", &MaterialParams::grain_diameter)
      .def_readwrite("mu1", &MaterialParams::mu1)
      .def_readwrite("mu2", &MaterialParams::mu2)
      .def_readwrite("inertial_number_i0", &MaterialParams::inertial_number_i0)
      .def_readwrite("bulk_stiffness", &MaterialParams::bulk_stiffness)
      .def_readwrite("eos_exponent", &MaterialParams::eos_exponent)
      .def_readwrite("water_content", &MaterialParams::water_content)
      .def_readwrite("cohesion", &MaterialParams::cohesion)
      .def_readwrite("elastic_quasi_static", &MaterialParams::elastic_quasi_static)
      .def_readwrite("shear_modulus", &MaterialParams::shear_modulus);

  py::class_<NumericsParams>(m, "NumericsParams")
      .def(py::init<>())
      .def_readwrite("spacing", &NumericsParams::spacing)
      .def_readwrite("h_factor", &NumericsParams::h_factor)
      .def_readwrite("cfl", &NumericsParams::cfl)
      .def_readwrite("fixed_dt", &NumericsParams::fixed_dt)
      .def_readwrite("sound_speed", &NumericsParams::sound_speed)
      .def_readwrite("artificial_viscosity", &NumericsParams::artificial_viscosity)
      .def_readwrite("wall_artificial_viscosity", &NumericsParams::wall_artificial_viscosity)
      .def_readwrite("wall_barrier", &NumericsParams::wall_barrier)
      .def_readwrite("density_floor", &NumericsParams::density_floor)
      .def_readwrite("delta_sph", &NumericsParams::delta_sph)
      .def_readwrite("xsph", &NumericsParams::xsph)
      .def_readwrite("shepard_interval", &NumericsParams::shepard_interval)
      .def_readwrite("kernel_gradient_correction", &NumericsParams::kernel_gradient_correction)
      .def_readwrite("strain_rate_epsilon", &NumericsParams::strain_rate_epsilon)
      .def_readwrite("neighbour_skin", &NumericsParams::neighbour_skin)
      .def_readwrite("density_ratio_min", &NumericsParams::density_ratio_min)
      .def_readwrite("density_ratio_max", &NumericsParams::density_ratio_max);

  py::class_<DomainParams<Dim>>(m, "DomainParams2D")
      .def(py::init<>())
      .def_readwrite("lower", &DomainParams<Dim>::lower)
      .def_readwrite("upper", &DomainParams<Dim>::upper)
      .def_readwrite("gravity", &DomainParams<Dim>::gravity);

  py::class_<ModelParams<Dim>>(m, "ModelParams2D")
      .def(py::init<>())
      .def_readwrite("material", &ModelParams<Dim>::material)
      .def_readwrite("numerics", &ModelParams<Dim>::numerics)
      .def_readwrite("domain", &ModelParams<Dim>::domain)
      .def("validate", &ModelParams<Dim>::validate)
      .def_property_readonly("smoothing_length", &ModelParams<Dim>::smoothing_length)
      .def_property_readonly("artificial_sound_speed", &ModelParams<Dim>::artificial_sound_speed)
      .def_property_readonly("eos_sound_speed", &ModelParams<Dim>::eos_sound_speed);
}
