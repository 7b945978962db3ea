#pragma once
// Conversions between Python objects and netkf's core types for the bindings (the only place
// they live): the CLI's JSON as Python objects, and checked numpy arguments.
#include <nlohmann/json.hpp>
#include <pybind11/pybind11.h>
#include <string>
#include <vector>

#include "netkf/support/types.hpp"

namespace netkf::python {

namespace py = pybind11;

/// A JSON value as Python: objects → dict, strings/bools/null → str/bool/None, integers → int,
/// and arrays of numbers → numpy arrays (1-D; an array of equal-length arrays of numbers → 2-D
/// float64), so that what the CLI prints as `[0.1, 0.2]` comes to a notebook as an array.
/// Other arrays (of objects, strings, mixed, empty) → list.
py::object to_python(const nlohmann::json& value);

/// `what` as a float64 vector: a number or a 1-D array of finite numbers unless `allow_nan`
/// (NaN and ±inf are then passed on as they are). Throws py::value_error naming `what`.
Vector vector_argument(const py::handle& value, const std::string& what, bool allow_nan = false);

/// `what` as a float64 matrix (2-D, finite). Throws py::value_error naming `what`.
Matrix matrix_argument(const py::handle& value, const std::string& what);

/// Arrival rates: a number or a 1-D array, each in [0, 1]. Throws py::value_error.
std::vector<double> rates_argument(const py::handle& value, const std::string& what);

}  // namespace netkf::python
