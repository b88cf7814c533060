// Rigid bodies with prescribed planar motion (docs/design.md §3.6, Eq. 3.24–3.25).
// A body is a set of wall particles rigidly attached to a reference point (hip axle, wheel
// centre). Motion is in the x–z plane (components 0 and D−1) with rotation about the
// out-of-plane axis; angles and angular velocities are clockwise-positive (docs/design.md §2).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "terrasph/errors.hpp"
#include "terrasph/math.hpp"

namespace terrasph {

// J r: the in-plane vector r turned a quarter clockwise, (x, z) ↦ (z, −x). A point at r from the
// reference moves with v = ω J r under clockwise spin ω, and a force f at r has the clockwise
// moment (J r)·f about the reference.
template <int D> Vec<D> quarter_turn_clockwise(const Vec<D>& r) {
  Vec<D> out = Vec<D>::Zero();
  out[0] = r[D - 1];
  out[D - 1] = -r[0];
  return out;
}

// r rotated clockwise by θ in the x–z plane, given c = cos θ and s = sin θ: (x c + z s, −x s + z c).
template <int D> Vec<D> rotate_clockwise(const Vec<D>& r, double c, double s) {
  Vec<D> out = r;
  out[0] = c * r[0] + s * r[D - 1];
  out[D - 1] = -s * r[0] + c * r[D - 1];
  return out;
}

// r rotated clockwise by `angle` in the x–z plane.
template <int D> Vec<D> rotate_clockwise(const Vec<D>& r, double angle) {
  return rotate_clockwise<D>(r, std::cos(angle), std::sin(angle));
}

// One piece of a prescribed motion: constant linear velocity of the reference point and constant
// clockwise spin about it for `duration` seconds (may be +inf for the last piece).
template <int D> struct MotionSegment {
  double duration = 0.0;
  Vec<D> velocity = Vec<D>::Zero();
  double spin = 0.0;  // rad/s, clockwise-positive
};

// Pose and rates of a body at one instant.
template <int D> struct BodyKinematics {
  Vec<D> reference = Vec<D>::Zero();     // position of the reference point
  double angle = 0.0;                    // clockwise rotation from the body frame (rad)
  Vec<D> velocity = Vec<D>::Zero();      // of the reference point
  double spin = 0.0;                     // clockwise angular velocity (rad/s)
  Vec<D> acceleration = Vec<D>::Zero();  // of the reference point (0 for a prescribed schedule)
  double angular_acceleration = 0.0;     // clockwise (rad/s², 0 for a prescribed schedule)

  // f(name, member) for each value a saved state carries (as LoadAccumulator::for_each_saved).
  template <class Self, class F> static void for_each_saved(Self& k, F&& f) {
    f("reference", k.reference);
    f("angle", k.angle);
    f("velocity", k.velocity);
    f("spin", k.spin);
    f("acceleration", k.acceleration);
    f("angular_acceleration", k.angular_acceleration);
  }
};

// A piecewise-constant-velocity schedule starting at t = 0; after its last piece the body holds
// still. The pose is integrated in closed form, so particles follow it exactly at any step size.
template <int D> class PrescribedMotion {
 public:
  PrescribedMotion() = default;
  PrescribedMotion(BodyKinematics<D> start, std::vector<MotionSegment<D>> segments)
      : start_(start), segments_(std::move(segments)) {
    for (size_t k = 0; k < segments_.size(); ++k) {
      const MotionSegment<D>& s = segments_[k];
      const std::string name = "motion segment " + std::to_string(k);
      const bool last = k + 1 == segments_.size();
      if (!(s.duration > 0.0) || (std::isinf(s.duration) && !last) || std::isnan(s.duration))
        throw parameter_error(name + " duration", s.duration, last ? "> 0 (may be inf)" : "finite and > 0");
      if (!s.velocity.allFinite() || !std::isfinite(s.spin))
        throw parameter_error(name + " velocity/spin", s.spin, "finite numbers");
    }
    start_.velocity = Vec<D>::Zero();
    start_.spin = 0.0;
  }

  // Pose and velocity at time t; at a piece boundary the later piece's velocity applies.
  BodyKinematics<D> at(double t) const {
    BodyKinematics<D> k = start_;
    double begin = 0.0;
    for (const MotionSegment<D>& s : segments_) {
      const double elapsed = std::min(std::max(t - begin, 0.0), s.duration);
      k.reference += elapsed * s.velocity;
      k.angle += elapsed * s.spin;
      if (t >= begin && t < begin + s.duration) {
        k.velocity = s.velocity;
        k.spin = s.spin;
      }
      begin += s.duration;
    }
    return k;
  }

  const BodyKinematics<D>& start() const { return start_; }
  const std::vector<MotionSegment<D>>& segments() const { return segments_; }

 private:
  BodyKinematics<D> start_;
  std::vector<MotionSegment<D>> segments_;
};

// The load of the grains on a rigid body or on a fixed wall group (Eq. 3.24–3.25): force and
// clockwise torque at the last rate evaluation, summed from the granular–wall pair forces, and
// their time integrals since the last reset (for time-averaged loads). Per metre of depth in 2D.
template <int D> struct LoadAccumulator {
  Vec<D> force = Vec<D>::Zero();     // Eq. 3.24 at the last rate evaluation
  double torque = 0.0;               // Eq. 3.25 at the last rate evaluation
  Vec<D> impulse = Vec<D>::Zero();   // Σ F dt since the last reset
  double angular_impulse = 0.0;      // Σ T dt since the last reset
  double impulse_time = 0.0;         // Σ dt since the last reset

  void clear_load() {
    force.setZero();
    torque = 0.0;
  }
  // Adds one pair force f acting at `arm` from the torque point (clockwise torque).
  void add(const Vec<D>& f, const Vec<D>& arm) {
    force += f;
    torque += quarter_turn_clockwise<D>(arm).dot(f);
  }
  void integrate(double dt) {
    impulse += dt * force;
    angular_impulse += dt * torque;
    impulse_time += dt;
  }
  void reset_impulses() {
    impulse.setZero();
    angular_impulse = 0.0;
    impulse_time = 0.0;
  }

  // f(name, member) for each value a saved state carries, each named once here (Self is a
  // LoadAccumulator or a const one: the saving and the restoring code walk the same list).
  template <class Self, class F> static void for_each_saved(Self& load, F&& f) {
    f("force", load.force);
    f("torque", load.torque);
    f("impulse", load.impulse);
    f("angular_impulse", load.angular_impulse);
    f("impulse_time", load.impulse_time);
  }
};

// A rigid body: its schedule, its current kinematics, and the granular load on it.
// Force and torque are per metre of depth in 2D (N/m, N·m/m); the Python layer multiplies by the
// body's real width. The torque is about the reference point, clockwise-positive.
template <int D> struct RigidBody : LoadAccumulator<D> {
  // false: follows `motion`; true: driven from outside (a multibody engine sets its kinematics
  // before every step, docs/design.md §3.6)
  bool driven = false;
  PrescribedMotion<D> motion;
  double motion_start = 0.0;         // simulation time at which the schedule's t = 0 falls
  BodyKinematics<D> kinematics;
};

// Points binned in cells of side L (sorted, occupied cells only): a query visits the 3^D cells
// about its own, so it sees every point within L of it.
template <int D> class PointCells {
 public:
  using Cell = std::array<std::int64_t, D>;

  PointCells(const std::vector<Vec<D>>& points, double cell_side) : side_(cell_side) {
    std::vector<std::pair<Cell, Vec<D>>> binned;
    binned.reserve(points.size());
    for (const Vec<D>& p : points) binned.emplace_back(cell_of(p), p);
    std::stable_sort(binned.begin(), binned.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [cell, p] : binned) {
      if (cells_.empty() || cells_.back() != cell) {
        cells_.push_back(cell);
        starts_.push_back(points_.size());
      }
      points_.push_back(p);
    }
    starts_.push_back(points_.size());
  }

  // Whether a point lies within `radius` (≤ L) of x; stops at the first.
  bool any_within(const Vec<D>& x, double radius) const {
    const double r2 = radius * radius;
    return visit_near(x, [&](const Vec<D>& p) { return (p - x).squaredNorm() <= r2; });
  }

  // The distance from x to the nearest point, or L if none is nearer.
  double nearest_within_side(const Vec<D>& x) const {
    double best2 = side_ * side_;
    visit_near(x, [&](const Vec<D>& p) {
      best2 = std::min(best2, (p - x).squaredNorm());
      return false;
    });
    return std::sqrt(best2);
  }

 private:
  // Calls stop(p) for the points of the 3^D cells about x's own until it returns true; returns
  // whether it did.
  template <class Stop> bool visit_near(const Vec<D>& x, Stop&& stop) const {
    const Cell centre = cell_of(x);
    Cell offset{};
    offset.fill(-1);
    while (true) {
      Cell cell = centre;
      for (int d = 0; d < D; ++d) cell[d] += offset[d];
      const auto found = std::lower_bound(cells_.begin(), cells_.end(), cell);
      if (found != cells_.end() && *found == cell) {
        const std::size_t k = static_cast<std::size_t>(found - cells_.begin());
        for (std::size_t p = starts_[k]; p < starts_[k + 1]; ++p)
          if (stop(points_[p])) return true;
      }
      int d = 0;
      while (d < D && offset[d] == 1) offset[d++] = -1;
      if (d == D) return false;
      ++offset[d];
    }
  }

  Cell cell_of(const Vec<D>& x) const {
    Cell cell;
    for (int d = 0; d < D; ++d) cell[d] = static_cast<std::int64_t>(std::floor(x[d] / side_));
    return cell;
  }

  double side_;
  std::vector<Cell> cells_;          // occupied cells, sorted
  std::vector<std::size_t> starts_;  // points_[starts_[k], starts_[k + 1]) lie in cells_[k]
  std::vector<Vec<D>> points_;
};

// Whether a point of a rigid body's frame lies within R of one of the body's particles. The
// distance d to the nearest particle is sampled once on a grid of spacing g = R/16 (coarser if the
// grid would pass kMaxNodes); d is 1-Lipschitz, so the sample at the node nearest to y bounds d(y)
// within δ = |y − node|, and the answer is read off the sample unless |d_node − R| ≤ δ (plus a
// round-off margin), a band about a node wide along the contour d = R, where the particles are
// visited (binned in cells of side R). Samples farther than R + 2g from every particle hold R + 2g,
// a lower bound that still decides "beyond R". Exact: the same answer as a visit of every particle.
template <int D> class BodyDistanceField {
 public:
  static constexpr Index kMaxNodes = Index{1} << 18;

  BodyDistanceField(const std::vector<Vec<D>>& offsets, double radius)
      : radius_(radius), particles_(offsets, radius) {
    if (offsets.empty()) return;  // no nodes: every point is beyond
    Vec<D> lower = Vec<D>::Constant(std::numeric_limits<double>::max());
    Vec<D> upper = Vec<D>::Constant(std::numeric_limits<double>::lowest());
    for (const Vec<D>& p : offsets) {
      lower = lower.cwiseMin(p);
      upper = upper.cwiseMax(p);
    }
    double cap = 0.0;
    spacing_ = radius / 16.0;
    while (true) {  // the particles' box padded by R + 2g, nodes g apart
      cap = radius + 2.0 * spacing_;
      origin_ = lower.array() - cap;
      Index nodes = 1;
      for (int d = 0; d < D; ++d) {
        dims_[d] = static_cast<Index>(std::ceil((upper[d] - lower[d] + 2.0 * cap) / spacing_)) + 1;
        nodes *= dims_[d];
      }
      if (nodes <= kMaxNodes) break;
      spacing_ *= 1.25;
    }
    margin_ = 1e-9 * cap;  // far above the round-off of the node positions and of |y − node|
    const PointCells<D> cells(offsets, cap);
    distance_.resize(static_cast<std::size_t>(node_count()));
    for (Index n = 0; n < node_count(); ++n) distance_[static_cast<std::size_t>(n)] = cells.nearest_within_side(node(n));
  }

  bool within(const Vec<D>& local) const {
    Index n = 0, stride = 1;
    Vec<D> nearest_node;
    for (int d = 0; d < D; ++d) {
      const double k = std::round((local[d] - origin_[d]) / spacing_);
      if (!(k >= 0.0 && k < static_cast<double>(dims_[d]))) return false;  // > R + 1.5g from the box
      nearest_node[d] = origin_[d] + spacing_ * k;
      n += static_cast<Index>(k) * stride;
      stride *= dims_[d];
    }
    const double offset = (local - nearest_node).norm();
    const double sampled = distance_[static_cast<std::size_t>(n)];
    if (sampled - offset > radius_ + margin_) return false;
    if (sampled + offset < radius_ - margin_) return true;
    return particles_.any_within(local, radius_);
  }

 private:
  Index node_count() const {
    Index n = 1;
    for (int d = 0; d < D; ++d) n *= dims_[d];
    return n;
  }
  Vec<D> node(Index n) const {
    Vec<D> x;
    for (int d = 0; d < D; ++d) {
      x[d] = origin_[d] + spacing_ * static_cast<double>(n % dims_[d]);
      n /= dims_[d];
    }
    return x;
  }

  double radius_, spacing_ = 0.0, margin_ = 0.0;
  PointCells<D> particles_;
  Vec<D> origin_ = Vec<D>::Zero();
  std::array<Index, D> dims_{};
  std::vector<double> distance_;  // per node, capped at R + 2g
};

// "Is any body particle within R of x?" for the active domain (numerics.active_radius), asked of
// each body's BodyDistanceField in the body's frame at its present pose (built once a step from the
// moved bodies). Exact up to the round-off of turning x into the body frame: no bounding shape.
template <int D> class BodyProximity {
 public:
  struct Frame {  // a body's pose and its distance field (in the body frame)
    const BodyDistanceField<D>* field;
    Vec<D> reference;
    double cos_angle, sin_angle;  // of the body's clockwise angle θ
  };

  explicit BodyProximity(std::vector<Frame> frames) : frames_(std::move(frames)) {}

  bool near(const Vec<D>& x) const {
    for (const Frame& f : frames_)  // the body frame's point: x − c turned back by θ
      if (f.field->within(rotate_clockwise<D>(Vec<D>(x - f.reference), f.cos_angle, -f.sin_angle))) return true;
    return false;
  }

 private:
  std::vector<Frame> frames_;
};

}  // namespace terrasph
