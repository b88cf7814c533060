// terrasph's 3D RFT terrain as a MuJoCo engine plugin, "terrasph.rft": a passive force (mjpPlugin
// with mjPLUGIN_PASSIVE) that adds to qfrc_passive, for every coupled body, the load of a flat
// granular surface on its collision geoms' surface elements (the law of terrasph/rft3d.hpp,
// body_wrench(); the elements of terrasph/rft3d_surface.hpp, built when MuJoCo makes an mjData).
// compute() adds the load explicitly, at the state MuJoCo passes; advance() then makes the step
// backward Euler in it, as terrasph's 3D RFT stepper does (Sand's comment). docs/mujoco_plugin.md
// has the steps at which it is accurate, measured.
//
// Per instance and mjData: the elements and scratch arrays (plugin_data, freed with the mjData,
// copied with it), and in plugin_state each coupled body's last wrench (F, τ about its centre of
// mass; N, N m; world frame). No global state besides the registration.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "backward_euler.hpp"
#include "rft3d_assembly.hpp"
#include "terrasph/rft.hpp"
#include "terrasph/rft3d.hpp"
#include "terrasph/rft3d_robot.hpp"
#include "terrasph/rft3d_surface.hpp"

namespace terrasph::rft {

namespace {

constexpr const char* kName = "terrasph.rft";
constexpr std::array<const char*, 7> kAttributes = {"table", "zeta", "surface", "element_length", "regularisation",
                                                    "coefficients", "implicit"};

/// terrasph.rft.REGULARISATION_SPEED (m/s): the default speed below which a leading face's load fades
/// with its normal speed (tests/test_mujoco_plugin.py checks the two agree).
constexpr double kRegularisationSpeed = 1e-4;
/// terrasph.rft.GLASS_BEADS_ZETA (N/m³), the generic map's default scale.
constexpr double kGlassBeadsZeta = 2.44e5;
/// terrasph.robots.rft3d's ELEMENT_FRACTION: the default element size as a fraction of the body's
/// largest geom's bounding radius.
constexpr double kElementFraction = 0.1;
/// terrasph.robots.rft3d_terrain's NEWTON_ITERATIONS, NEWTON_HALVINGS, NEWTON_TOLERANCE: the implicit
/// correction's Newton iterations per step at most, halvings of a step, and relative tolerance.
constexpr NewtonSettings kNewton{12, 20, 1e-8};
/// Li, Zhang & Goldman 2013 (Science 339:1408), supplementary Table S2, as terrasph.rft.GENERIC.
constexpr const char* kGenericTerms = "A00=0.206 A10=0.169 B11=0.212 B01=0.358 Bm11=0.055 C11=-0.124 C01=0.253 "
                                      "Cm11=0.007 D10=0.088";

/// A bad configuration: the message names the attribute and what is allowed.
struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The attribute `name` of `instance`, "" when not set.
std::string attribute(const mjModel* m, int instance, const char* name) {
  const char* value = mj_getPluginConfig(m, instance, name);
  return value ? std::string(value) : std::string();
}

/// `value` as printf's %g writes it.
std::string shortest(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

/// A finite number from attribute `name`, `fallback` if unset; ConfigError unless it is finite and,
/// if `positive`, > 0.
double number(const mjModel* m, int instance, const char* name, double fallback, bool positive, const char* unit) {
  const std::string text = attribute(m, instance, name);
  if (text.empty()) return fallback;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !std::isfinite(value) || (positive && !(value > 0.0)))
    throw ConfigError(std::string("attribute '") + name + "' = '" + text + "' is invalid: allowed a finite number" +
                      (positive ? " > 0" : "") + " (" + unit + ")");
  return value;
}

/// Adds the term named `name` (terrasph.rft.parse_term: A, B, C or D, then m (m1 for −1) and n)
/// with `value` to `table`.
void add_term(Coefficients& table, const std::string& name, double value) {
  const bool negative = name.size() == 4 && name[1] == 'm';
  const std::string digits = name.substr(negative ? 2 : 1);
  const char letter = name.empty() ? '?' : name[0];
  if (std::string("ABCD").find(letter) == std::string::npos || digits.size() != 2 || !std::isdigit(digits[0]) ||
      !std::isdigit(digits[1]) || (negative && digits[0] == '0'))
    throw ConfigError("coefficient '" + name + "' is not a term's name: allowed A, B, C or D, then m (m1 for -1) and "
                      "n, each 0..4 (e.g. A00, Bm11)");
  const int m = (negative ? -1 : 1) * (digits[0] - '0'), n = digits[1] - '0';
  if (std::abs(m) > kMaxOrder || n > kMaxOrder)
    throw ConfigError("coefficient '" + name + "' exceeds the order " + std::to_string(kMaxOrder));
  Term* term = nullptr;
  for (Term& t : table.terms)
    if (t.m == m && t.n == n) term = &t;
  if (term == nullptr) term = &table.terms.emplace_back(Term{m, n});
  // A: α̂_z cos, B: α̂_z sin, C: α̂_x cos, D: α̂_x sin (terrasph.rft's naming, Li et al. Eq. S2)
  (letter == 'A' ? term->z_cos : letter == 'B' ? term->z_sin : letter == 'C' ? term->x_cos : term->x_sin) += value;
  table.order_beta = std::max(table.order_beta, std::abs(m));
  table.order_gamma = std::max(table.order_gamma, n);
}

/// A yes/no attribute `name` ("true"/"false"), `fallback` if unset.
bool flag(const mjModel* m, int instance, const char* name, bool fallback) {
  const std::string text = attribute(m, instance, name);
  if (text.empty()) return fallback;
  if (text == "true") return true;
  if (text == "false") return false;
  throw ConfigError(std::string("attribute '") + name + "' = '" + text + "' is invalid: allowed true or false");
}

/// A map from "NAME=value NAME=value ..." (whitespace or commas between the pairs).
Coefficients parse_terms(const std::string& text, const char* attribute_name) {
  Coefficients table;
  table.order_beta = table.order_gamma = 0;
  std::string pairs = text;
  for (char& c : pairs)
    if (c == ',') c = ' ';
  std::istringstream in(pairs);
  std::string pair;
  while (in >> pair) {
    const auto equals = pair.find('=');
    char* end = nullptr;
    const std::string value = equals == std::string::npos ? "" : pair.substr(equals + 1);
    const double v = std::strtod(value.c_str(), &end);
    if (equals == std::string::npos || value.empty() || *end != '\0' || !std::isfinite(v))
      throw ConfigError(std::string("attribute '") + attribute_name + "': '" + pair +
                        "' is invalid: allowed NAME=number pairs, e.g. 'A00=0.206 B01=0.358'");
    try {
      add_term(table, pair.substr(0, equals), v);
    } catch (const ConfigError& error) {
      throw ConfigError(std::string("attribute '") + attribute_name + "': " + error.what());
    }
  }
  if (table.terms.empty())
    throw ConfigError(std::string("attribute '") + attribute_name + "' holds no coefficient");
  return table;
}

/// The coefficients and ζ of a table file written by terrasph.rft.save_coefficients (JSON with
/// "format": "terrasph-rft-coefficients", "zeta" and a flat "coefficients" object).
Coefficients read_table_file(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw ConfigError("attribute 'table' = '" + path + "': the file cannot be read");
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const auto malformed = [&](const std::string& what) {
    return ConfigError("attribute 'table' = '" + path + "' is malformed: " + what +
                       " (allowed a table written by terrasph rft-calibrate)");
  };
  if (text.find("\"terrasph-rft-coefficients\"") == std::string::npos) throw malformed("no \"format\"");
  // the value of the first "key" whose value starts as `accepts` allows (the units' entries are strings)
  const auto value_of = [&](const std::string& key, const auto& accepts) {
    for (auto at = text.find("\"" + key + "\""); at != std::string::npos; at = text.find("\"" + key + "\"", at + 1)) {
      const auto colon = text.find_first_not_of(" \t\r\n", at + key.size() + 2);
      if (colon == std::string::npos || text[colon] != ':') continue;
      const auto value = text.find_first_not_of(" \t\r\n", colon + 1);
      if (value != std::string::npos && accepts(text[value])) return value;
    }
    throw malformed("no \"" + key + "\" of the right kind");
  };
  const auto open = value_of("coefficients", [](char c) { return c == '{'; });
  const auto close = text.find('}', open);
  if (close == std::string::npos) throw malformed("\"coefficients\" is not closed");
  std::string pairs;
  for (std::size_t i = open + 1; i < close; ++i) {
    const char c = text[i];
    if (c == ':') pairs += '=';
    else if (c != '"' && !std::isspace(static_cast<unsigned char>(c))) pairs += c;
  }
  Coefficients table = parse_terms(pairs, "table");
  const auto at = value_of("zeta", [](char c) { return std::isdigit(static_cast<unsigned char>(c)) || c == '.'; });
  const double zeta = std::strtod(text.c_str() + at, nullptr);
  if (!(std::isfinite(zeta) && zeta > 0)) throw malformed("\"zeta\" is not a number > 0");
  table.zeta = zeta;
  return table;
}

/// The map of the instance's "table" (generic, or the path of a JSON table), or its "coefficients"
/// ("A00=... B01=..."); "zeta" (N/m³) replaces the scale.
Coefficients read_map(const mjModel* m, int instance) {
  const std::string name = attribute(m, instance, "table"), terms = attribute(m, instance, "coefficients");
  Coefficients table;
  if (!terms.empty()) {
    if (!name.empty()) throw ConfigError("attributes 'table' and 'coefficients' are both set: allowed one of them");
    table = parse_terms(terms, "coefficients");
    table.zeta = kGlassBeadsZeta;
  } else if (name.empty() || name == "generic") {
    table = parse_terms(kGenericTerms, "table");
    table.zeta = kGlassBeadsZeta;
  } else if (name.size() > 5 && name.compare(name.size() - 5, 5, ".json") == 0) {
    table = read_table_file(name);
  } else {
    throw ConfigError("attribute 'table' = '" + name + "' is invalid: allowed 'generic' or the path of a JSON "
                      "coefficient table (terrasph rft-calibrate)");
  }
  table.zeta = number(m, instance, "zeta", table.zeta, true, "N/m^3");
  return table;
}

bool is_collision(const mjModel* m, int geom) { return m->geom_contype[geom] || m->geom_conaffinity[geom]; }

/// The bodies the instance loads: those whose MJCF names the instance (<body><plugin instance=.../>),
/// or, if none does, every body that can move (not welded to the world) with a collision geom.
std::vector<int> coupled_bodies(const mjModel* m, int instance) {
  std::vector<int> named, automatic;
  for (int b = 1; b < m->nbody; ++b) {
    if (m->body_plugin[b] == instance) named.push_back(b);
    bool collides = false;
    for (int g = m->body_geomadr[b]; g >= 0 && g < m->body_geomadr[b] + m->body_geomnum[b]; ++g)
      collides = collides || is_collision(m, g);
    if (collides && m->body_weldid[b] != 0) automatic.push_back(b);
  }
  return named.empty() ? automatic : named;
}

std::string name_of(const mjModel* m, mjtObj kind, int id) {
  const char* name = mj_id2name(m, kind, id);
  return name ? std::string(name) : "#" + std::to_string(id);
}

/// The elements of body `b` from its collision geoms, about `length` m across (0: the default).
RobotBody3D body_elements(const mjModel* m, int b, double length) {
  std::vector<GeomSolid> solids;
  double bound = 0.0;
  for (int g = m->body_geomadr[b]; g >= 0 && g < m->body_geomadr[b] + m->body_geomnum[b]; ++g) {
    bound = std::max(bound, static_cast<double>(m->geom_rbound[g]));
    if (!is_collision(m, g)) continue;
    GeomSolid solid;
    solid.kind = m->geom_type[g];
    if (!is_solid_kind(solid.kind))
      throw ConfigError("geom '" + name_of(m, mjOBJ_GEOM, g) + "' of body '" + name_of(m, mjOBJ_BODY, b) +
                        "' is not a solid the sand can load (allowed sphere, capsule, cylinder, ellipsoid, box, "
                        "mesh): switch its contacts off (contype=conaffinity=0) or name the coupled bodies");
    for (int i = 0; i < 3; ++i) {
      solid.size[i] = m->geom_size[3 * g + i];
      solid.position[i] = m->geom_pos[3 * g + i];
    }
    mju_quat2Mat(solid.rotation.data(), m->geom_quat + 4 * g);
    if (solid.kind == kMesh) {
      const int mesh = m->geom_dataid[g];
      solid.vertices = m->mesh_vert + 3 * m->mesh_vertadr[mesh];
      solid.vertex_count = m->mesh_vertnum[mesh];
      solid.faces = m->mesh_face + 3 * m->mesh_faceadr[mesh];
      solid.face_count = m->mesh_facenum[mesh];
    }
    solids.push_back(solid);
  }
  if (solids.empty())
    throw ConfigError("body '" + name_of(m, mjOBJ_BODY, b) + "' names the sand but has no collision geom");
  SurfacePatches patches = body_surface(solids, length > 0 ? length : kElementFraction * bound);
  return {b, std::move(patches.centre), std::move(patches.normal), std::move(patches.area)};
}

/// An instance's terrain on one mjData.
///
/// compute() (MuJoCo's passive stage of a step's start state t_n) adds each coupled body's load
/// W_n = W(q_n, q̇_n) to qfrc_passive: the explicit load. advance() (after MuJoCo's integrator has
/// taken the step to q̇*, q*, its frames still those of t_n) makes the step backward Euler in the
/// load, as terrasph's RFT stepper does (terrasph.robots.rft3d_terrain, cpp/src/rft3d_robot.cpp, with
/// the same solver, backward_euler.hpp): M (q̇ − q̇*) = dt (G(q̇) − G_n), G = Σ Jᵀ W(J q̇) at t_n's
/// pose, and the positions move by dt (q̇ − q̇*). MuJoCo's RK4 integrator evaluates the forces at
/// other states than t_n's, so there the load stays explicit.
struct Sand {
  Coefficients table;
  double surface = 0.0, regularisation = kRegularisationSpeed;
  bool implicit = true;
  std::vector<RobotBody3D> bodies;
  std::vector<BodyBounds> bounds;  // each body's body_bounds()
  Submerged sub;  // the elements below the surface at the step's start pose
  // what compute() leaves for advance(): the time it saw, the generalised load G_n
  double start_time = std::nan("");
  Vector start_load;
  // each owner's 6 × nv Jacobian (v_com, ω) and wrench; G, ∂G/∂q̇ and M of the correction
  std::vector<Matrix> jacobians;
  std::vector<Vector6> wrenches;
  Vector generalised;
  Matrix stiffness, mass;
  std::vector<mjtNum> linear, angular;

