// Rigid bodies with prescribed or driven motion (docs/design.md §3.6, Eq. 3.24–3.25).
// A body is a set of wall particles rigidly attached to a reference point (hip axle, wheel
// centre). In 2D (plane strain, components x and z) a body turns about the out-of-plane axis y;
// its angle and angular velocity are clockwise-positive in the x–z plane (docs/design.md §2), which
// is the right-handed sense about +y. In 3D a body turns freely: its orientation is a unit
// quaternion, its angular velocity and the torque on it are vectors (right-handed), so a 3D body
// spinning about +y with ω_y moves as the 2D body with spin ω (docs/sph3d.md).
#pragma once

#include <Eigen/Geometry>
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
inline Vec<2> quarter_turn_clockwise(const Vec<2>& r) { return Vec<2>(r[1], -r[0]); }

// r rotated clockwise by θ in the x–z plane, given c = cos θ and s = sin θ: (x c + z s, −x s + z c).
inline Vec<2> rotate_clockwise(const Vec<2>& r, double c, double s) {
  return Vec<2>(c * r[0] + s * r[1], -s * r[0] + c * r[1]);
}

// r rotated clockwise by `angle` in the x–z plane.
inline Vec<2> rotate_clockwise(const Vec<2>& r, double angle) { return rotate_clockwise(r, std::cos(angle), std::sin(angle)); }

// The rotational part of a rigid body's motion in D dimensions: how an orientation and an angular
// rate are stored, named in a saved state, applied to a body-frame vector and integrated. A point
// at `arm` from the reference point of a body moving with (v, ω, a, α) has
//   v_p = v + ω × arm,   a_p = a + α × arm + ω × (ω × arm)                    (rigid-body kinematics)
// and a force f there has the moment arm × f about the reference (Eq. 3.25).
template <int D> struct BodyRotation;

// Plane strain: one angle θ about +y (clockwise in the x–z plane), ω × arm = ω J arm.
template <> struct BodyRotation<2> {
  using Orientation = double;  // θ (rad)
  using Angular = double;      // angular velocity, acceleration, torque, about +y
  struct Inverse {             // cos θ and sin θ, to turn world vectors into the body frame
    double c, s;
  };
  static constexpr const char* orientation_name = "angle";
  static constexpr const char* angular_velocity_name = "spin";
  static constexpr int angular_components = 1;

  static Orientation identity() { return 0.0; }
  static Angular zero() { return 0.0; }
  static bool finite(double value) { return std::isfinite(value); }
  static Orientation normalised(Orientation angle) { return angle; }
  static Vec<2> rotate(Orientation angle, const Vec<2>& r) { return rotate_clockwise(r, angle); }
  static Vec<2> unrotate(Orientation angle, const Vec<2>& r) { return rotate_clockwise(r, -angle); }
  static Inverse inverse(Orientation angle) { return {std::cos(angle), std::sin(angle)}; }
  static Vec<2> apply(const Inverse& t, const Vec<2>& r) { return rotate_clockwise(r, t.c, -t.s); }
  static Vec<2> point_velocity(const Vec<2>& v, Angular omega, const Vec<2>& arm) {
    return v + omega * quarter_turn_clockwise(arm);
  }
  static Vec<2> point_acceleration(const Vec<2>& a, Angular alpha, Angular omega, const Vec<2>& arm) {
    const Vec<2> turned = quarter_turn_clockwise(arm);
    return a + alpha * turned - (omega * omega) * arm;  // ω × (ω × arm) = −ω² arm in the plane
  }
  static Angular moment(const Vec<2>& arm, const Vec<2>& f) { return quarter_turn_clockwise(arm).dot(f); }
  // θ after turning at ω for `elapsed` seconds
  static Orientation advanced(Orientation angle, Angular omega, double elapsed) { return angle + elapsed * omega; }
};

// 3D: a unit quaternion (w, x, y, z) taking body-frame vectors to world vectors; vector rates.
template <> struct BodyRotation<3> {
  using Orientation = Eigen::Matrix<double, 4, 1>;  // (w, x, y, z), unit
  using Angular = Vec<3>;
  using Inverse = Mat<3>;  // Rᵀ
  static constexpr const char* orientation_name = "orientation";
  static constexpr const char* angular_velocity_name = "angular_velocity";
  static constexpr int angular_components = 3;

  static Orientation identity() { return Orientation(1.0, 0.0, 0.0, 0.0); }
  static Angular zero() { return Angular::Zero(); }
  template <class V> static bool finite(const V& value) { return value.allFinite(); }
  static Eigen::Quaterniond quaternion(const Orientation& q) { return Eigen::Quaterniond(q[0], q[1], q[2], q[3]); }
  static Orientation stored(const Eigen::Quaterniond& q) { return Orientation(q.w(), q.x(), q.y(), q.z()); }
  // q / |q|, refused when |q| is far from 1 (a mistyped quaternion rather than round-off)
  static Orientation normalised(const Orientation& q) {
    const double norm = q.norm();
    if (!(std::abs(norm - 1.0) < 1e-6)) throw parameter_error("body orientation quaternion norm", norm, "1 (a unit quaternion w, x, y, z)");
    return q / norm;
  }
  static Vec<3> rotate(const Orientation& q, const Vec<3>& r) { return quaternion(q) * r; }
  static Vec<3> unrotate(const Orientation& q, const Vec<3>& r) { return quaternion(q).conjugate() * r; }
  static Inverse inverse(const Orientation& q) { return quaternion(q).toRotationMatrix().transpose(); }
  static Vec<3> apply(const Inverse& t, const Vec<3>& r) { return t * r; }
  static Vec<3> point_velocity(const Vec<3>& v, const Angular& omega, const Vec<3>& arm) { return v + omega.cross(arm); }
  static Vec<3> point_acceleration(const Vec<3>& a, const Angular& alpha, const Angular& omega, const Vec<3>& arm) {
    return a + alpha.cross(arm) + omega.cross(Vec<3>(omega.cross(arm)));
  }
  static Angular moment(const Vec<3>& arm, const Vec<3>& f) { return arm.cross(f); }
  // q turned about the fixed world axis ω/|ω| by |ω| elapsed (constant ω: exact, any step size)
  static Orientation advanced(const Orientation& q, const Angular& omega, double elapsed) {
    const double turn = omega.norm() * elapsed;
    if (turn == 0.0) return q;
    const Eigen::Quaterniond step(Eigen::AngleAxisd(turn, omega / omega.norm()));
    return stored((step * quaternion(q)).normalized());
  }
};

