// Bindings of the SPH core, for any dimension D (Simulation2D, Simulation3D). Particle fields are
// read and written by name and in particle-id order; every array handed out is a fresh copy (a
// frame is small next to a step), so nothing a user holds can dangle after the core resizes or
// reorders its storage. state()/restore() move the whole State (storage order, bit for bit).
// advance() runs with the GIL released.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <omp.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <numeric>
#include <string>
#include <type_traits>
#include <vector>

#include "terrasph/errors.hpp"
#include "terrasph/kernel.hpp"
#include "terrasph/neighbours.hpp"
#include "terrasph/simulation.hpp"

namespace py = pybind11;
using namespace terrasph;

namespace {

// Calls fn(Scalar{}) with the scalar type of a field.
template <class Fn> auto visit_scalar(const FieldBase& f, Fn&& fn) {
  if (f.scalar_type() == typeid(double)) return fn(double{});
  if (f.scalar_type() == typeid(std::int64_t)) return fn(std::int64_t{});
  if (f.scalar_type() == typeid(std::int32_t)) return fn(std::int32_t{});
  if (f.scalar_type() == typeid(std::uint8_t)) return fn(std::uint8_t{});
  throw std::logic_error("particle field '" + f.name() + "' has a scalar type the bindings do not know");
}

// numpy shape of a field with n rows: (n,), (n, k, k) for a k×k tensor (k > 1), else (n, columns).
std::vector<py::ssize_t> numpy_shape(const FieldBase& f, py::ssize_t n) {
  const int c = f.columns();
  if (c == 1) return {n};
  for (int k = 2; k * k <= c; ++k)
    if (k * k == c) return {n, k, k};
  return {n, c};
}

// Storage index of each particle in ascending id order.
std::vector<Index> id_order(const IdArray& ids) {
  std::vector<Index> order(static_cast<size_t>(ids.size()));
  std::iota(order.begin(), order.end(), Index(0));
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return ids[a] < ids[b]; });
  return order;
}

// A read-only copy of a field, rows in the given storage order.
py::array copy_rows(const FieldBase& f, const std::vector<Index>& order) {
  return visit_scalar(f, [&](auto zero) {
    using Scalar = decltype(zero);
    py::array_t<Scalar> out(numpy_shape(f, static_cast<py::ssize_t>(order.size())));
    const std::size_t row = static_cast<std::size_t>(f.columns()) * sizeof(Scalar);
    auto* dst = static_cast<char*>(static_cast<void*>(out.mutable_data()));
    const auto* src = static_cast<const char*>(f.data());
    for (std::size_t k = 0; k < order.size(); ++k)
      std::memcpy(dst + k * row, src + static_cast<std::size_t>(order[k]) * row, row);
    out.attr("flags").attr("writeable") = false;
    return py::array(out);
  });
}

// Writes `values` (rows in the given storage order) into a field, checking dtype-compatible shape.
void write_rows(FieldBase& f, const py::handle& values, const std::vector<Index>& order, const std::string& label) {
  visit_scalar(f, [&](auto zero) {
    using Scalar = decltype(zero);
    const auto a = py::array_t<Scalar, py::array::c_style | py::array::forcecast>::ensure(values);
    if (!a) throw py::type_error(label + " must be an array of numbers");
    const py::ssize_t n = static_cast<py::ssize_t>(order.size());
    if (a.size() != n * f.columns() || (a.ndim() > 0 && a.shape(0) != n)) {
      std::string shape;
      for (py::ssize_t s : numpy_shape(f, n)) shape += (shape.empty() ? "" : ", ") + std::to_string(s);
      throw std::invalid_argument(label + " must have shape (" + shape + (n >= 0 && f.columns() == 1 ? ",)" : ")"));
    }
    const std::size_t row = static_cast<std::size_t>(f.columns()) * sizeof(Scalar);
    const auto* src = static_cast<const char*>(static_cast<const void*>(a.data()));
    auto* dst = static_cast<char*>(f.data());
    for (std::size_t k = 0; k < order.size(); ++k)
      std::memcpy(dst + static_cast<std::size_t>(order[k]) * row, src + k * row, row);
    return 0;
  });
}

std::vector<Index> identity_order(Index n) {
  std::vector<Index> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), Index(0));
  return order;
}

