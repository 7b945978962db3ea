// netkf._core: the core library (scenario, theory, Monte Carlo, loss fit, the filter) for Python.
// The friendly layer (what a scenario argument may be, defaults, docs) is python/netkf/theory.py;
// docs/python.md says how to use it.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "netkf/links/link_trace.hpp"
#include "netkf/model/scenario.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "netkf's core library: scenarios, the papers' theory, Monte Carlo, loss-model fits and the "
            "intermittent Kalman filter (use it through the netkf package, docs/python.md)";
  // A malformed scenario or trace is the caller's input: ValueError with the core's message
  // (FILE:LINE:COL: what is wrong, or the key).
  pybind11::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const netkf::ScenarioError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const netkf::TraceError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  netkf::python::bind_scenario(m);
  netkf::python::bind_theory(m);
  netkf::python::bind_filter(m);
}