// One piece of a prescribed motion: constant linear velocity of the reference point and constant
// angular velocity about it for `duration` seconds (may be +inf for the last piece).
template <int D> struct MotionSegment {
  double duration = 0.0;
  Vec<D> velocity = Vec<D>::Zero();
  typename BodyRotation<D>::Angular angular_velocity = BodyRotation<D>::zero();  // rad/s (2D: clockwise)
};

// Pose and rates of a body at one instant.
template <int D> struct BodyKinematics {
  using Rotation = BodyRotation<D>;
  Vec<D> reference = Vec<D>::Zero();     // position of the reference point
  typename Rotation::Orientation orientation = Rotation::identity();  // from the body frame
  Vec<D> velocity = Vec<D>::Zero();      // of the reference point
  typename Rotation::Angular angular_velocity = Rotation::zero();    // rad/s
  Vec<D> acceleration = Vec<D>::Zero();  // of the reference point (0 for a prescribed schedule)
  typename Rotation::Angular angular_acceleration = Rotation::zero();  // rad/s² (0 for a prescribed schedule)

  bool finite() const {
    return reference.allFinite() && Rotation::finite(orientation) && velocity.allFinite() &&
           Rotation::finite(angular_velocity) && acceleration.allFinite() && Rotation::finite(angular_acceleration);
  }

  // f(name, member) for each value a saved state carries (as LoadAccumulator::for_each_saved).
  // The 2D names ("angle", "spin") are those of every saved 2D state.
  template <class Self, class F> static void for_each_saved(Self& k, F&& f) {
    f("reference", k.reference);
    f(Rotation::orientation_name, k.orientation);
    f("velocity", k.velocity);
    f(Rotation::angular_velocity_name, k.angular_velocity);
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
      if (!s.velocity.allFinite() || !BodyRotation<D>::finite(s.angular_velocity))
        throw parameter_error(name + " velocity/angular velocity", s.duration, "finite numbers");
    }
    start_.orientation = BodyRotation<D>::normalised(start_.orientation);
    start_.velocity = Vec<D>::Zero();
    start_.angular_velocity = BodyRotation<D>::zero();
  }

  // Pose and velocity at time t; at a piece boundary the later piece's velocity applies.
  BodyKinematics<D> at(double t) const {
    BodyKinematics<D> k = start_;
    double begin = 0.0;
    for (const MotionSegment<D>& s : segments_) {
      const double elapsed = std::min(std::max(t - begin, 0.0), s.duration);
      k.reference += elapsed * s.velocity;
      k.orientation = BodyRotation<D>::advanced(k.orientation, s.angular_velocity, elapsed);
      if (t >= begin && t < begin + s.duration) {
        k.velocity = s.velocity;
        k.angular_velocity = s.angular_velocity;
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
// torque (2D: clockwise; 3D: a vector) at the last rate evaluation, summed from the granular–wall
// pair forces, and their time integrals since the last reset (for time-averaged loads). Per metre
// of depth in 2D.
template <int D> struct LoadAccumulator {
  using Angular = typename BodyRotation<D>::Angular;
  Vec<D> force = Vec<D>::Zero();                      // Eq. 3.24 at the last rate evaluation
  Angular torque = BodyRotation<D>::zero();           // Eq. 3.25 at the last rate evaluation
  Vec<D> impulse = Vec<D>::Zero();                    // Σ F dt since the last reset
  Angular angular_impulse = BodyRotation<D>::zero();  // Σ T dt since the last reset
  double impulse_time = 0.0;                          // Σ dt since the last reset

  void clear_load() {
    force.setZero();
    torque = BodyRotation<D>::zero();
  }
  // Adds one pair force f acting at `arm` from the torque point.
  void add(const Vec<D>& f, const Vec<D>& arm) {
    force += f;
    torque += BodyRotation<D>::moment(arm, f);
  }
  void integrate(double dt) {
    impulse += dt * force;
    angular_impulse += dt * torque;
    impulse_time += dt;
  }
  void reset_impulses() {
    impulse.setZero();
    angular_impulse = BodyRotation<D>::zero();
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
// Force and torque are per metre of depth in 2D (N/m, N·m/m; the Python layer multiplies by the
// body's real width), whole in 3D (N, N·m). The torque is about the reference point.
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
    typename BodyRotation<D>::Inverse inverse;  // of the body's orientation
  };

  explicit BodyProximity(std::vector<Frame> frames) : frames_(std::move(frames)) {}

  bool near(const Vec<D>& x) const {
    for (const Frame& f : frames_)  // the body frame's point: x − c turned back
      if (f.field->within(BodyRotation<D>::apply(f.inverse, Vec<D>(x - f.reference)))) return true;
    return false;
  }

 private:
  std::vector<Frame> frames_;
};

}  // namespace terrasph
