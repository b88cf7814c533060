// Bindings of the SPH core. Particle arrays are exposed as zero-copy numpy views whose base is
// the Simulation object (row-major (N, D) and (N, D, D)); advance() runs with the GIL released.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <omp.h>

#include <array>
#include <string>
#include <vector>

#include "terrasph/errors.hpp"
#include "terrasph/kernel.hpp"
#include "terrasph/neighbours.hpp"
#include "terrasph/simulation.hpp"

namespace py = pybind11;
using namespace terrasph;

namespace {

constexpr int Dim = 2;
using Sim = Simulation<Dim>;

py::array_t<double> vector_view(VecArray<Dim>& a, py::handle owner) {
  return py::array_t<double>({a.rows(), Index(Dim)}, {sizeof(double) * Dim, sizeof(double)}, a.data(), owner);
}
py::array_t<double> tensor_view(MatArray<Dim>& a, py::handle owner) {
  return py::array_t<double>({a.rows(), Index(Dim), Index(Dim)},
                             {sizeof(double) * Dim * Dim, sizeof(double) * Dim, sizeof(double)}, a.data(), owner);
}
py::array_t<double> scalar_view(ScalarArray& a, py::handle owner) {
  return py::array_t<double>({a.size()}, {sizeof(double)}, a.data(), owner);
}

VecArray<Dim> to_vectors(const py::array_t<double, py::array::c_style | py::array::forcecast>& a,
                         const char* name) {
  if (a.ndim() != 2 || a.shape(1) != Dim)
    throw std::invalid_argument(std::string(name) + " must have shape (N, 2)");
  VecArray<Dim> out(a.shape(0), Dim);
  std::copy(a.data(), a.data() + a.size(), out.data());
  return out;
}
ScalarArray to_scalars(const py::array_t<double, py::array::c_style | py::array::forcecast>& a,
                       Index n, const char* name) {
  if (a.ndim() != 1 || a.shape(0) != n)
    throw std::invalid_argument(std::string(name) + " must have shape (" + std::to_string(n) + ",)");
  ScalarArray out(n);
  std::copy(a.data(), a.data() + n, out.data());
  return out;
}

std::unique_ptr<Sim> make_simulation(
    const ModelParams<Dim>& params, const py::array_t<double, py::array::c_style | py::array::forcecast>& position,
    const py::array_t<double, py::array::c_style | py::array::forcecast>& velocity,
    const py::array_t<double, py::array::c_style | py::array::forcecast>& density,
    const py::array_t<double, py::array::c_style | py::array::forcecast>& mass,
    const py::array_t<double, py::array::c_style | py::array::forcecast>& wall_position,
    const py::array_t<double, py::array::c_style | py::array::forcecast>& wall_normal,
    const py::array_t<double, py::array::c_style | py::array::forcecast>& wall_mass,
    const py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>& wall_no_slip,
    const py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>& wall_group) {
  GranularParticles<Dim> granular;
  const VecArray<Dim> x = to_vectors(position, "position");
  const Index n = x.rows();
  granular.resize(n, params.numerics.xsph > 0.0, params.material.model == ConstitutiveModel::mu_i_hypoelastic);
  granular.position = x;
  granular.velocity = to_vectors(velocity, "velocity");
  if (granular.velocity.rows() != n) throw std::invalid_argument("velocity must have shape (N, 2) like position");
  granular.density = to_scalars(density, n, "density");
  granular.mass = to_scalars(mass, n, "mass");

  WallParticles<Dim> walls;
  const VecArray<Dim> xw = to_vectors(wall_position, "wall_position");
  const Index nw = xw.rows();
  walls.resize(nw);
  walls.position = xw;
  walls.mass = to_scalars(wall_mass, nw, "wall_mass");
  walls.normal = to_vectors(wall_normal, "wall_normal");
  if (walls.normal.rows() != nw) throw std::invalid_argument("wall_normal must have shape (M, 2) like wall_position");
  walls.density.setConstant(nw, params.material.reference_density);
  if (wall_no_slip.size() != nw || wall_group.size() != nw)
    throw std::invalid_argument("wall_no_slip and wall_group must have one entry per wall particle");
  walls.no_slip.assign(wall_no_slip.data(), wall_no_slip.data() + nw);
  walls.group.assign(wall_group.data(), wall_group.data() + nw);
  return std::make_unique<Sim>(params, std::move(granular), std::move(walls));
}

// Motion segments from Python rows (duration s, vx m/s, vz m/s, spin rad/s clockwise).
std::vector<MotionSegment<Dim>> to_segments(const std::vector<std::array<double, 4>>& rows) {
  std::vector<MotionSegment<Dim>> out;
  for (const auto& row : rows) {
    MotionSegment<Dim> s;
    s.duration = row[0];
    s.velocity = Vec<Dim>(row[1], row[2]);
    s.spin = row[3];
    out.push_back(s);
  }
  return out;
}

py::dict body_state(const RigidBody<Dim>& b) {
  py::dict d;
  d["reference"] = Vec<Dim>(b.kinematics.reference);
  d["angle"] = b.kinematics.angle;
  d["velocity"] = Vec<Dim>(b.kinematics.velocity);
  d["spin"] = b.kinematics.spin;
  d["force"] = Vec<Dim>(b.force);
  d["torque"] = b.torque;
  const double t = b.impulse_time;
  d["mean_force"] = t > 0.0 ? Vec<Dim>(b.impulse / t) : Vec<Dim>(b.force);
  d["mean_torque"] = t > 0.0 ? b.angular_impulse / t : b.torque;
  d["averaged_over"] = t;
  return d;
}

}  // namespace

