// Conversions for the bindings (py_convert.hpp).
#include "py_convert.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>

#include <cmath>

namespace netkf::python {
namespace {

bool all_numbers(const nlohmann::json& array) {
  for (const auto& v : array)
    if (!v.is_number()) return false;
  return !array.empty();
}

bool all_integers(const nlohmann::json& array) {
  for (const auto& v : array)
    if (!v.is_number_integer()) return false;
  return true;
}

// An array of equal-length arrays of numbers: its column count, else 0.
std::size_t matrix_columns(const nlohmann::json& array) {
  if (array.empty() || !array.front().is_array()) return 0;
  const std::size_t columns = array.front().size();
  for (const auto& row : array)
    if (!row.is_array() || row.size() != columns || !all_numbers(row)) return 0;
  return columns;
}

py::array_t<double> float_array(const nlohmann::json& array) {
  py::array_t<double> out(static_cast<py::ssize_t>(array.size()));
  auto view = out.mutable_unchecked<1>();
  for (std::size_t i = 0; i < array.size(); ++i) view(static_cast<py::ssize_t>(i)) = array[i].get<double>();
  return out;
}

py::array numeric_array(const nlohmann::json& array) {
  if (all_integers(array)) {
    py::array_t<std::int64_t> out(static_cast<py::ssize_t>(array.size()));
    auto view = out.mutable_unchecked<1>();
    for (std::size_t i = 0; i < array.size(); ++i)
      view(static_cast<py::ssize_t>(i)) = array[i].is_number_unsigned()
                                              ? static_cast<std::int64_t>(array[i].get<std::uint64_t>())
                                              : array[i].get<std::int64_t>();
    return out;
  }
  return float_array(array);
}

py::array_t<double> matrix_array(const nlohmann::json& array, std::size_t columns) {
  py::array_t<double> out({static_cast<py::ssize_t>(array.size()), static_cast<py::ssize_t>(columns)});
  auto view = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < array.size(); ++i)
    for (std::size_t j = 0; j < columns; ++j)
      view(static_cast<py::ssize_t>(i), static_cast<py::ssize_t>(j)) = array[i][j].get<double>();
  return out;
}

// A float64 array of `value` (no copy when it is one already); py::value_error when it is not
// numeric.
py::array_t<double> as_float_array(const py::handle& value, const std::string& what) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!a) throw py::value_error(what + ": not an array of numbers");
  return a;
}

}  // namespace

py::object to_python(const nlohmann::json& value) {
  switch (value.type()) {
    case nlohmann::json::value_t::null: return py::none();
    case nlohmann::json::value_t::boolean: return py::bool_(value.get<bool>());
    case nlohmann::json::value_t::number_integer: return py::int_(value.get<std::int64_t>());
    case nlohmann::json::value_t::number_unsigned: return py::int_(value.get<std::uint64_t>());
    case nlohmann::json::value_t::number_float: return py::float_(value.get<double>());
    case nlohmann::json::value_t::string: return py::str(value.get<std::string>());
    case nlohmann::json::value_t::object: {
      py::dict out;
      for (const auto& [key, item] : value.items()) out[py::str(key)] = to_python(item);
      return out;
    }
    case nlohmann::json::value_t::array: {
      if (all_numbers(value)) return numeric_array(value);
      if (const std::size_t columns = matrix_columns(value)) return matrix_array(value, columns);
      py::list out;
      for (const auto& item : value) out.append(to_python(item));
      return out;
    }
    default: return py::none();  // binary / discarded: never produced by netkf's JSON
  }
}

Vector vector_argument(const py::handle& value, const std::string& what, bool allow_nan) {
  if (value.is_none()) throw py::value_error(what + ": None is not a number");
  const auto a = as_float_array(value, what);
  if (a.ndim() > 1) throw py::value_error(what + ": expected a number or a 1-D array, got " +
                                          std::to_string(a.ndim()) + " dimensions");
  Vector v(a.size());
  const double* data = a.data();
  for (py::ssize_t i = 0; i < a.size(); ++i) {
    if (!allow_nan && !std::isfinite(data[i])) throw py::value_error(what + ": not finite (NaN or inf)");
    v(i) = data[i];
  }
  return v;
}

Matrix matrix_argument(const py::handle& value, const std::string& what) {
  const auto a = as_float_array(value, what);
  if (a.ndim() != 2) throw py::value_error(what + ": expected a 2-D array, got " + std::to_string(a.ndim()) +
                                           " dimensions");
  Matrix m(a.shape(0), a.shape(1));
  auto view = a.unchecked<2>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i)
    for (py::ssize_t j = 0; j < a.shape(1); ++j) {
      if (!std::isfinite(view(i, j))) throw py::value_error(what + ": not finite (NaN or inf)");
      m(i, j) = view(i, j);
    }
  return m;
}

std::vector<double> rates_argument(const py::handle& value, const std::string& what) {
  const Vector v = vector_argument(value, what, true);
  std::vector<double> out(v.data(), v.data() + v.size());
  for (double r : out)
    if (!(r >= 0.0 && r <= 1.0)) throw py::value_error(what + ": an arrival rate must be in [0, 1]");
  return out;
}

}  // namespace netkf::python