// Fills a fresh particle set from named arrays (in the given order, which becomes the id order
// unless an 'id' array is given). `required` names the arrays that must be present.
template <class Set>
void fill_set(Set& set, const py::dict& arrays, const std::vector<std::string>& required, const std::string& label) {
  for (const std::string& name : required)
    if (!arrays.contains(name)) throw std::invalid_argument(label + " needs the array '" + name + "'");
  const py::array first = py::array::ensure(arrays[py::str(required.front())]);
  if (!first || first.ndim() < 1) throw std::invalid_argument(label + "['" + required.front() + "'] must be an array");
  const Index n = first.shape(0);
  set.resize(n);
  const std::vector<Index> order = identity_order(n);
  for (auto item : arrays) {
    const std::string name = py::cast<std::string>(item.first);
    if (!set.fields.contains(name)) {
      std::string known;
      for (const auto& f : set.fields.all()) known += (known.empty() ? "" : ", ") + f->name();
      throw std::invalid_argument("unknown " + label + " array '" + name + "'; known: " + known);
    }
    write_rows(set.fields.at(name), item.second, order, label + "['" + name + "']");
  }
  if (!arrays.contains("id")) std::iota(set.id.data(), set.id.data() + n, std::int64_t(0));
}

// The storage-order fields of a set as {name: array} (a State part), and back.
py::dict fields_to_dict(const FieldRegistry& fields) {
  py::dict out;
  const std::vector<Index> order = identity_order(fields.size());
  for (const auto& f : fields.all()) out[py::str(f->name())] = copy_rows(*f, order);
  return out;
}
void fields_from_dict(FieldRegistry& fields, const py::dict& saved, const std::string& label) {
  for (const auto& f : fields.all())
    if (!saved.contains(f->name()))
      throw std::invalid_argument("the saved state has no " + label + " field '" + f->name() +
                                  "' that this simulation needs (another version or other options)");
  Index n = -1;
  for (auto item : saved) {
    const std::string name = py::cast<std::string>(item.first);
    if (!fields.contains(name))
      throw std::invalid_argument("the saved state has a " + label + " field '" + name +
                                  "' that this simulation does not use (another version or other options)");
    const py::array a = py::array::ensure(item.second);
    if (!a || a.ndim() < 1) throw std::invalid_argument("saved " + label + " field '" + name + "' is not an array");
    if (n >= 0 && a.shape(0) != n)
      throw std::invalid_argument("saved " + label + " fields have different lengths");
    n = a.shape(0);
  }
  fields.resize(std::max<Index>(n, 0));
  const std::vector<Index> order = identity_order(fields.size());
  for (const auto& f : fields.all()) write_rows(*f, saved[py::str(f->name())], order, "saved " + label + " field '" + f->name() + "'");
}

// The saved values of a part of the State that lists them (for_each_saved: RunCounters,
// LoadAccumulator, BodyKinematics) into / from a dictionary, each value copied (an Eigen vector becomes an array).
template <class Saved> void saved_to_dict(const Saved& saved, py::dict& d) {
  Saved::for_each_saved(saved, [&](const char* name, const auto& value) { d[name] = std::decay_t<decltype(value)>(value); });
}
template <class Saved> void saved_from_dict(const py::dict& d, Saved& saved) {
  Saved::for_each_saved(saved, [&](const char* name, auto& value) { value = d[name].cast<std::decay_t<decltype(value)>>(); });
}

py::dict counters_to_dict(const RunCounters& c) {
  py::dict d;
  saved_to_dict(c, d);
  return d;
}
RunCounters counters_from_dict(const py::dict& d) {
  RunCounters c;
  saved_from_dict(d, c);
  return c;
}

// A load as users read it: force and torque at the last step and their time averages since the
// last reset (the last values before any step has been averaged).
template <int D> void load_summary(const LoadAccumulator<D>& load, py::dict& d) {
  using Angular = typename BodyRotation<D>::Angular;
  d["force"] = Vec<D>(load.force);
  d["torque"] = Angular(load.torque);
  const double t = load.impulse_time;
  d["mean_force"] = t > 0.0 ? Vec<D>(load.impulse / t) : Vec<D>(load.force);
  d["mean_torque"] = t > 0.0 ? Angular(load.angular_impulse / t) : Angular(load.torque);
  d["averaged_over"] = t;
}