void bind_sph(py::module_& m) {
  // The exception type lives with the module (pybind11's documented once-per-interpreter store).
  PYBIND11_CONSTINIT static py::gil_safe_call_once_and_store<py::object> instability_type;
  instability_type.call_once_and_store_result([&]() {
    return py::object(py::exception<InstabilityError>(m, "InstabilityError", PyExc_RuntimeError));
  });
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InstabilityError& e) {
      const py::object& type = instability_type.get_stored();
      py::object err = type(e.what());
      err.attr("step") = e.step();
      err.attr("time") = e.time();
      err.attr("particle") = e.particle();
      err.attr("reason") = e.reason();
      PyErr_SetObject(type.ptr(), err.ptr());
    }
  });

  py::class_<Sim>(m, "Simulation2D", "Granular SPH simulation in plane strain (x, z).")
      .def(py::init(&make_simulation), py::arg("params"), py::arg("position"), py::arg("velocity"),
           py::arg("density"), py::arg("mass"), py::arg("wall_position"), py::arg("wall_normal"), py::arg("wall_mass"),
           py::arg("wall_no_slip"), py::arg("wall_group"))
      .def("advance", &Sim::advance, py::arg("t_end"), py::arg("max_steps"),
           py::call_guard<py::gil_scoped_release>(),
           "Step until t_end or max_steps; returns the number of steps taken.")
      .def("refresh", &Sim::refresh, "Rebuild neighbours and rates after editing the state.")
      .def("remove_wall_group", &Sim::remove_wall_group, py::arg("group"))
      .def("add_body", [](Sim& s, std::int32_t group, const Vec<Dim>& reference, double angle,
                          const std::vector<std::array<double, 4>>& motion) {
             return s.add_body(group, reference, angle, to_segments(motion));
           }, py::arg("group"), py::arg("reference"), py::arg("angle"), py::arg("motion"),
           "Make a wall group a rigid body with reference point `reference` (m) and current clockwise "
           "angle `angle` (rad), following `motion`: rows (duration s, vx, vz m/s, spin rad/s clockwise) "
           "from now on, holding still after the last. Returns the body index.")
      .def_property_readonly("body_count", [](const Sim& s) { return s.bodies().size(); })
      .def("body_state", [](const Sim& s, std::size_t b) {
             if (b >= s.bodies().size()) throw py::index_error("no body " + std::to_string(b));
             return body_state(s.bodies()[b]);
           }, py::arg("body"),
           "Pose, rates and granular load of a body: force (N/m) and clockwise torque (N·m/m) about the "
           "reference point at the last step, and their time averages since reset_body_means().")
      .def("reset_body_means", &Sim::reset_body_impulses, "Restart the time averages of body loads.")
      .def_property_readonly("penetrating_particles", [](const Sim& s) { return s.counters().penetrating_particles; },
           "Granular particles past a wall's surface row (closer than spacing/2 to an interior wall "
           "particle) at the last step.")
      .def_property_readonly("penetrated_particles", [](const Sim& s) { return s.counters().penetrated_particles; },
           "Distinct granular particles that have got past a wall's surface row at any step of the run "
           "(leak counter).")
      .def_property_readonly("wall_interior", [](const Sim& s) {
        const auto& v = s.walls_const().interior;
        return py::array_t<std::uint8_t>(static_cast<py::ssize_t>(v.size()), v.data());
      }, "1 for wall particles a layer or more inside their wall, 0 on the surface row.")
      .def("stable_time_step", &Sim::stable_time_step)
      .def("apply_shepard_filter", &Sim::apply_shepard_filter)
      .def("kernel_sum", &Sim::kernel_sum)
      .def("kernel_gradient_sum", &Sim::kernel_gradient_sum)
      .def_property_readonly("step", [](const Sim& s) { return s.counters().step; })
      .def_property_readonly("time", [](const Sim& s) { return s.counters().time; })
      .def_property_readonly("last_dt", [](const Sim& s) { return s.counters().last_dt; })
      .def_property_readonly("neighbour_builds", [](const Sim& s) { return s.counters().neighbour_builds; })
      .def_property_readonly("max_speed", [](const Sim& s) { return s.counters().max_speed; })
      .def_property_readonly("max_acceleration", [](const Sim& s) { return s.counters().max_acceleration; })
      .def_property_readonly("phase_seconds", [](const Sim& s) {
        const PhaseTimes& t = s.counters().phase_seconds;
        py::dict d;
        d["neighbours"] = t.neighbours;
        d["wall_velocity"] = t.wall_velocity;
        d["velocity_gradient_and_stress"] = t.velocity_gradient_and_stress;
        d["wall_stress"] = t.wall_stress;
        d["forces"] = t.forces;
        d["integrate_and_check"] = t.integrate_and_check;
        return d;
      }, "Wall-clock seconds spent in each phase of the step, summed over the run.")
      .def_property_readonly("smoothing_length", &Sim::smoothing_length)
      .def_property_readonly("params", &Sim::params)
      .def_property_readonly("position", [](py::object self) { return vector_view(self.cast<Sim&>().granular().position, self); })
      .def_property_readonly("velocity", [](py::object self) { return vector_view(self.cast<Sim&>().granular().velocity, self); })
      .def_property_readonly("acceleration", [](py::object self) { return vector_view(self.cast<Sim&>().granular().acceleration, self); })
      .def_property_readonly("density", [](py::object self) { return scalar_view(self.cast<Sim&>().granular().density, self); })
      .def_property_readonly("density_rate", [](py::object self) { return scalar_view(self.cast<Sim&>().granular().density_rate, self); })
      .def_property_readonly("pressure", [](py::object self) { return scalar_view(self.cast<Sim&>().granular().pressure, self); })
      .def_property_readonly("mass", [](py::object self) { return scalar_view(self.cast<Sim&>().granular().mass, self); })
      .def_property_readonly("stress", [](py::object self) { return tensor_view(self.cast<Sim&>().granular().stress, self); })
      .def_property_readonly("deviatoric_stress", [](py::object self) { return tensor_view(self.cast<Sim&>().granular().deviatoric_stress, self); })
      .def_property_readonly("velocity_gradient", [](py::object self) { return tensor_view(self.cast<Sim&>().granular().velocity_gradient, self); })
      .def_property_readonly("wall_position", [](py::object self) { return vector_view(self.cast<Sim&>().walls().position, self); })
      .def_property_readonly("wall_velocity", [](py::object self) { return vector_view(self.cast<Sim&>().walls().velocity, self); })
      .def_property_readonly("wall_density", [](py::object self) { return scalar_view(self.cast<Sim&>().walls().density, self); })
      .def_property_readonly("wall_normal", [](py::object self) { return vector_view(self.cast<Sim&>().walls().normal, self); })
      .def_property_readonly("wall_stress", [](py::object self) { return tensor_view(self.cast<Sim&>().walls().stress, self); })
      .def_property_readonly("wall_group", [](const Sim& s) {
        const auto& g = s.walls_const().group;
        return py::array_t<std::int32_t>(static_cast<py::ssize_t>(g.size()), g.data());
      });

  m.def("set_num_threads", [](int n) {
        if (n < 1) throw std::invalid_argument("threads must be >= 1");
        omp_set_num_threads(n);
      }, py::arg("n"), "Number of OpenMP threads for the following runs (process-wide OpenMP setting).");
  m.def("get_max_threads", &omp_get_max_threads, "OpenMP threads a parallel loop would use now.");

  m.def("neighbour_lists", [](const py::array_t<double, py::array::c_style | py::array::forcecast>& points, double radius) {
        const VecArray<Dim> x = to_vectors(points, "points");
        if (!(radius > 0.0)) throw std::invalid_argument("radius must be > 0");
        Vec<Dim> lower, upper;
        bounding_box<Dim>(x, VecArray<Dim>(0, Dim), radius, lower, upper);
        CellGrid<Dim> grid;
        grid.build(x, lower, upper, radius);
        NeighbourList list;
        build_neighbour_list<Dim>(x, x, grid, radius, true, list);
        py::array_t<std::int64_t> offsets(static_cast<py::ssize_t>(list.offsets.size()), list.offsets.data());
        py::array_t<std::int32_t> indices(static_cast<py::ssize_t>(list.indices.size()), list.indices.data());
        return py::make_tuple(offsets, indices);
      }, py::arg("points"), py::arg("radius"),
      "Neighbours within radius (excluding self) of 2D points as CSR (offsets, indices).");

  m.def("wendland_c2_2d", [](const py::array_t<double, py::array::c_style | py::array::forcecast>& r, double h) {
        if (!(h > 0.0)) throw std::invalid_argument("h must be > 0");
        const WendlandC2<Dim> kernel(h);
        py::array_t<double> w(r.size()), f(r.size());
        for (py::ssize_t k = 0; k < r.size(); ++k) {
          w.mutable_data()[k] = kernel.value(r.data()[k]);
          f.mutable_data()[k] = kernel.gradient_factor(r.data()[k]);
        }
        return py::make_tuple(w, f);
      }, py::arg("r"), py::arg("h"),
      "Wendland C2 kernel W(r) and (dW/dr)/r in 2D, support 2h (Eq. 2.36).");
}
