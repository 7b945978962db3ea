// netkf._core.Scenario: a loaded, validated scenario (netkf/model/scenario.hpp), read-only.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "netkf/links/link.hpp"
#include "netkf/links/link_text.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::python {

namespace py = pybind11;

void bind_scenario(py::module_& m) {
  py::class_<Scenario>(m, "Scenario", "A validated scenario (load it with netkf.load_scenario)")
      .def_readonly("name", &Scenario::name)
      .def_readonly("source", &Scenario::source, "the file (or '<text>', '<dict>') it was loaded from")
      .def_readonly("period_ms", &Scenario::period_ms)
      .def_readonly("seed", &Scenario::seed)
      .def_property_readonly("state_dim", &Scenario::state_dim)
      .def_property_readonly("deadline_ms", &Scenario::deadline_ms)
      .def_property_readonly("A", [](const Scenario& s) { return s.plant.A; })
      .def_property_readonly("Q", [](const Scenario& s) { return s.plant.Q; })
      .def_property_readonly("B", [](const Scenario& s) { return s.plant.B; })
      .def_property_readonly("x0", [](const Scenario& s) { return s.plant.x0; })
      .def_property_readonly("P0", [](const Scenario& s) { return s.plant.P0; })
      .def_property_readonly("sensor_ids",
                             [](const Scenario& s) {
                               std::vector<int> ids;
                               for (const auto& sensor : s.sensors) ids.push_back(sensor.id);
                               return ids;
                             })
      .def_property_readonly(
          "sensors",
          [](const Scenario& s) {
            py::list out;
            for (const auto& sensor : s.sensors) {
              py::dict d;
              d["id"] = sensor.id;
              d["C"] = sensor.C;
              d["R"] = sensor.R;
              d["link"] = describe_link(sensor.link);
              out.append(d);
            }
            return out;
          },
          "per sensor: id, C, R and its link in words")
      .def("to_yaml", &scenario_to_yaml, "the scenario as a YAML file netkf reads back")
      .def("__repr__", [](const Scenario& s) {
        return "<netkf.Scenario '" + s.name + "': n = " + std::to_string(s.state_dim()) + ", " +
               std::to_string(s.sensors.size()) + " sensors, period " + std::to_string(s.period_ms) + " ms>";
      });

  m.def("load_scenario_file", [](const std::string& path) { return load_scenario_file(path); }, py::arg("path"),
        "Load and validate a scenario file (ValueError: FILE:LINE:COL: what is wrong)");
  m.def("parse_scenario", &parse_scenario, py::arg("yaml_text"), py::arg("source_name"),
        "Parse and validate a scenario from YAML text; source_name is the FILE of error messages");
}

}  // namespace netkf::python