// A motion segment as one row of numbers: duration (s), velocity (D values, m/s), angular velocity
// (2D: one value, rad/s clockwise; 3D: three, rad/s) and back.
template <int D> std::vector<double> segment_row(const MotionSegment<D>& s) {
  std::vector<double> row{s.duration};
  for (int c = 0; c < D; ++c) row.push_back(s.velocity[c]);
  if constexpr (D == 2) {
    row.push_back(s.angular_velocity);
  } else {
    for (int c = 0; c < 3; ++c) row.push_back(s.angular_velocity[c]);
  }
  return row;
}
template <int D> MotionSegment<D> segment_from_row(const std::vector<double>& row) {
  constexpr int spin_values = BodyRotation<D>::angular_components;
  if (row.size() != static_cast<size_t>(1 + D + spin_values))
    throw std::invalid_argument("a motion row is (duration, velocity (" + std::to_string(D) + " values), angular velocity (" +
                                std::to_string(spin_values) + (D == 2 ? " value, clockwise))" : " values))"));
  MotionSegment<D> s;
  s.duration = row[0];
  for (int c = 0; c < D; ++c) s.velocity[c] = row[static_cast<size_t>(1 + c)];
  if constexpr (D == 2) {
    s.angular_velocity = row[D + 1];
  } else {
    for (int c = 0; c < 3; ++c) s.angular_velocity[c] = row[static_cast<size_t>(D + 1 + c)];
  }
  return s;
}

// A body's full state as numbers: kinematics, loads, impulses, and its motion schedule.
template <int D> py::dict body_to_dict(const RigidBody<D>& b) {
  using Orientation = typename BodyRotation<D>::Orientation;
  py::dict d;
  saved_to_dict(b.kinematics, d);
  d["driven"] = b.driven;
  saved_to_dict<LoadAccumulator<D>>(b, d);
  d["motion_start"] = b.motion_start;
  d["start_reference"] = Vec<D>(b.motion.start().reference);
  d[py::str(std::string("start_") + BodyRotation<D>::orientation_name)] = Orientation(b.motion.start().orientation);
  std::vector<std::vector<double>> segments;
  for (const MotionSegment<D>& s : b.motion.segments()) segments.push_back(segment_row<D>(s));
  d["segments"] = segments;
  return d;
}
template <int D> RigidBody<D> body_from_dict(const py::dict& d) {
  using Orientation = typename BodyRotation<D>::Orientation;
  RigidBody<D> b;
  BodyKinematics<D> start;
  start.reference = d["start_reference"].cast<Vec<D>>();
  start.orientation = d[py::str(std::string("start_") + BodyRotation<D>::orientation_name)].template cast<Orientation>();
  std::vector<MotionSegment<D>> segments;
  for (const auto& row : d["segments"].cast<std::vector<std::vector<double>>>()) segments.push_back(segment_from_row<D>(row));
  b.motion = PrescribedMotion<D>(start, std::move(segments));
  b.motion_start = d["motion_start"].cast<double>();
  saved_from_dict(d, b.kinematics);
  b.driven = d["driven"].cast<bool>();
  saved_from_dict<LoadAccumulator<D>>(d, b);
  return b;
}

// The load and pose of a body as users read it (per metre of depth; Python multiplies by width).
template <int D> py::dict body_summary(const RigidBody<D>& b) {
  py::dict d;
  saved_to_dict(b.kinematics, d);
  d["driven"] = b.driven;
  load_summary<D>(b, d);
  return d;
}

// Motion segments from Python rows (segment_from_row).
template <int D> std::vector<MotionSegment<D>> to_segments(const std::vector<std::vector<double>>& rows) {
  std::vector<MotionSegment<D>> out;
  for (const auto& row : rows) out.push_back(segment_from_row<D>(row));
  return out;
}

template <int D> FieldRegistry& fields_of(Simulation<D>& s, const std::string& set) {
  if (set == "granular") return s.granular().fields;
  if (set == "walls") return s.walls().fields;
  throw std::invalid_argument("particle set must be 'granular' or 'walls', not '" + set + "'");
}
template <int D> const IdArray& ids_of(Simulation<D>& s, const std::string& set) {
  return set == "walls" ? s.walls().id : s.granular().id;
}