  Sand(const mjModel* m, int instance)
      : table(read_map(m, instance)),
        surface(number(m, instance, "surface", 0.0, false, "m")),
        regularisation(number(m, instance, "regularisation", kRegularisationSpeed, true, "m/s")),
        implicit(flag(m, instance, "implicit", true)) {
    const double length = number(m, instance, "element_length", 0.0, true, "m");
    const mjtNum* g = m->opt.gravity;  // the law's depth and planes are taken along z
    if (!(g[0] == 0.0 && g[1] == 0.0 && g[2] < 0.0))
      throw ConfigError("option gravity = (" + shortest(g[0]) + ", " + shortest(g[1]) + ", " + shortest(g[2]) +
                        ") is invalid for the sand: allowed along -z (its surface is level)");
    for (const int b : coupled_bodies(m, instance)) bodies.push_back(body_elements(m, b, length));
    bounds = body_bounds(bodies);
  }

  /// Writes the owners' wrenches into `state` (6 per coupled body, 0 for the others).
  void record(mjtNum* state) const {
    std::fill(state, state + 6 * bodies.size(), 0.0);
    for (std::size_t i = 0; i < sub.owners.size(); ++i)
      std::copy(wrenches[i].data(), wrenches[i].data() + 6, state + 6 * sub.owners[i]);
  }

