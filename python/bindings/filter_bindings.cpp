// netkf._core.Filter: the intermittent multi-sensor Kalman filter (netkf/filter/kalman_filter.hpp) on a
// scenario's model, the same filter the estimator runs, for a user's own data.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <map>
#include <optional>

#include "bindings.hpp"
#include "netkf/filter/kalman_filter.hpp"
#include "netkf/model/scenario.hpp"
#include "py_convert.hpp"

namespace netkf::python {
namespace {

class Filter {
 public:
  Filter(const Scenario& s, const py::object& x0, const py::object& P0)
      : filter_(filter_model(s), given_or_prior_mean(s, x0), given_or_prior_covariance(s, P0), filter_options(s)) {
    for (const auto& sensor : s.sensors) sensor_sizes_[sensor.id] = static_cast<int>(sensor.C.rows());
  }

  // samples: {sensor id: y}; absent sensors were lost. A NaN or inf in y is not fused (the
  // sample counts as lost, as statsmodels treats NaN), and is named under "rejected".
  py::dict update(const py::dict& samples) {
    std::vector<SensorSample> received;
    for (const auto& [key, value] : samples) {
      if (!py::isinstance<py::int_>(key)) throw py::type_error("update: the keys are sensor ids (int)");
      const int id = key.cast<int>();
      const auto size = sensor_sizes_.find(id);
      if (size == sensor_sizes_.end()) throw py::value_error("update: the scenario has no sensor " + std::to_string(id));
      Vector y = vector_argument(value, "update: sensor " + std::to_string(id) + "'s sample", true);
      if (y.size() != size->second)
        throw py::value_error("update: sensor " + std::to_string(id) + " measures " + std::to_string(size->second) +
                              (size->second == 1 ? " value" : " values") + ", got " + std::to_string(y.size()));
      received.push_back({id, std::move(y)});
    }
    const FusedUpdateResult r = filter_.update(received);
    py::dict out;
    out["fused"] = r.fused_ids;
    py::dict rejected;
    for (const auto& [id, reason] : r.rejected) rejected[py::int_(id)] = to_string(reason);
    out["rejected"] = rejected;
    return out;
  }

  void predict(const py::object& u, const py::object& input_covariance) {
    const auto& B = filter_.model().B;
    if (u.is_none()) {
      if (!input_covariance.is_none()) throw py::value_error("predict: input_covariance needs u");
      filter_.predict();
      return;
    }
    if (!B) throw py::value_error("predict: the scenario's plant has no input (plant.B)");
    const Vector input = vector_argument(u, "predict: u");
    if (input.size() != B->cols())
      throw py::value_error("predict: u has " + std::to_string(input.size()) + " entries, plant.B has " +
                            std::to_string(B->cols()) + " columns");
    if (input_covariance.is_none()) {
      filter_.predict(&input);
      return;
    }
    const Matrix cov = matrix_argument(input_covariance, "predict: input_covariance");
    if (cov.rows() != input.size() || cov.cols() != input.size())
      throw py::value_error("predict: input_covariance must be " + std::to_string(input.size()) + " x " +
                            std::to_string(input.size()));
    filter_.predict(input, cov);
  }

  void restore(const py::object& x, const py::object& P) {
    const Vector xv = vector_argument(x, "restore: x");
    const Matrix Pm = matrix_argument(P, "restore: P");
    filter_.restore(xv, Pm);  // std::invalid_argument (ValueError) on a wrong size
  }

  const IntermittentKalmanFilter& core() const { return filter_; }

  py::dict rejections() const {
    py::dict out;
    // The reasons the filter itself judges (the estimator's period logic adds the others).
    for (const SampleRejection r : {SampleRejection::unknown_sensor, SampleRejection::wrong_size,
                                    SampleRejection::non_finite, SampleRejection::duplicate})
      out[to_string(r)] = filter_.rejections()[r];
    return out;
  }

  std::vector<int> sensor_ids() const {
    std::vector<int> ids;
    for (const auto& [id, size] : sensor_sizes_) ids.push_back(id);
    return ids;
  }

 private:
  // The estimator's prior (netkf::prior_mean, prior_covariance) unless given.
  static Vector given_or_prior_mean(const Scenario& s, const py::object& x0) {
    if (x0.is_none()) return prior_mean(s);
    Vector x = vector_argument(x0, "x0");
    if (x.size() != s.plant.A.rows())
      throw py::value_error("x0: " + std::to_string(x.size()) + " entries, the state has " +
                            std::to_string(s.plant.A.rows()));
    return x;
  }
  static Matrix given_or_prior_covariance(const Scenario& s, const py::object& P0) {
    if (P0.is_none()) return prior_covariance(s);
    const auto n = s.plant.A.rows();
    Matrix P = matrix_argument(P0, "P0");
    if (P.rows() != n || P.cols() != n) throw py::value_error("P0 must be " + std::to_string(n) + " x " + std::to_string(n));
    return P;
  }

  IntermittentKalmanFilter filter_;
  std::map<int, int> sensor_sizes_;  // sensor id -> rows of its C
};

}  // namespace

void bind_filter(py::module_& m) {
  py::class_<Filter>(m, "Filter",
                     "The intermittent multi-sensor Kalman filter on a scenario's model: update() with the "
                     "samples that arrived, then predict(); x and P are x-hat and P after the last step")
      .def(py::init<const Scenario&, const py::object&, const py::object&>(), py::arg("scenario"),
           py::arg("x0") = py::none(), py::arg("P0") = py::none())
      .def("update", &Filter::update, py::arg("samples"),
           "fused update with {sensor id: y} (absent: lost); returns {'fused': ids, 'rejected': {id: reason}}")
      .def("predict", &Filter::predict, py::arg("u") = py::none(), py::arg("input_covariance") = py::none(),
           "time update to the next period (u: the input applied, with plant.B)")
      .def("restore", &Filter::restore, py::arg("x"), py::arg("P"), "continue from a filtered x-hat, P")
      .def_property_readonly("x", [](const Filter& f) { return Vector(f.core().x()); })
      .def_property_readonly("P", [](const Filter& f) { return Matrix(f.core().P()); })
      .def_property_readonly("trace_P", [](const Filter& f) { return f.core().trace_P(); })
      .def_property_readonly("state", [](const Filter& f) { return std::string(to_string(f.core().state())); })
      .def_property_readonly("rejections", &Filter::rejections, "samples not fused so far, by reason")
      .def_property_readonly("sensor_ids", &Filter::sensor_ids)
      .def_property_readonly("state_dim", [](const Filter& f) { return f.core().state_dim(); });
}

}  // namespace netkf::python
