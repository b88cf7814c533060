// Exceptions the core raises; the bindings map them to Python exception types.
#pragma once

#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

namespace terrasph {

// A number for a message: 6 significant digits, so 1.5e-06 does not print as 0.000001.
inline std::string format_number(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

// A run that went unstable: where and when, and which particle (by its stable id), so the user can
// find it in the output.
class InstabilityError : public std::runtime_error {
 public:
  InstabilityError(const std::string& reason, std::int64_t step, double time, std::int64_t particle)
      : std::runtime_error(format(reason, step, time, particle)),
        reason_(reason), step_(step), time_(time), particle_(particle) {}

  const std::string& reason() const { return reason_; }
  std::int64_t step() const { return step_; }
  double time() const { return time_; }
  std::int64_t particle() const { return particle_; }

 private:
  static std::string format(const std::string& reason, std::int64_t step, double time,
                            std::int64_t particle) {
    std::string msg = reason + " at step " + std::to_string(step) + ", t = " + format_number(time) + " s";
    if (particle >= 0) msg += ", granular particle id " + std::to_string(particle);
    return msg;
  }
  std::string reason_;
  std::int64_t step_;
  double time_;
  std::int64_t particle_;
};

// A parameter outside its allowed range: the message names it and the range.
inline std::invalid_argument parameter_error(const std::string& name, double value,
                                             const std::string& allowed) {
  return std::invalid_argument("parameter '" + name + "' = " + format_number(value) +
                               " is invalid: allowed " + allowed);
}

}  // namespace terrasph