  /// The explicit load at the current state: each owner's wrench W(v_com, ω) into qfrc_passive.
  void compute(const mjModel* m, mjData* d, mjtNum* state) {
    sub.fill(bodies, bounds, d->xpos, d->xmat, d->xipos, surface);
    wrenches.assign(sub.owners.size(), Vector6::Zero());
    start_load = Vector::Zero(m->nv);
    for (std::size_t i = 0; i < sub.owners.size(); ++i) {
      const int id = bodies[sub.owners[i]].body_id;
      mjtNum twist[6];  // [ω, v] at the centre of mass, world frame
      mj_objectVelocity(m, d, mjOBJ_BODY, id, twist, 0);
      const BodyWrench load = body_wrench(sub.elements(i), {twist[3], twist[4], twist[5]},
                                          {twist[0], twist[1], twist[2]}, table, regularisation, false);
      wrenches[i] = Eigen::Map<const Vector6>(load.wrench.data());
      // G_n = Jᵀ W at the centre of mass (mj_applyFT adds it to qfrc_passive and to start_load)
      mj_applyFT(m, d, load.wrench.data(), load.wrench.data() + 3, d->xipos + 3 * id, id, d->qfrc_passive);
      mj_applyFT(m, d, load.wrench.data(), load.wrench.data() + 3, d->xipos + 3 * id, id, start_load.data());
    }
    start_time = d->time;
    record(state);
  }

