#pragma once
// The parts of the module netkf._core (module.cpp): each adds its names to the module.
#include <pybind11/pybind11.h>

namespace netkf::python {

void bind_scenario(pybind11::module_& m);  // Scenario, load_scenario_file, parse_scenario
void bind_theory(pybind11::module_& m);    // analyze, critical_rate, bounds, markov_criterion, simulate, fit
void bind_filter(pybind11::module_& m);    // Filter

}  // namespace netkf::python