template <int D> void bind_simulation(py::module_& m, const char* class_name) {
  using Sim = Simulation<D>;
  using Rotation = BodyRotation<D>;
  using Orientation = typename Rotation::Orientation;
  using Angular = typename Rotation::Angular;
  auto field = [](Sim& s, const std::string& name, const std::string& set) {
    FieldRegistry& fields = fields_of(s, set);
    return copy_rows(fields.at(name), id_order(ids_of(s, set)));
  };
  auto property = [field](const char* field_name, const char* set, const char* doc) {
    return py::cpp_function([field, field_name, set](Sim& s) { return field(s, field_name, set); },
                            py::doc(doc));
  };
  py::class_<Sim> cls(m, class_name, "Granular SPH simulation (plane strain in 2D: x, z). Arrays are id-ordered copies.");
  cls.def(py::init([](const ModelParams<D>& params, const py::dict& granular, const py::dict& walls) {
           GranularParticles<D> g;
           fill_set(g, granular, {"position", "velocity", "density", "mass"}, "granular");
           WallParticles<D> w;
           fill_set(w, walls, {"position", "normal", "mass", "no_slip", "group"}, "walls");
           if (!walls.contains("density")) w.density.setConstant(w.size(), params.material.reference_density);
           w.body.setConstant(w.size(), -1);
           return std::make_unique<Sim>(params, std::move(g), std::move(w));
         }),
         py::arg("params"), py::arg("granular"), py::arg("walls"),
         "granular: named arrays position (N, D), velocity, density (N,), mass (N,) [, id (N,)];\n"
         "walls: position (M, D), normal, mass, no_slip (uint8), group (int32) [, id, density].")
      .def("advance", &Sim::advance, py::arg("t_end"), py::arg("max_steps"), py::call_guard<py::gil_scoped_release>(),
           "Step until t_end or max_steps (scheduled wall removals applied on the way); returns the steps taken.")
      .def("refresh", &Sim::refresh, "Rebuild neighbours and rates after editing the state.")
      .def("remove_wall_group", &Sim::remove_wall_group, py::arg("group"))
      .def("schedule_wall_removal", &Sim::schedule_wall_removal, py::arg("group"), py::arg("time"),
           "Remove wall group `group` when the simulation time reaches `time` (s).")
      .def("field", field, py::arg("name"), py::arg("set") = "granular",
           "A copy (read-only) of a registered per-particle field, rows in ascending id order.")
      .def("set_field", [](Sim& s, const std::string& name, const py::handle& values, const std::string& set) {
             write_rows(fields_of(s, set).at(name), values, id_order(ids_of(s, set)), set + " field '" + name + "'");
           }, py::arg("name"), py::arg("values"), py::arg("set") = "granular",
           "Overwrite a per-particle field, rows in ascending id order; call refresh() afterwards.")
      .def("field_names", [](Sim& s, const std::string& set) {
             std::vector<std::string> names;
             for (const auto& f : fields_of(s, set).all()) names.push_back(f->name());
             return names;
           }, py::arg("set") = "granular", "Names of the registered fields of a particle set.")
      .def("field_units", [](Sim& s, const std::string& set) {
             py::dict out;
             for (const auto& f : fields_of(s, set).all()) out[py::str(f->name())] = py::make_tuple(f->unit(), f->doc());
             return out;
           }, py::arg("set") = "granular", "{name: (unit, doc)} of the registered fields of a particle set.")
      .def("state", [](Sim& s) {
             py::dict d;
             d["granular"] = fields_to_dict(s.granular().fields);
             d["walls"] = fields_to_dict(s.walls().fields);
             d["counters"] = counters_to_dict(s.counters());
             py::list bodies;
             for (const RigidBody<D>& b : s.bodies()) bodies.append(body_to_dict(b));
             d["bodies"] = bodies;
             std::vector<std::pair<double, std::int32_t>> removals;
             for (const WallRemoval& r : s.pending_wall_removals()) removals.emplace_back(r.time, r.group);
             d["removals"] = removals;
             py::list wall_loads;  // empty unless tracked
             for (const WallLoad<D>& load : s.wall_loads()) {
               py::dict l;
               l["group"] = load.group;
               saved_to_dict<LoadAccumulator<D>>(load, l);
               wall_loads.append(l);
             }
             d["wall_loads"] = py::dict(py::arg("tracked") = s.tracks_wall_loads(),
                                        py::arg("point") = Vec<D>(s.wall_load_point()), py::arg("loads") = wall_loads);
             return d;
           }, "The whole State in storage order (copies): granular and wall fields, counters, bodies, removals, "
              "tracked wall loads.")
      .def("restore", [](Sim& s, const py::dict& state) {
             fields_from_dict(s.granular().fields, state["granular"].cast<py::dict>(), "granular");
             fields_from_dict(s.walls().fields, state["walls"].cast<py::dict>(), "wall");
             std::vector<RigidBody<D>> bodies;
             for (const auto& b : state["bodies"].cast<py::list>()) bodies.push_back(body_from_dict<D>(b.cast<py::dict>()));
             std::vector<WallRemoval> removals;
             for (const auto& [time, group] : state["removals"].cast<std::vector<std::pair<double, std::int32_t>>>())
               removals.push_back({time, group});
             s.restore(counters_from_dict(state["counters"].cast<py::dict>()), bodies, std::move(removals));
             const py::dict wall_loads = state.contains("wall_loads") ? state["wall_loads"].cast<py::dict>() : py::dict();
             const bool saved_tracked = wall_loads.contains("tracked") && wall_loads["tracked"].cast<bool>();
             if (saved_tracked) {
               std::vector<WallLoad<D>> loads;
               for (const auto& item : wall_loads["loads"].cast<py::list>()) {
                 const py::dict l = item.cast<py::dict>();
                 WallLoad<D> load;
                 load.group = l["group"].cast<std::int32_t>();
                 saved_from_dict<LoadAccumulator<D>>(l, load);
                 loads.push_back(load);
               }
               s.restore_wall_loads(wall_loads["point"].cast<Vec<D>>(), loads);
             } else if (s.tracks_wall_loads()) {
               throw std::invalid_argument("the saved state does not track wall loads, this simulation does");
             }
           }, py::arg("state"), "Continue from a State made by state(): nothing is recomputed.")
      .def("permute_storage", [](Sim& s, const std::string& set, const std::vector<Index>& order) {
             std::vector<Index> check(order);
             std::sort(check.begin(), check.end());
             for (size_t k = 0; k < check.size(); ++k)
               if (check[k] != static_cast<Index>(k)) throw std::invalid_argument("order must be a permutation of 0..N-1");
             if (set == "walls") s.permute_walls(order);
             else if (set == "granular") s.permute_granular(order);
             else throw std::invalid_argument("particle set must be 'granular' or 'walls'");
           }, py::arg("set"), py::arg("order"),
           "Debug hook: reorder a particle set's storage (row k takes old row order[k]). Users see no change.")
      .def("add_body", [](Sim& s, std::int32_t group, const Vec<D>& reference, const Orientation& orientation,
                          const std::vector<std::vector<double>>& motion) {
             return s.add_body(group, reference, orientation, to_segments<D>(motion));
           }, py::arg("group"), py::arg("reference"), py::arg(Rotation::orientation_name), py::arg("motion"),
           D == 2 ? "Make a wall group a rigid body with reference point `reference` (m) and current clockwise "
                    "angle `angle` (rad), following `motion`: rows (duration s, velocity m/s, spin rad/s clockwise) "
                    "from now on, holding still after the last. Returns the body index."
                  : "Make a wall group a rigid body with reference point `reference` (m) and current orientation "
                    "`orientation` (unit quaternion w, x, y, z), following `motion`: rows (duration s, velocity "
                    "(3) m/s, angular velocity (3) rad/s, right-handed, about the reference point) from now on, "
                    "holding still after the last. Returns the body index.")
      .def("add_driven_body", &Sim::add_driven_body, py::arg("group"), py::arg("reference"),
           py::arg(Rotation::orientation_name),
           "Make a wall group a rigid body driven from outside (a multibody engine): set its kinematics with "
           "set_body_kinematics before each step. `reference` (m) and the orientation (2D: clockwise angle, "
           "rad; 3D: unit quaternion w, x, y, z) describe the present layout. Returns the body index.")
      .def("set_body_kinematics", [](Sim& s, int body, const Vec<D>& reference, const Orientation& orientation,
                                     const Vec<D>& velocity, const Angular& angular_velocity,
                                     const Vec<D>& acceleration, const Angular& angular_acceleration) {
             BodyKinematics<D> k;
             k.reference = reference;
             k.orientation = orientation;
             k.velocity = velocity;
             k.angular_velocity = angular_velocity;
             k.acceleration = acceleration;
             k.angular_acceleration = angular_acceleration;
             s.set_body_kinematics(body, k);
           }, py::arg("body"), py::arg("reference"), py::arg(Rotation::orientation_name), py::arg("velocity"),
           py::arg(Rotation::angular_velocity_name), py::arg("acceleration"), py::arg("angular_acceleration"),
           "Pose (m; 2D: rad clockwise, 3D: unit quaternion w, x, y, z), velocity (m/s, rad/s) and acceleration "
           "(m/s², rad/s²) of a driven body at the end of the next step; its particles follow at that step.")
      .def_property_readonly("body_count", [](const Sim& s) { return s.bodies().size(); })
      .def("body_state", [](const Sim& s, std::size_t b) {
             if (b >= s.bodies().size()) throw py::index_error("no body " + std::to_string(b));
             return body_summary(s.bodies()[b]);
           }, py::arg("body"),
           "Pose, rates and granular load of a body: force (2D: N/m; 3D: N) and torque (2D: clockwise, N·m/m; "
           "3D: a vector, N·m) about the reference point at the last step, and their time averages since "
           "reset_body_means().")
      .def("reset_body_means", &Sim::reset_body_impulses, "Restart the time averages of body loads.")
      .def("track_wall_loads", &Sim::track_wall_loads, py::arg("point"),
           "From now on keep the load of the grains on every fixed wall group (not a body), torques clockwise "
           "about `point` (m); re-evaluates the rates at the present state. Off by default (no cost).")
      .def_property_readonly("tracks_wall_loads", &Sim::tracks_wall_loads)
      .def("wall_loads", [](const Sim& s) {
             py::dict out;
             for (const WallLoad<D>& load : s.wall_loads()) {
               py::dict d;
               load_summary<D>(load, d);
               out[py::int_(load.group)] = d;
             }
             return out;
           },
           "{wall group: load} of the grains on each tracked fixed wall group: force (N/m) and clockwise torque "
           "(N·m/m) about the tracking point at the last step, and their time averages since reset_wall_load_means().")
      .def("reset_wall_load_means", &Sim::reset_wall_load_impulses, "Restart the time averages of wall loads.")
      .def_property_readonly("penetrating_particles", [](const Sim& s) { return s.counters().penetrating_particles; },
           "Granular particles past a wall's surface row (closer than spacing/2 to an interior wall "
           "particle) at the last step.")
      .def_property_readonly("penetrated_particles", [](const Sim& s) { return s.counters().penetrated_particles; },
           "Distinct granular particles that have got past a wall's surface row at any step of the run "
           "(leak counter).")
      .def_property_readonly("leaked_ids", [](Sim& s) {
             std::vector<std::int64_t> ids;
             const GranularParticles<D>& g = s.granular();
             for (Index i = 0; i < g.size(); ++i)
               if (g.penetrated[i]) ids.push_back(g.id[i]);
             std::sort(ids.begin(), ids.end());
             return ids;
           }, "Ids of the granular particles counted by the leak counter, ascending.")
      .def("stable_time_step", &Sim::stable_time_step)
      .def("apply_shepard_filter", &Sim::apply_shepard_filter)
      .def("apply_mls_regularisation", &Sim::apply_mls_regularisation,
           "MLS-regularises the constitutive model's stress state once (Eq. 3.26-3.30, linear basis).")
      .def("kernel_sum", [](Sim& s) {
             const std::vector<Index> order = id_order(s.granular().id);
             const ScalarArray sums = s.kernel_sum();
             ScalarArray out(sums.size());
             for (size_t k = 0; k < order.size(); ++k) out[static_cast<Index>(k)] = sums[order[k]];
             return out;
           }, "Σ_j V_j W_ij over granular neighbours, self included, in id order.")
      .def("kernel_gradient_sum", [](Sim& s) {
             const std::vector<Index> order = id_order(s.granular().id);
             const VecArray<D> sums = s.kernel_gradient_sum();
             VecArray<D> out(sums.rows(), D);
             for (size_t k = 0; k < order.size(); ++k) out.row(static_cast<Index>(k)) = sums.row(order[k]);
             return out;
           }, "Σ_j V_j ∇W_ij over granular neighbours, in id order.")
      .def_property_readonly("step", [](const Sim& s) { return s.counters().step; })
      .def_property_readonly("time", [](const Sim& s) { return s.counters().time; })
      .def_property_readonly("last_dt", [](const Sim& s) { return s.counters().last_dt; })
      .def_property_readonly("neighbour_builds", [](const Sim& s) { return s.counters().neighbour_builds; })
      .def_property_readonly("max_speed", [](const Sim& s) { return s.counters().max_speed; })
      .def_property_readonly("max_acceleration", [](const Sim& s) { return s.counters().max_acceleration; })
      .def_property_readonly("memory_bytes", &Sim::memory_bytes,
                             "Bytes held by particle fields, neighbour lists and pair caches.")
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
      .def_property_readonly("params", &Sim::params);
  // id-ordered copies of the fields users read most
  const std::array<std::pair<const char*, const char*>, 12> granular_fields{{
      {"id", "granular particle ids, ascending"}, {"position", "positions (N, D), m"},
      {"velocity", "velocities (N, D), m/s"}, {"acceleration", "Dv/Dt (N, D), m/s²"},
      {"density", "densities (N,), kg/m³"}, {"density_rate", "Dρ/Dt (N,)"}, {"pressure", "pressures (N,), Pa"},
      {"mass", "masses (N,), kg per metre of depth in 2D"}, {"stress", "Cauchy stress (N, D, D), Pa"},
      {"velocity_gradient", "∇v (N, D, D), 1/s"}, {"penetrated", "leak flags (N,)"},
      {"volume", "m/ρ (N,)"}}};
  for (const auto& [field_name, doc] : granular_fields)
    cls.def_property_readonly(field_name, property(field_name, "granular", doc));
  const std::array<std::pair<const char*, const char*>, 9> wall_fields{{
      {"id", "wall particle ids, ascending"}, {"position", "wall positions, m"}, {"velocity", "wall velocities, m/s"},
      {"density", "wall densities, kg/m³"}, {"normal", "wall normals"}, {"stress", "wall stress, Pa"},
      {"group", "wall group of each wall particle"}, {"interior", "1: a layer or more inside its wall"},
      {"body", "rigid body index, -1 for fixed walls"}}};
  for (const auto& [field_name, doc] : wall_fields)
    cls.def_property_readonly((std::string("wall_") + field_name).c_str(), property(field_name, "walls", doc));
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

  bind_simulation<2>(m, "Simulation2D");
  bind_simulation<3>(m, "Simulation3D");

  m.def("constitutive_update", [](const ModelParams<2>& params, const Mat<2>& velocity_gradient, double density,
                                  double dt, const py::dict& state) {
        params.validate();
        FieldRegistry fields;
        fields.resize(1);
        ConstitutiveModelVariant<2> model = make_constitutive_model(params);
        return std::visit([&](auto& chosen) {
          chosen.register_fields(fields);
          const std::vector<Index> particle{0};
          for (auto item : state) {
            const std::string name = py::cast<std::string>(item.first);
            if (!fields.contains(name)) throw std::invalid_argument("this model keeps no state named '" + name + "'");
            py::array values = py::array::ensure(item.second);
            write_rows(fields.at(name), values.reshape({py::ssize_t(1), values.size()}), particle, "state['" + name + "']");
          }
          double pressure = 0.0;
          const Mat<2> sigma = chosen.update(0, velocity_gradient, density, dt, pressure);
          py::dict new_state;
          for (const auto& f : fields.all()) new_state[py::str(f->name())] = copy_rows(*f, particle)[py::int_(0)];
          py::dict out;
          out["stress"] = sigma;
          out["pressure"] = pressure;
          out["state"] = new_state;
          out["wave_speed"] = chosen.wave_speed();
          out["wall_pressure_floor"] = chosen.wall_pressure_floor();
          return out;
        }, model);
      }, py::arg("params"), py::arg("velocity_gradient"), py::arg("density"), py::arg("dt"),
      py::arg("state") = py::dict(),
      "One stress update of the configured constitutive model for one particle (for tests and studies). "
      "`state` holds the model's per-particle state by field name (e.g. deviatoric_stress (2, 2) of "
      "mu_i_hypoelastic, stress_state (3, 3) of drucker_prager; zero when not given). Returns the in-plane "
      "stress, the pressure, the new state, the model's wave speed and its wall tension cut-off.");

  m.def("set_num_threads", [](int n) {
        if (n < 1) throw std::invalid_argument("threads must be >= 1");
        omp_set_num_threads(n);
      }, py::arg("n"), "Number of OpenMP threads for the following runs (process-wide OpenMP setting).");
  m.def("get_max_threads", &omp_get_max_threads, "OpenMP threads a parallel loop would use now.");
  m.def("set_particles_per_thread", [](Index n) {
        if (n < 1) throw std::invalid_argument("particles per thread must be >= 1");
        particles_per_thread().store(n);
      }, py::arg("n"),
      "Fewest particles a loop gives each thread (process-wide, like the thread count): a smaller loop "
      "runs on fewer threads. 1 = split every loop.");
  m.def("get_particles_per_thread", [] { return particles_per_thread().load(); },
        "Fewest particles a loop gives each thread (see set_particles_per_thread).");

  m.def("neighbour_lists", [](const py::array_t<double, py::array::c_style | py::array::forcecast>& points, double radius) {
        if (points.ndim() != 2 || points.shape(1) != 2) throw std::invalid_argument("points must have shape (N, 2)");
        VecArray<2> x(points.shape(0), 2);
        std::copy(points.data(), points.data() + points.size(), x.data());
        if (!(radius > 0.0)) throw std::invalid_argument("radius must be > 0");
        Vec<2> lower, upper;
        bounding_box<2>(x, VecArray<2>(0, 2), radius, lower, upper);
        CellGrid<2> grid;
        grid.build(x, lower, upper, radius);
        NeighbourList list;
        build_neighbour_list<2>(x, x, grid, radius, true, list);
        py::array_t<std::int64_t> offsets(static_cast<py::ssize_t>(list.offsets.size()), list.offsets.data());
        py::array_t<std::int32_t> indices(static_cast<py::ssize_t>(list.indices.size()), list.indices.data());
        return py::make_tuple(offsets, indices);
      }, py::arg("points"), py::arg("radius"),
      "Neighbours within radius (excluding self) of 2D points as CSR (offsets, indices).");

  m.def("near_body", [](const py::array_t<double, py::array::c_style | py::array::forcecast>& offsets,
                        const Vec<2>& reference, double angle, double radius,
                        const py::array_t<double, py::array::c_style | py::array::forcecast>& points) {
        if (offsets.ndim() != 2 || offsets.shape(1) != 2) throw std::invalid_argument("offsets must have shape (N, 2)");
        if (points.ndim() != 2 || points.shape(1) != 2) throw std::invalid_argument("points must have shape (M, 2)");
        if (!(radius > 0.0)) throw std::invalid_argument("radius must be > 0");
        std::vector<Vec<2>> local;
        for (py::ssize_t k = 0; k < offsets.shape(0); ++k) local.emplace_back(offsets.at(k, 0), offsets.at(k, 1));
        const BodyDistanceField<2> field(local, radius);
        const BodyProximity<2> proximity({{&field, reference, BodyRotation<2>::inverse(angle)}});
        py::array_t<bool> near(points.shape(0));
        for (py::ssize_t k = 0; k < points.shape(0); ++k)
          near.mutable_data()[k] = proximity.near(Vec<2>(points.at(k, 0), points.at(k, 1)));
        return near;
      }, py::arg("offsets"), py::arg("reference"), py::arg("angle"), py::arg("radius"), py::arg("points"),
      "The active domain's proximity test: whether each point lies within radius of a particle of a rigid "
      "body whose body-frame offsets are turned clockwise by angle about reference.");

  m.def("wendland_c2_2d", [](const py::array_t<double, py::array::c_style | py::array::forcecast>& r, double h) {
        if (!(h > 0.0)) throw std::invalid_argument("h must be > 0");
        const WendlandC2<2> kernel(h);
        py::array_t<double> w(r.size()), f(r.size());
        for (py::ssize_t k = 0; k < r.size(); ++k) {
          w.mutable_data()[k] = kernel.value(r.data()[k]);
          f.mutable_data()[k] = kernel.gradient_factor(r.data()[k]);
        }
        return py::make_tuple(w, f);
      }, py::arg("r"), py::arg("h"),
      "Wendland C2 kernel W(r) and (dW/dr)/r in 2D, support 2h (Eq. 2.36).");
}
