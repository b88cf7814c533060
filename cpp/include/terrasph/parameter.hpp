// The machinery that turns one parameter list (params.hpp) into struct fields, range checks and a
// descriptor table. A parameter group is a struct with a `group` name and a static
// `for_each_field(visit)` that calls visit(ParameterField<Group, T>) once per parameter, in list order.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "terrasph/errors.hpp"

namespace terrasph {

inline constexpr double inf = std::numeric_limits<double>::infinity();

// One end of an allowed interval.
struct Bound {
  double value;
  bool inclusive;
};
constexpr Bound inclusive(double value) { return {value, true}; }
constexpr Bound exclusive(double value) { return {value, false}; }

// Names of the values of a choice (an enum class whose values are 0, 1, …). Each choice type
// specialises it with `static constexpr std::array<const char*, N> names`.
template <class Enum> struct ChoiceNames;

template <class Enum> std::string choice_name(Enum value) {
  return ChoiceNames<Enum>::names[static_cast<std::size_t>(value)];
}

inline std::string quoted(const std::string& text) { return "'" + text + "'"; }

template <class Enum> std::string choice_list() {
  std::string list;
  for (const char* name : ChoiceNames<Enum>::names) list += (list.empty() ? "" : ", ") + quoted(name);
  return list;
}

// The value named `name`; an unknown name is refused with the parameter's name and the choices.
template <class Enum> Enum parse_choice(const std::string& parameter, const std::string& name) {
  const auto& names = ChoiceNames<Enum>::names;
  for (std::size_t k = 0; k < names.size(); ++k)
    if (name == names[k]) return static_cast<Enum>(k);
  throw std::invalid_argument("parameter '" + parameter + "' = " + quoted(name) +
                              " is invalid: allowed one of " + choice_list<Enum>());
}

// One parameter: its member, default, unit, allowed interval (numbers only) and a one-line doc.
template <class Group, class T> struct ParameterField {
  const char* name;
  T Group::*member;
  T default_value;
  const char* unit;  // SI; "1" for a pure number
  Bound lower;
  Bound upper;
  const char* doc;

  static constexpr bool is_number = std::is_arithmetic_v<T> && !std::is_same_v<T, bool>;

  std::string qualified_name() const { return std::string(Group::group) + "." + name; }

  // "lower <(=) name <(=) upper" plus the unit, e.g. "0 <= water_content < 1".
  std::string allowed() const {
    if constexpr (std::is_enum_v<T>) {
      return "one of " + choice_list<T>();
    } else if constexpr (std::is_same_v<T, bool>) {
      return "true or false";
    } else {
      std::string text = format_number(lower.value) + (lower.inclusive ? " <= " : " < ") + name +
                         (upper.inclusive ? " <= " : " < ") + format_number(upper.value);
      if (std::string(unit) != "1") text += std::string(" (") + unit + ")";
      return text;
    }
  }

  // A bool or a choice cannot hold a value outside its set; a number must lie in [lower, upper].
  bool admits(T value) const {
    if constexpr (is_number) {
      const double x = static_cast<double>(value);
      const bool above = lower.inclusive ? x >= lower.value : x > lower.value;
      const bool below = upper.inclusive ? x <= upper.value : x < upper.value;
      return above && below;  // NaN fails both
    } else {
      return true;
    }
  }

  void check(const Group& group) const {
    if constexpr (is_number) {
      const T value = group.*member;
      if (!admits(value)) throw parameter_error(qualified_name(), static_cast<double>(value), allowed());
    }
  }
};

// Every parameter of a group checked against its interval; the first violation throws.
template <class Group> void check_ranges(const Group& group) {
  Group::for_each_field([&](const auto& field) { field.check(group); });
}

// A parameter's description as data: what the bindings export and everything else derives from.
using ParameterValue = std::variant<bool, int, double, std::string>;
struct ParameterInfo {
  std::string group;
  std::string name;
  std::string kind;  // "double", "int", "bool" or "choice"
  ParameterValue default_value;
  std::string unit;
  double lower;
  bool lower_inclusive;
  double upper;
  bool upper_inclusive;
  std::vector<std::string> choices;  // a choice's allowed names; empty otherwise
  std::string allowed;               // the range as the error messages state it
  std::string doc;
};

template <class Group, class T> ParameterInfo describe(const ParameterField<Group, T>& field) {
  ParameterInfo info{Group::group, field.name, "", {}, field.unit, field.lower.value,
                     field.lower.inclusive, field.upper.value, field.upper.inclusive, {},
                     field.allowed(), field.doc};
  if constexpr (std::is_enum_v<T>) {
    info.kind = "choice";
    info.default_value = choice_name(field.default_value);
    for (const char* name : ChoiceNames<T>::names) info.choices.emplace_back(name);
  } else if constexpr (std::is_same_v<T, bool>) {
    info.kind = "bool";
    info.default_value = field.default_value;
  } else if constexpr (std::is_same_v<T, int>) {
    info.kind = "int";
    info.default_value = field.default_value;
  } else {
    static_assert(std::is_same_v<T, double>, "a parameter is a double, an int, a bool or a choice");
    info.kind = "double";
    info.default_value = field.default_value;
  }
  return info;
}

template <class Group> std::vector<ParameterInfo> parameter_table() {
  std::vector<ParameterInfo> table;
  Group::for_each_field([&](const auto& field) { table.push_back(describe(field)); });
  return table;
}

}  // namespace terrasph

// Inside a group struct: declares its fields with their defaults and its for_each_field from a
// list macro LIST(X) whose entries are X(type, name, default, unit, lower, upper, doc).
#define TERRASPH_PARAMETER_MEMBER(type, name, value, unit, lower, upper, doc) type name = value;
#define TERRASPH_PARAMETER_VISIT(type, name, value, unit, lower, upper, doc) \
  visit(::terrasph::ParameterField<Self, type>{#name, &Self::name, value, unit, lower, upper, doc});
#define TERRASPH_PARAMETER_GROUP(Struct, group_name, LIST)          \
  using Self = Struct;                                               \
  static constexpr const char* group = group_name;                   \
  LIST(TERRASPH_PARAMETER_MEMBER)                                    \
  template <class Visit> static void for_each_field(Visit&& visit) { \
    LIST(TERRASPH_PARAMETER_VISIT)                                   \
  }
