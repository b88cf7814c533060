// Rigid bodies with prescribed planar motion (DESIGN §3.6, Eq. 3.24–3.25).
// A body is a set of wall particles rigidly attached to a reference point (hip axle, wheel
// centre). Motion is in the x–z plane (components 0 and D−1) with rotation about the
// out-of-plane axis; angles and angular velocities are clockwise-positive (DESIGN §2).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
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

// r rotated clockwise by `angle` in the x–z plane: (x cos θ + z sin θ, −x sin θ + z cos θ).
template <int D> Vec<D> rotate_clockwise(const Vec<D>& r, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Vec<D> out = r;
  out[0] = c * r[0] + s * r[D - 1];
  out[D - 1] = -s * r[0] + c * r[D - 1];
  return out;
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

// A rigid body: its schedule, its current kinematics, and the granular load on it.
// Force and torque are per metre of depth in 2D (N/m, N·m/m); the Python layer multiplies by the
// body's real width. The torque is about the reference point, clockwise-positive.
template <int D> struct RigidBody {
  // false: follows `motion`; true: driven from outside (a multibody engine sets its kinematics
  // before every step, DESIGN §3.6)
  bool driven = false;
  PrescribedMotion<D> motion;
  double motion_start = 0.0;         // simulation time at which the schedule's t = 0 falls
  BodyKinematics<D> kinematics;
  Vec<D> force = Vec<D>::Zero();     // Eq. 3.24 at the last rate evaluation
  double torque = 0.0;               // Eq. 3.25 at the last rate evaluation
  Vec<D> impulse = Vec<D>::Zero();   // Σ F dt since the last reset (for time-averaged loads)
  double angular_impulse = 0.0;      // Σ T dt since the last reset
  double impulse_time = 0.0;         // Σ dt since the last reset
};

// "Is any body particle within R of x?" for the active domain (numerics.active_radius): the body
// particles binned in cells of side R, so that a query visits the 3^D cells about x and stops at
// the first particle within R. Built once a step from the moved bodies; exact (no bounding shape).
template <int D> class BodyProximity {
 public:
  using Cell = std::array<std::int64_t, D>;

  BodyProximity(std::vector<Vec<D>> points, double radius) : radius_(radius) {
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

  bool near(const Vec<D>& x) const {
    const Cell centre = cell_of(x);
    const double r2 = radius_ * radius_;
    Cell offset{};
    offset.fill(-1);
    while (true) {  // the 3^D cells about x's own
      Cell cell = centre;
      for (int d = 0; d < D; ++d) cell[d] += offset[d];
      const auto found = std::lower_bound(cells_.begin(), cells_.end(), cell);
      if (found != cells_.end() && *found == cell) {
        const std::size_t k = static_cast<std::size_t>(found - cells_.begin());
        for (std::size_t p = starts_[k]; p < starts_[k + 1]; ++p)
          if ((points_[p] - x).squaredNorm() <= r2) return true;
      }
      int d = 0;
      while (d < D && offset[d] == 1) offset[d++] = -1;
      if (d == D) return false;
      ++offset[d];
    }
  }

 private:
  Cell cell_of(const Vec<D>& x) const {
    Cell cell;
    for (int d = 0; d < D; ++d) cell[d] = static_cast<std::int64_t>(std::floor(x[d] / radius_));
    return cell;
  }

  double radius_;
  std::vector<Cell> cells_;  // occupied cells, sorted
  std::vector<std::size_t> starts_;  // points_[starts_[k], starts_[k + 1]) lie in cells_[k]
  std::vector<Vec<D>> points_;
};

}  // namespace terrasph
