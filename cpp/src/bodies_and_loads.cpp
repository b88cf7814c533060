// Simulation<D>: rigid bodies (prescribed and driven), their motion, the loads of the grains on
// bodies and on fixed walls (Eq. 3.24–3.25), and the bodies' distance fields for the active domain.
#include "terrasph/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "terrasph/parallel.hpp"

namespace terrasph {

template <int D>
int Simulation<D>::add_body(std::int32_t wall_group, const Vec<D>& reference, const Orientation& orientation,
                            std::vector<MotionSegment<D>> motion) {
  BodyKinematics<D> start;
  start.reference = reference;
  start.orientation = orientation;
  RigidBody<D> body;
  body.motion = PrescribedMotion<D>(start, std::move(motion));
  body.motion_start = counters_.time;
  return attach_body(wall_group, std::move(body));
}

template <int D>
int Simulation<D>::add_driven_body(std::int32_t wall_group, const Vec<D>& reference, const Orientation& orientation) {
  RigidBody<D> body;
  body.driven = true;
  body.kinematics.reference = reference;
  body.kinematics.orientation = BodyRotation<D>::normalised(orientation);
  return attach_body(wall_group, std::move(body));
}

template <int D> void Simulation<D>::set_body_kinematics(int index, const BodyKinematics<D>& kinematics) {
  if (index < 0 || index >= static_cast<int>(bodies_.size()))
    throw std::out_of_range("no body " + std::to_string(index));
  if (!bodies_[static_cast<size_t>(index)].driven)
    throw std::invalid_argument("body " + std::to_string(index) + " follows a prescribed motion; only a driven "
                                "body takes its kinematics from outside");
  if (!kinematics.finite())
    throw std::invalid_argument("body " + std::to_string(index) + " kinematics must be finite numbers");
  BodyKinematics<D>& now = bodies_[static_cast<size_t>(index)].kinematics;
  now = kinematics;
  now.orientation = BodyRotation<D>::normalised(kinematics.orientation);
}

// Makes the particles of `wall_group` the rigid body `body`, its frame given by the body's
// kinematics at the current time (reference point and orientation of the present layout).
template <int D> int Simulation<D>::attach_body(std::int32_t wall_group, RigidBody<D> body) {
  const BodyKinematics<D> now = body.driven ? body.kinematics : body.motion.at(0.0);
  if (!now.reference.allFinite() || !BodyRotation<D>::finite(now.orientation))
    throw std::invalid_argument("body reference point and orientation must be finite");
  const int index = static_cast<int>(bodies_.size());
  body_offset_ = &walls_.fields.template add<double, D>("body_offset", "m", "position in the body frame");
  body_normal_ = &walls_.fields.template add<double, D>("body_normal", "", "normal in the body frame");
  Index members = 0;
  for (Index w = 0; w < walls_.size(); ++w) {
    if (walls_.group[w] != wall_group) continue;
    if (walls_.body[w] >= 0)
      throw std::invalid_argument("wall group " + std::to_string(wall_group) + " is already a body");
    walls_.body[w] = index;
    row_vec<D>(*body_offset_, w) = BodyRotation<D>::unrotate(now.orientation, row_vec<D>(walls_.position, w) - now.reference);
    row_vec<D>(*body_normal_, w) = BodyRotation<D>::unrotate(now.orientation, row_vec<D>(walls_.normal, w));
    ++members;
  }
  if (members == 0)
    throw std::invalid_argument("wall group " + std::to_string(wall_group) + " has no particles to make a body of");
  bodies_.push_back(std::move(body));
  compose_passes();
  move_bodies(counters_.time);
  refresh();
  reset_body_impulses();
  return index;
}

template <int D> void Simulation<D>::reset_body_impulses() {
  for (RigidBody<D>& body : bodies_) body.reset_impulses();
}

// Places every body particle at its body's pose at `time` (the schedule's for a prescribed body,
// the last one set for a driven body), with the rigid-body velocity and acceleration
//   x = c + R r,  v = v_c + ω × R r,  a = a_c + α × R r + ω × (ω × R r)
// (in 2D ω × R r = ω J R r, J the quarter turn clockwise, and ω × (ω × R r) = −ω² R r), the
// acceleration entering the wall pressure as (g − a_w) (Eq. 3.31). A prescribed schedule has
// piecewise-constant velocities, so a_c = α = 0 there, leaving the steady-spin term.
template <int D> void Simulation<D>::move_bodies(double time) {
  for (RigidBody<D>& body : bodies_)
    if (!body.driven) body.kinematics = body.motion.at(time - body.motion_start);
  for_each_particle(walls_.size(), [&](Index w) {
    const std::int32_t b = walls_.body[w];
    if (b < 0) return;
    const BodyKinematics<D>& k = bodies_[static_cast<size_t>(b)].kinematics;
    const Vec<D> arm = BodyRotation<D>::rotate(k.orientation, row_vec<D>(*body_offset_, w));
    row_vec<D>(walls_.position, w) = k.reference + arm;
    row_vec<D>(walls_.velocity, w) = BodyRotation<D>::point_velocity(k.velocity, k.angular_velocity, arm);
    row_vec<D>(walls_.acceleration, w) =
        BodyRotation<D>::point_acceleration(k.acceleration, k.angular_acceleration, k.angular_velocity, arm);
    row_vec<D>(walls_.normal, w) = BodyRotation<D>::rotate(k.orientation, row_vec<D>(*body_normal_, w));
  });
}

// Force and torque (2D: clockwise) of the grains on each body (about its reference point) and, when
// tracked, on each fixed wall group (about the tracking point) (Eq. 3.24–3.25), summed from the
// stored pair forces in a fixed order (granular particle, then its neighbour list), so the totals
// do not depend on the thread count and are the exact opposite of the pair forces on the grains:
// with the weight they balance the grains' momentum, Σ m_i a_i = M g − Σ F_bodies − Σ F_walls.
template <int D> void Simulation<D>::accumulate_loads(double dt) {
  for (RigidBody<D>& body : bodies_) body.clear_load();
  for (WallLoad<D>& load : wall_loads_) load.clear_load();
  auto by_group = [](const WallLoad<D>& load, std::int32_t group) { return load.group < group; };
  const Index n = granular_.size();
  for (Index i = 0; i < n; ++i) {
    for (Index s = granular_wall_.offsets[i]; s < granular_wall_.offsets[i + 1]; ++s) {
      const std::int32_t w = granular_wall_.indices[s];
      const std::int32_t b = walls_.body[w];
      if (b < 0 && !tracks_wall_loads_) continue;  // a fixed wall's pair force is kept only when tracked
      const Vec<D> f = row_vec<D>(pair_wall_force_, s);
      const Vec<D> x = row_vec<D>(walls_.position, w);
      if (b >= 0) {
        RigidBody<D>& body = bodies_[static_cast<size_t>(b)];
        body.add(f, x - body.kinematics.reference);
      } else {  // every fixed wall's group is listed (track_wall_loads), so the search finds it
        const auto load = std::lower_bound(wall_loads_.begin(), wall_loads_.end(), walls_.group[w], by_group);
        load->add(f, x - wall_load_point_);
      }
    }
  }
  for (RigidBody<D>& body : bodies_) body.integrate(dt);
  for (WallLoad<D>& load : wall_loads_) load.integrate(dt);
}

// Each body's pose after this step's move with its distance field, for the active domain's "far
// from every body" test. The fields are built from the particles' body-frame offsets (in storage
// order, serially) at the first call after the bodies or the walls last changed.
template <int D> BodyProximity<D> Simulation<D>::body_proximity(double radius) {
  if (body_fields_.empty()) {
    std::vector<std::vector<Vec<D>>> offsets(bodies_.size());
    for (Index w = 0; w < walls_.size(); ++w)
      if (walls_.body[w] >= 0) offsets[static_cast<std::size_t>(walls_.body[w])].emplace_back(row_vec<D>(*body_offset_, w));
    for (const std::vector<Vec<D>>& body : offsets) body_fields_.emplace_back(body, radius);
  }
  std::vector<typename BodyProximity<D>::Frame> frames;
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const BodyKinematics<D>& k = bodies_[b].kinematics;
    frames.push_back({&body_fields_[b], k.reference, BodyRotation<D>::inverse(k.orientation)});
  }
  return BodyProximity<D>(std::move(frames));
}