  /// backward_euler()'s view of the loads: G and ∂G/∂q̇ at q̇ (rft3d_assembly.hpp).
  struct StepLoads {
    Sand& sand;
    Vector& generalised;
    Matrix& stiffness;
    std::vector<Vector6> best;
    static constexpr bool kCheapJacobian = false;  // the 3D law's Jacobian costs several loads
    void evaluate(const Vector& qvel, bool jacobian) {
      generalised.setZero();
      if (jacobian) stiffness.setZero();
      add_generalised_load(sand.sub, sand.jacobians, qvel, sand.table, sand.regularisation, jacobian, sand.wrenches,
                           generalised, stiffness);
    }
    void keep() { best = sand.wrenches; }
    void restore() { sand.wrenches = best; }
  };

  /// The backward-Euler correction of the step just integrated (the class comment).
  void advance(const mjModel* m, mjData* d, mjtNum* state) {
    const double dt = m->opt.timestep;
    // only right after the step whose start compute() saw, with an integrator that evaluated the
    // forces there once
    if (!implicit || m->opt.integrator == mjINT_RK4 || sub.owners.empty() || !(start_time + dt == d->time)) return;
    const int nv = static_cast<int>(m->nv);
    jacobians.resize(sub.owners.size());
    linear.resize(static_cast<std::size_t>(3 * nv));
    angular.resize(static_cast<std::size_t>(3 * nv));
    for (std::size_t i = 0; i < sub.owners.size(); ++i) {  // the frames are still t_n's
      mj_jacBodyCom(m, d, linear.data(), angular.data(), bodies[sub.owners[i]].body_id);
      jacobians[i].resize(6, nv);
      jacobians[i].topRows(3) = Eigen::Map<const Matrix>(linear.data(), 3, nv);
      jacobians[i].bottomRows(3) = Eigen::Map<const Matrix>(angular.data(), 3, nv);
    }
    mass.resize(nv, nv);
    mj_fullM(m, d, mass.data());
    generalised.resize(nv);
    stiffness.resize(nv, nv);
    const Vector explicit_qvel = Eigen::Map<const Vector>(d->qvel, nv);
    StepLoads loads{*this, generalised, stiffness, {}};
    const Vector qvel = backward_euler(loads, mass, explicit_qvel, start_load, explicit_qvel, nullptr, dt, kNewton);
    const Vector change = qvel - explicit_qvel;
    mj_integratePos(m, d->qpos, change.data(), dt);  // q moves by dt (q̇ − q̇*)
    Eigen::Map<Vector>(d->qvel, nv) = qvel;
    record(state);
  }
};

Sand* sand_of(const mjData* d, int instance) { return reinterpret_cast<Sand*>(d->plugin_data[instance]); }

int nstate(const mjModel* m, int instance) { return 6 * static_cast<int>(coupled_bodies(m, instance).size()); }

int init(const mjModel* m, mjData* d, int instance) {
  std::string error;
  try {
    auto sand = std::make_unique<Sand>(m, instance);
    if (sand->implicit && m->opt.integrator == mjINT_RK4)
      mju_warning("%s: with the RK4 integrator the sand's load is explicit: the implicit correction needs Euler, "
                  "implicit or implicitfast (docs/mujoco_plugin.md)", kName);
    d->plugin_data[instance] = reinterpret_cast<uintptr_t>(sand.release());
    return 0;
  } catch (const std::exception& e) {
    error = e.what();
  }
  mju_error("%s: %s", kName, error.c_str());  // MuJoCo's compiler, or the caller's handler, reports it
  return -1;
}

void destroy(mjData* d, int instance) {
  delete sand_of(d, instance);
  d->plugin_data[instance] = 0;
}

void copy(mjData* dest, const mjModel*, const mjData* src, int instance) {
  delete sand_of(dest, instance);
  dest->plugin_data[instance] = reinterpret_cast<uintptr_t>(new Sand(*sand_of(src, instance)));
}

void reset(const mjModel* m, mjtNum* state, void*, int instance) {
  std::fill(state, state + m->plugin_statenum[instance], 0.0);
}

void compute(const mjModel* m, mjData* d, int instance, int capability) {
  if (!(capability & mjPLUGIN_PASSIVE)) return;
  sand_of(d, instance)->compute(m, d, d->plugin_state + m->plugin_stateadr[instance]);
}

void advance(const mjModel* m, mjData* d, int instance) {
  sand_of(d, instance)->advance(m, d, d->plugin_state + m->plugin_stateadr[instance]);
}

}  // namespace

}  // namespace terrasph::rft

mjPLUGIN_LIB_INIT(terrasph_rft) {
  namespace tr = terrasph::rft;
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = tr::kName;
  plugin.nattribute = static_cast<int>(tr::kAttributes.size());
  plugin.attributes = tr::kAttributes.data();
  plugin.capabilityflags = mjPLUGIN_PASSIVE;
  plugin.nstate = tr::nstate;
  plugin.init = tr::init;
  plugin.destroy = tr::destroy;
  plugin.copy = tr::copy;
  plugin.reset = tr::reset;
  plugin.compute = tr::compute;
  plugin.advance = tr::advance;
  mjp_registerPlugin(&plugin);
}
