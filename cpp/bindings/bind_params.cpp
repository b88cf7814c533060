// Bindings of the model constants (cpp/include/terrasph/params.hpp): material, numerics, domain.
// The material and numerics fields are bound from the parameter lists themselves, and the lists
// are exported as `parameter_table()` for the Python configuration classes (terrasph.config).
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <type_traits>

#include "terrasph/params.hpp"

namespace py = pybind11;
using namespace terrasph;

namespace {

// A number or bool is a plain attribute; a choice is a str attribute that refuses unknown names.
template <class Group, class T>
void bind_field(py::class_<Group>& cls, const ParameterField<Group, T>& field) {
  if constexpr (std::is_enum_v<T>) {
    const auto member = field.member;
    const std::string parameter = field.qualified_name();
    cls.def_property(
        field.name, [member](const Group& group) { return choice_name(group.*member); },
        [member, parameter](Group& group, const std::string& name) {
          group.*member = parse_choice<T>(parameter, name);
        },
        field.doc);
  } else {
    cls.def_readwrite(field.name, field.member, field.doc);
  }
}

template <class Group> py::class_<Group> bind_group(py::module_& m, const char* class_name) {
  py::class_<Group> cls(m, class_name);
  cls.def(py::init<>());
  Group::for_each_field([&](const auto& field) { bind_field(cls, field); });
  cls.def("validate", &Group::validate,
          "Checks every parameter against its range and the rules linking them; ValueError names the first "
          "offender.");
  return cls;
}

py::dict as_dict(const ParameterInfo& info) {
  py::dict entry;
  entry["group"] = info.group;
  entry["name"] = info.name;
  entry["kind"] = info.kind;
  entry["default"] = std::visit([](const auto& value) { return py::cast(value); }, info.default_value);
  entry["unit"] = info.unit;
  entry["lower"] = info.lower;
  entry["lower_inclusive"] = info.lower_inclusive;
  entry["upper"] = info.upper;
  entry["upper_inclusive"] = info.upper_inclusive;
  entry["choices"] = py::tuple(py::cast(info.choices));
  entry["allowed"] = info.allowed;
  entry["doc"] = info.doc;
  return entry;
}

py::list exported_table() {
  py::list table;
  for (const auto& info : parameter_table<MaterialParams>()) table.append(as_dict(info));
  for (const auto& info : parameter_table<NumericsParams>()) table.append(as_dict(info));
  return table;
}
// DomainParams<D> and ModelParams<D> as DomainParams2D/3D and ModelParams2D/3D.
template <int D> void bind_model_params(py::module_& m, const std::string& suffix) {
  py::class_<DomainParams<D>>(m, ("DomainParams" + suffix).c_str())
      .def(py::init<>())
      .def_readwrite("lower", &DomainParams<D>::lower)
      .def_readwrite("upper", &DomainParams<D>::upper)
      .def_readwrite("gravity", &DomainParams<D>::gravity);

  py::class_<ModelParams<D>>(m, ("ModelParams" + suffix).c_str())
      .def(py::init<>())
      .def_readwrite("material", &ModelParams<D>::material)
      .def_readwrite("numerics", &ModelParams<D>::numerics)
      .def_readwrite("domain", &ModelParams<D>::domain)
      .def("validate", &ModelParams<D>::validate)
      .def_property_readonly("smoothing_length", &ModelParams<D>::smoothing_length)
      .def_property_readonly("artificial_sound_speed", &ModelParams<D>::artificial_sound_speed)
      .def_property_readonly("eos_sound_speed", &ModelParams<D>::eos_sound_speed);
}
}  // namespace

void bind_params(py::module_& m) {
  bind_group<MaterialParams>(m, "MaterialParams")
      .def("cohesion", &MaterialParams::cohesion, "Capillary cohesion c (Pa) of Eq. 2.33-2.34, 0 when dry.")
      .def("liquid_saturation", &MaterialParams::liquid_saturation,
           "Liquid saturation S = w rho_s,dry nu / (rho_l (1 - nu)) of the pores.")
      .def("max_pendular_water_content", &MaterialParams::max_pendular_water_content,
           "Largest water content of the supported pendular state (S <= 0.1) for this packing.");
  bind_group<NumericsParams>(m, "NumericsParams");
  m.def("parameter_table", &exported_table,
        "Every material and numerics parameter as a dict: group, name, kind ('double', 'int', 'bool', "
        "'choice'), default, unit, lower, lower_inclusive, upper, upper_inclusive, choices, allowed, doc.");

  bind_model_params<2>(m, "2D");
  bind_model_params<3>(m, "3D");
}
