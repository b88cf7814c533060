// Bindings of resistive force theory (cpp/include/terrasph/rft.hpp, rft_robot.hpp, rft3d.hpp,
// rft3d_robot.hpp): the load of a body's surface elements in the plane and of 3D elements, and the
// native steps of a planar and of any MuJoCo robot on the planar and 3D RFT terrains.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cstdlib>
#include <string>
#include <tuple>
#include <vector>

#include "terrasph/rft.hpp"
#include "terrasph/rft3d.hpp"
#include "terrasph/rft3d_robot.hpp"
#include "terrasph/rft_robot.hpp"

namespace py = pybind11;
namespace tr = terrasph::rft;

namespace {

using CArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// The elements' arrays checked: `centre` and `normal` (count, 2), `length` (count,).
void check_elements(const CArray& centre, const CArray& normal, const CArray& length) {
  const py::ssize_t count = length.ndim() == 1 ? length.shape(0) : -1;
  for (const CArray* a : {&centre, &normal})
    if (a->ndim() != 2 || a->shape(0) != count || a->shape(1) != 2)
      throw py::value_error("RFT elements: centre and normal must be (count, 2) and length (count,)");
}

/// A map's terms as (vertical, sine, m, n, value) tuples (terrasph.rft.RFTCoefficients.terms).
using TermTuple = std::tuple<bool, bool, int, int, double>;

tr::Coefficients coefficients(const std::vector<TermTuple>& terms, double zeta, double unit_weight = 0.0) {
  tr::Coefficients out;
  out.order_beta = out.order_gamma = 0;
  for (const auto& [vertical, sine, m, n, value] : terms) {
    if (std::abs(m) > tr::kMaxOrder || n < 0 || n > tr::kMaxOrder)
      throw py::value_error("RFT coefficients: a term's order exceeds " + std::to_string(tr::kMaxOrder));
    auto same = std::find_if(out.terms.begin(), out.terms.end(),
                             [m = m, n = n](const tr::Term& t) { return t.m == m && t.n == n; });
    tr::Term& term = same != out.terms.end() ? *same : out.terms.emplace_back(tr::Term{m, n});
    (vertical ? (sine ? term.z_sin : term.z_cos) : (sine ? term.x_sin : term.x_cos)) += value;
    out.order_beta = std::max(out.order_beta, std::abs(m));
    out.order_gamma = std::max(out.order_gamma, n);
  }
  out.zeta = zeta;
  out.unit_weight = unit_weight;
  return out;
}

std::vector<double> copied(const CArray& a) { return {a.data(), a.data() + a.size()}; }

using IArray = py::array_t<int, py::array::c_style | py::array::forcecast>;

/// A body's pockets as (wall_pocket (count,), cell_centre (cells, 2), cell_area (cells,), cell_pocket
/// (cells,)) (terrasph.rft.SurfaceElements), checked: pocket indices within 0 … max.
struct Pockets {
  std::vector<int> wall_pocket, cell_pocket;
  std::vector<double> cell_centre, cell_area;
  int count = 0;
};
using PocketTuple = std::tuple<IArray, CArray, CArray, IArray>;

Pockets pockets(const PocketTuple& tuple, py::ssize_t elements) {
  const auto& [wall, centre, area, cell] = tuple;
  const py::ssize_t cells = area.ndim() == 1 ? area.shape(0) : -1;
  if (wall.ndim() != 1 || wall.shape(0) != elements || centre.ndim() != 2 || centre.shape(0) != cells ||
      centre.shape(1) != 2 || cell.ndim() != 1 || cell.shape(0) != cells)
    throw py::value_error("RFT pockets: wall_pocket (count,), cell_centre (cells, 2), cell_area and cell_pocket (cells,)");
  Pockets out{{wall.data(), wall.data() + wall.size()}, {cell.data(), cell.data() + cell.size()}, copied(centre),
              copied(area), 0};
  for (int p : out.cell_pocket) {
    if (p < 0) throw py::value_error("RFT pockets: a cell's pocket index is negative");
    out.count = std::max(out.count, p + 1);
  }
  for (int p : out.wall_pocket)
    if (p >= out.count) throw py::value_error("RFT pockets: a wall faces a pocket without cells");
  return out;
}

/// `a` is (count, 3).
void check_rows(const CArray& a, py::ssize_t count, const char* what) {
  if (a.ndim() != 2 || a.shape(0) != count || a.shape(1) != 3)
    throw py::value_error(std::string("3D RFT elements: ") + what + " must be (count, 3)");
}

std::vector<tr::VelocityServo> robot_servos(const std::vector<std::tuple<int, int, double, double, double, double>>& servos) {
  std::vector<tr::VelocityServo> out;
  for (const auto& [actuator, dof, kv, gear, lower, upper] : servos) out.push_back({actuator, dof, kv, gear, lower, upper});
  return out;
}

}  // namespace

