// Registered per-particle fields (the SPHinXsys registerStateVariableData / PySPH
// _ensure_properties idea): a module that needs an array registers it by name; resizing, gathering
// (permute, remove), copying in and out and serialising are done here, once, for every field.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <typeinfo>
#include <vector>

#include "terrasph/math.hpp"

namespace terrasph {

// One named per-particle array: `columns()` values per particle, rows in storage order.
class FieldBase {
 public:
  FieldBase(std::string name, std::string unit, std::string doc)
      : name_(std::move(name)), unit_(std::move(unit)), doc_(std::move(doc)) {}
  virtual ~FieldBase() = default;
  FieldBase(const FieldBase&) = delete;
  FieldBase& operator=(const FieldBase&) = delete;

  const std::string& name() const { return name_; }
  const std::string& unit() const { return unit_; }
  const std::string& doc() const { return doc_; }

  virtual Index rows() const = 0;
  virtual int columns() const = 0;
  virtual const std::type_info& scalar_type() const = 0;
  virtual std::size_t scalar_size() const = 0;
  std::size_t bytes() const { return static_cast<std::size_t>(rows()) * columns() * scalar_size(); }
  virtual const void* data() const = 0;
  virtual void* data() = 0;
  // New rows are zero; existing rows keep their values.
  virtual void resize(Index n) = 0;
  // Row k becomes the old row source[k] (permutes when source is a permutation, removes rows it omits).
  virtual void gather(const std::vector<Index>& source) = 0;

 private:
  std::string name_, unit_, doc_;
};

// Eigen storage of a field: (N, Cols) row-major, or a plain vector for one column.
template <class Scalar, int Cols>
using FieldArray = Eigen::Matrix<Scalar, Eigen::Dynamic, Cols, Cols == 1 ? Eigen::ColMajor : Eigen::RowMajor>;

template <class Scalar, int Cols> class Field final : public FieldBase {
 public:
  using Array = FieldArray<Scalar, Cols>;
  Field(std::string name, std::string unit, std::string doc, Index rows)
      : FieldBase(std::move(name), std::move(unit), std::move(doc)) {
    values.setZero(rows, Cols);
  }

  Index rows() const override { return values.rows(); }
  int columns() const override { return Cols; }
  const std::type_info& scalar_type() const override { return typeid(Scalar); }
  std::size_t scalar_size() const override { return sizeof(Scalar); }
  const void* data() const override { return values.data(); }
  void* data() override { return values.data(); }

  void resize(Index n) override {
    const Index old = values.rows();
    values.conservativeResize(n, Cols);
    if (n > old) values.bottomRows(n - old).setZero();
  }

  void gather(const std::vector<Index>& source) override {
    Array out(static_cast<Index>(source.size()), Cols);
    for (std::size_t k = 0; k < source.size(); ++k) out.row(static_cast<Index>(k)) = values.row(source[k]);
    values = std::move(out);
  }

  Array values;
};

// The fields of one particle set, in registration order. A field object never moves once
// registered, so a reference to its array stays valid for the registry's lifetime (also across
// resize and gather, which change the array's contents, not the array object).
class FieldRegistry {
 public:
  FieldRegistry() = default;
  FieldRegistry(FieldRegistry&&) = default;
  FieldRegistry& operator=(FieldRegistry&&) = delete;  // references into it must not be rebound

  // Registers a field (zero-filled to the current size) or returns the existing one of that name;
  // a name registered with another type or width is an error.
  template <class Scalar, int Cols>
  FieldArray<Scalar, Cols>& add(const std::string& name, const std::string& unit, const std::string& doc) {
    if (FieldBase* existing = find(name)) return typed<Scalar, Cols>(*existing).values;
    fields_.push_back(std::make_unique<Field<Scalar, Cols>>(name, unit, doc, size_));
    return static_cast<Field<Scalar, Cols>&>(*fields_.back()).values;
  }

  template <class Scalar, int Cols> FieldArray<Scalar, Cols>& get(const std::string& name) {
    return typed<Scalar, Cols>(at(name)).values;
  }

  bool contains(const std::string& name) const { return find(name) != nullptr; }
  FieldBase& at(const std::string& name) const {
    FieldBase* f = find(name);
    if (!f) throw std::out_of_range("no particle field named '" + name + "'");
    return *f;
  }

  Index size() const { return size_; }
  void resize(Index n) {
    for (auto& f : fields_) f->resize(n);
    size_ = n;
  }
  void gather(const std::vector<Index>& source) {
    for (auto& f : fields_) f->gather(source);
    size_ = static_cast<Index>(source.size());
  }

  const std::vector<std::unique_ptr<FieldBase>>& all() const { return fields_; }
  std::size_t bytes() const {
    std::size_t total = 0;
    for (const auto& f : fields_) total += f->bytes();
    return total;
  }

 private:
  FieldBase* find(const std::string& name) const {
    for (const auto& f : fields_)
      if (f->name() == name) return f.get();
    return nullptr;
  }
  template <class Scalar, int Cols> static Field<Scalar, Cols>& typed(FieldBase& f) {
    auto* t = dynamic_cast<Field<Scalar, Cols>*>(&f);
    if (!t) throw std::logic_error("particle field '" + f.name() + "' is registered with another type or width");
    return *t;
  }

  std::vector<std::unique_ptr<FieldBase>> fields_;
  Index size_ = 0;
};

}  // namespace terrasph
