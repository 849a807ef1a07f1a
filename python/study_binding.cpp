// spacearm.Study: a study file's runs from Python (sweep/sweep.hpp), so that any engine that
// maps a function over chunks of run indices (Dask, python/spacearm/dask_sweep.py) computes
// the rows that `spacearm sweep` writes, byte for byte, and merges them into results.csv.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <thread>

#include "sweep.hpp"

namespace py = pybind11;

namespace spacearm {
namespace {

std::unique_ptr<StudyRunner> open_study(const std::string& path, const std::string& cache_dir) {
  CompileOptions options;
  options.cache_dir = cache_dir;
  options.engine = Engine::automatic;  // runs start at once; the compiled code takes over
  Study study = load_study(path);
  py::gil_scoped_release release;  // a compile can take seconds
  return std::make_unique<StudyRunner>(std::move(study), options);
}

// The rows of the runs, on `threads` threads without the GIL, in the order of `runs`.
std::vector<std::string> rows(const StudyRunner& runner, const py::iterable& run_indices,
                              int threads) {
  const long n = runner.study().num_runs();
  std::vector<long> runs;
  for (const py::handle& i : run_indices) {
    if (!PyIndex_Check(i.ptr()) || PyBool_Check(i.ptr()))  // ints and numpy's integers
      throw py::type_error("runs: run indices are integers, not " +
                           std::string(py::str(py::type::of(i).attr("__name__"))));
    const long r = PyLong_AsLong(py::reinterpret_steal<py::object>(PyNumber_Index(i.ptr())).ptr());
    if (PyErr_Occurred()) throw py::error_already_set();
    runs.push_back(r);
  }
  for (long r : runs)
    if (r < 0 || r >= n)
      throw py::index_error("run " + std::to_string(r) + ": the study has runs 0 .. " +
                            std::to_string(n - 1));
  if (threads < 1 || threads > 1024) throw py::value_error("threads: 1 to 1024");
  std::vector<std::string> out(runs.size());
  py::gil_scoped_release release;
  std::atomic<size_t> next{0};
  const size_t group = std::max(1, runner.lanes());  // runs integrated at once
  auto work = [&] {
    for (size_t k; (k = next.fetch_add(group)) < runs.size();) {
      const std::vector<long> some(runs.begin() + k,
                                   runs.begin() + std::min(runs.size(), k + group));
      const std::vector<std::string> rows = runner.rows(some);
      std::copy(rows.begin(), rows.end(), out.begin() + k);
    }
  };
  std::vector<std::thread> pool;
  try {
    for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  } catch (const std::system_error&) {  // fewer threads then: the rows are the same
  }
  work();
  for (auto& t : pool) t.join();
  return out;
}

}  // namespace

void bind_study(py::module& module) {
  py::register_exception<StudyError>(module, "StudyError", PyExc_ValueError);
  py::class_<StudyRunner>(module, "Study",
                          "A study file (spacearm sweep): its runs, one CSV row each.")
      .def(py::init(&open_study), py::arg("path"), py::arg("cache_dir") = "",
           "Read a study file and compile (or take from the cache) its scenes.")
      .def_property_readonly("num_runs", [](const StudyRunner& r) { return r.study().num_runs(); })
      .def_property_readonly("header", &StudyRunner::header)
      .def_property_readonly("identity", [](const StudyRunner& r) { return r.study().identity; })
      .def_property_readonly("time_series",
                             [](const StudyRunner& r) { return r.study().series_every > 0; })
      .def_property_readonly("parameter_names",
                             [](const StudyRunner& r) { return r.study().parameter_names(); })
      .def(
          "parameters", [](const StudyRunner& r, long run) { return r.study().parameters(run); },
          py::arg("run"), "The run's parameter values, in parameter_names' order.")
      .def("rows", &rows, py::arg("runs"), py::arg("threads") = 1,
           "The CSV rows of the runs (each with its newline), computed without the GIL.")
      .def("merge", &merge_rows, py::arg("rows"),
           "results.csv's text from the rows of every run, in any order.")
      .def("claim_folder", &claim_results_folder, py::arg("out_dir"),
           "Checks out_dir as spacearm sweep does (yours, nothing planted, not another study's) "
           "and claims it for this study (study.id).")
      .def("write_results", &write_results, py::arg("out_dir"), py::arg("rows"),
           "Writes out_dir/results.csv from the rows of every run, into a folder checked and "
           "claimed as spacearm sweep's (study.id); returns its path.")
      .def("__repr__", [](const StudyRunner& r) {
        return "<spacearm.Study '" + r.study().source_path +
               "': " + std::to_string(r.study().num_runs()) + " runs of scene " +
               r.study().scene.name + ">";
      });
}

}  // namespace spacearm