void bind_rft(py::module_& m) {
  m.def(
      "rft_body_load",
      [](const CArray& centre, const CArray& normal, const CArray& length, double width, const PocketTuple& pocket,
         double angle, double x, double z, double vx, double vz, double omega, double surface,
         const std::vector<TermTuple>& c, double zeta, double unit_weight, double regularisation, bool jacobian) {
        check_elements(centre, normal, length);
        const Pockets p = pockets(pocket, length.shape(0));
        const tr::ElementsView view{centre.data(), normal.data(), length.data(),
                                    static_cast<std::size_t>(length.shape(0)), width,
                                    {p.wall_pocket.data(), p.cell_centre.data(), p.cell_area.data(),
                                     p.cell_pocket.data(), p.cell_area.size(), p.count}};
        const tr::BodyLoad load = tr::body_load(view, {angle, x, z, vx, vz, omega}, surface,
                                                coefficients(c, zeta, unit_weight), regularisation, jacobian);
        return std::make_tuple(load.fx, load.fz, load.torque, load.jacobian);
      },
      py::arg("centre"), py::arg("normal"), py::arg("length"), py::arg("width"), py::arg("pockets"),
      py::arg("angle"), py::arg("x"), py::arg("z"), py::arg("vx"), py::arg("vz"), py::arg("omega"),
      py::arg("surface"), py::arg("coefficients"), py::arg("zeta"), py::arg("unit_weight"),
      py::arg("regularisation"), py::arg("jacobian"),
      "RFT load (F_x, F_z, torque, row-major 3x3 Jacobian) of body surface elements (terrasph.rft.body_load)");

  py::class_<tr::PlanarRobotStepper>(m, "PlanarRobotStepper",
                                     "A planar MuJoCo robot on the RFT terrain stepped natively "
                                     "(terrasph.robots.rft_terrain.RFTCoupling)")
      .def(py::init([](const std::string& library, std::uintptr_t model, std::uintptr_t data,
                       const std::vector<std::tuple<int, CArray, CArray, CArray, double, PocketTuple>>& bodies,
                       const std::vector<std::tuple<int, int, double, double, double, double>>& servos,
                       double surface, const std::vector<TermTuple>& c, double zeta, double unit_weight,
                       double time_step, double regularisation, int iterations, int halvings, double tolerance) {
             std::vector<tr::RobotBody> robot_bodies;
             for (const auto& [id, centre, normal, length, width, pocket] : bodies) {
               check_elements(centre, normal, length);
               Pockets p = pockets(pocket, length.shape(0));
               robot_bodies.push_back({id, copied(centre), copied(normal), copied(length), width,
                                       std::move(p.wall_pocket), std::move(p.cell_pocket), std::move(p.cell_centre),
                                       std::move(p.cell_area), p.count});
             }
             return std::make_unique<tr::PlanarRobotStepper>(library, model, data, std::move(robot_bodies),
                                                             robot_servos(servos), surface,
                                                             coefficients(c, zeta, unit_weight),
                                                             time_step, regularisation,
                                                             tr::NewtonSettings{iterations, halvings, tolerance});
           }),
           py::arg("library"), py::arg("model"), py::arg("data"), py::arg("bodies"), py::arg("servos"),
           py::arg("surface"), py::arg("coefficients"), py::arg("zeta"), py::arg("unit_weight"),
           py::arg("time_step"), py::arg("regularisation"), py::arg("iterations"), py::arg("halvings"),
           py::arg("tolerance"))
      .def("step", &tr::PlanarRobotStepper::step,
           "one step; returns MuJoCo's count of the states it could not integrate (and reset) so far")
      .def("steps", &tr::PlanarRobotStepper::steps, py::arg("count"), "`count` steps; returns step()'s count")
      .def_property(
          "angles", [](tr::PlanarRobotStepper& s) { return s.angles(); },
          [](tr::PlanarRobotStepper& s, const std::vector<double>& v) {
            if (v.size() != s.angles().size()) throw py::value_error("angles: one per coupled body");
            s.angles() = v;
          },
          "each coupled body's clockwise angle (rad), continuous over turns")
      .def_property(
          "load_sums", [](tr::PlanarRobotStepper& s) { return s.load_sums(); },
          [](tr::PlanarRobotStepper& s, const std::vector<double>& v) {
            if (v.size() != s.load_sums().size()) throw py::value_error("load_sums: three per coupled body");
            s.load_sums() = v;
          },
          "each body's (F_x, F_z, torque) integrated over time since cleared (N s, N m s)")
      .def_property("step_count", &tr::PlanarRobotStepper::step_count, &tr::PlanarRobotStepper::set_step_count)
      .def_property_readonly("load_evaluations", &tr::PlanarRobotStepper::load_evaluations,
                             "how many times the steps evaluated the loads and their Jacobian");

  m.def(
      "rft3d_element_loads",
      [](const CArray& normal, const CArray& velocity, const CArray& depth, const CArray& area,
         const std::vector<TermTuple>& c, double zeta, double regularisation, bool jacobian) {
        const py::ssize_t count = depth.ndim() == 1 ? depth.shape(0) : -1;
        if (area.ndim() != 1 || area.shape(0) != count)
          throw py::value_error("3D RFT elements: depth and area must be (count,)");
        check_rows(normal, count, "normal");
        check_rows(velocity, count, "velocity");
        const tr::Coefficients table = coefficients(c, zeta);
        py::array_t<double> forces({count, py::ssize_t{3}});
        py::array_t<double> jacobians = jacobian ? py::array_t<double>({count, py::ssize_t{3}, py::ssize_t{3}})
                                                 : py::array_t<double>();
        const double *n = normal.data(), *v = velocity.data();
        for (py::ssize_t e = 0; e < count; ++e) {
          const tr::ElementLoad load = tr::element_force({n[3 * e], n[3 * e + 1], n[3 * e + 2]},
                                                         {v[3 * e], v[3 * e + 1], v[3 * e + 2]}, depth.data()[e],
                                                         area.data()[e], table, regularisation, jacobian);
          std::copy(load.force.begin(), load.force.end(), forces.mutable_data() + 3 * e);
          if (jacobian) std::copy(load.jacobian.begin(), load.jacobian.end(), jacobians.mutable_data() + 9 * e);
        }
        return py::make_tuple(forces, jacobian ? py::object(jacobians) : py::object(py::none()));
      },
      py::arg("normal"), py::arg("velocity"), py::arg("depth"), py::arg("area"), py::arg("coefficients"),
      py::arg("zeta"), py::arg("regularisation"), py::arg("jacobian") = false,
      "3D RFT forces (count, 3) on elements (terrasph.rft3d.element_forces) and, if asked, dF/dv (count, 3, 3)");

  py::class_<tr::Robot3DStepper>(m, "Robot3DStepper",
                                 "A MuJoCo robot on the 3D RFT terrain stepped natively "
                                 "(terrasph.robots.rft3d_terrain.RFT3DCoupling)")
      .def(py::init([](const std::string& library, std::uintptr_t model, std::uintptr_t data,
                       const std::vector<std::tuple<int, CArray, CArray, CArray>>& bodies,
                       const std::vector<std::tuple<int, int, double, double, double, double>>& servos,
                       double surface, const std::vector<TermTuple>& c, double zeta, double time_step,
                       double regularisation, int iterations, int halvings, double tolerance) {
             std::vector<tr::RobotBody3D> robot_bodies;
             for (const auto& [id, centre, normal, area] : bodies) {
               if (area.ndim() != 1) throw py::value_error("3D RFT elements: area must be (count,)");
               check_rows(centre, area.shape(0), "centre");
               check_rows(normal, area.shape(0), "normal");
               robot_bodies.push_back({id, copied(centre), copied(normal), copied(area)});
             }
             return std::make_unique<tr::Robot3DStepper>(library, model, data, std::move(robot_bodies),
                                                         robot_servos(servos), surface, coefficients(c, zeta),
                                                         time_step, regularisation,
                                                         tr::NewtonSettings{iterations, halvings, tolerance});
           }),
           py::arg("library"), py::arg("model"), py::arg("data"), py::arg("bodies"), py::arg("servos"),
           py::arg("surface"), py::arg("coefficients"), py::arg("zeta"), py::arg("time_step"),
           py::arg("regularisation"), py::arg("iterations"), py::arg("halvings"), py::arg("tolerance"))
      .def("step", &tr::Robot3DStepper::step,
           "one step; returns MuJoCo's count of the states it could not integrate (and reset) so far")
      .def("steps", &tr::Robot3DStepper::steps, py::arg("count"), "`count` steps; returns step()'s count")
      .def_property(
          "load_sums", [](tr::Robot3DStepper& s) { return s.load_sums(); },
          [](tr::Robot3DStepper& s, const std::vector<double>& v) {
            if (v.size() != s.load_sums().size()) throw py::value_error("load_sums: six per coupled body");
            s.load_sums() = v;
          },
          "each body's (force, torque about its centre of mass) integrated over time since cleared (N s, N m s)")
      .def_property("step_count", &tr::Robot3DStepper::step_count, &tr::Robot3DStepper::set_step_count);
}