template <int D> void Simulation<D>::track_wall_loads(const Vec<D>& point) {
  if (!point.allFinite()) throw std::invalid_argument("the wall loads' torque point must be finite");
  if (params_.numerics.freeze_speed > 0.0)
    throw std::invalid_argument("wall loads cannot be tracked with the active domain on (numerics.freeze_speed > 0): "
                                "its frozen grains keep old rates");
  std::vector<std::int32_t> groups;
  for (Index w = 0; w < walls_.size(); ++w)
    if (walls_.body[w] < 0) groups.push_back(walls_.group[w]);
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  wall_loads_.assign(groups.size(), WallLoad<D>{});
  for (size_t k = 0; k < groups.size(); ++k) wall_loads_[k].group = groups[k];
  wall_load_point_ = point;
  tracks_wall_loads_ = true;
  compose_passes();
  refresh();
  reset_wall_load_impulses();
}

template <int D> void Simulation<D>::reset_wall_load_impulses() {
  for (WallLoad<D>& load : wall_loads_) load.reset_impulses();
}

template <int D> void Simulation<D>::restore_wall_loads(const Vec<D>& point, const std::vector<WallLoad<D>>& loads) {
  if (!tracks_wall_loads_)
    throw std::invalid_argument("the saved state tracks wall loads: call track_wall_loads before restoring it");
  if (point != wall_load_point_)
    throw std::invalid_argument("the saved wall loads are about another point than this simulation's track_wall_loads");
  bool same_groups = loads.size() == wall_loads_.size();
  for (size_t k = 0; same_groups && k < loads.size(); ++k) same_groups = loads[k].group == wall_loads_[k].group;
  if (!same_groups) throw std::invalid_argument("the saved wall loads belong to other wall groups");
  wall_loads_ = loads;
}

#define TERRASPH_INSTANTIATE(D) \
  template int Simulation<D>::add_body(std::int32_t, const Vec<D>&, const Orientation&, std::vector<MotionSegment<D>>); \
  template int Simulation<D>::add_driven_body(std::int32_t, const Vec<D>&, const Orientation&); \
  template void Simulation<D>::set_body_kinematics(int, const BodyKinematics<D>&); \
  template int Simulation<D>::attach_body(std::int32_t, RigidBody<D>); \
  template void Simulation<D>::reset_body_impulses(); \
  template void Simulation<D>::move_bodies(double); \
  template void Simulation<D>::accumulate_loads(double); \
  template BodyProximity<D> Simulation<D>::body_proximity(double); \
  template void Simulation<D>::track_wall_loads(const Vec<D>&); \
  template void Simulation<D>::reset_wall_load_impulses(); \
  template void Simulation<D>::restore_wall_loads(const Vec<D>&, const std::vector<WallLoad<D>>&);
TERRASPH_INSTANTIATE(2)
TERRASPH_INSTANTIATE(3)
#undef TERRASPH_INSTANTIATE

}  // namespace terrasph
