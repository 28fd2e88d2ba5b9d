// The Python module `relief` (compiled part, `relief._relief`): a thin front end over the library,
// in the spirit of the CLI's main.cpp. It fills relief::GenerateSettings / RunOptions and calls the
// library; it re-implements no writing policy (format selection, writer dependencies, memory checks,
// the atomic commit are relief::generate's).
//
// Threads and the GIL: every long call (a generation, writing files, encoding) runs on a worker
// thread with the GIL released, while the calling thread waits on a condition variable. Every 50 ms
// (and whenever the library reports progress) the calling thread takes the GIL back, hands the
// progress events to the Python callback (so callbacks always run on the calling thread, with the
// GIL) and calls PyErr_CheckSignals(). A callback that raises, or a KeyboardInterrupt (Ctrl-C),
// sets the library's cancel hook; the library stops at its next check (before each stage and each
// writer), unwinds (no file changed), and the Python exception is raised.
//
// Memory: a Terrain's layers are numpy arrays viewing the library's buffers. Each array holds a
// capsule that owns a std::shared_ptr to the relief::Terrain, so an array outlives the Terrain
// object it came from (`del t`), and no layer is ever copied.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "relief/error.hpp"
#include "relief/explain.hpp"
#include "relief/generate.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "py_common.hpp"

namespace py = pybind11;
using relief::json;

namespace relief_py {

PyObject* g_error_type = nullptr;      // relief.Error (a ValueError)
PyObject* g_cancelled_type = nullptr;  // relief.Cancelled

json to_json(const py::handle& obj, const std::string& path) {
  py::object dumps = py::module_::import("json").attr("dumps");
  std::string text;
  try {
    text = py::cast<std::string>(dumps(obj, py::arg("allow_nan") = true));
  } catch (py::error_already_set& e) {
    throw relief::Error(path, std::string("expected JSON-compatible data: ") + e.what());
  }
  return relief::parse_json(text, path.empty() ? "value" : path, path);
}

py::object from_json(const json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

// ---- the one place presets are looked up: the built-in ones, then the user folders of the
// environment, as the CLI and the studio do (RELIEF_PRESETS, XDG_CONFIG_HOME, HOME) ------------
std::vector<std::string> user_dirs() {
  return relief::user_preset_dirs(std::getenv("RELIEF_PRESETS"), std::getenv("XDG_CONFIG_HOME"), std::getenv("HOME"));
}
json preset_doc(const std::string& name) { return relief::load_preset(name, user_dirs()); }
std::vector<relief::PresetInfo> preset_list() { return relief::list_presets(user_dirs()); }

// ---- interruptible calls -------------------------------------------------------------------
struct Hooks {
  std::mutex m;
  std::condition_variable cv;
  std::vector<std::pair<std::string, double>> events;
  std::uint64_t posted = 0, delivered = 0;  // progress events, in order
  bool done = false;
  // With a Python callback, the library's thread waits until its event has been handed to the
  // callback, so that a callback that raises stops the run at the library's next check (it cannot
  // run ahead and commit files meanwhile).
  bool wait_for_callback = false;
  std::atomic<bool> cancel{false};

  void progress(std::string_view what, double f) {
    std::unique_lock<std::mutex> lock(m);
    events.emplace_back(std::string(what), f);
    const std::uint64_t mine = ++posted;
    cv.notify_all();
    if (wait_for_callback) cv.wait(lock, [&] { return delivered >= mine || cancel.load(); });
  }
  bool cancelled() const { return cancel.load(); }
};

// Runs work(hooks) on a worker thread (GIL released) while this thread delivers progress and
// watches for signals; see the top of the file.
template <class R>
R run_interruptible(const py::object& progress, const std::function<R(Hooks&)>& work) {
  auto hooks = std::make_shared<Hooks>();
  hooks->wait_for_callback = !progress.is_none();
  std::optional<R> result;
  std::exception_ptr err;
  std::optional<py::error_already_set> py_err;
  std::thread worker([&] {
    try {
      result.emplace(work(*hooks));
    } catch (...) {
      err = std::current_exception();
    }
    {
      std::lock_guard<std::mutex> lock(hooks->m);
      hooks->done = true;
    }
    hooks->cv.notify_all();
  });
  for (;;) {
    std::vector<std::pair<std::string, double>> ev;
    std::uint64_t upto = 0;
    bool done = false;
    {
      py::gil_scoped_release release;
      std::unique_lock<std::mutex> lock(hooks->m);
      hooks->cv.wait_for(lock, std::chrono::milliseconds(50), [&] { return hooks->done || !hooks->events.empty(); });
      ev.swap(hooks->events);
      upto = hooks->posted;
      done = hooks->done;
    }
    if (!py_err) {
      try {
        if (!progress.is_none())
          for (auto& [what, f] : ev) progress(what, f);
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      } catch (py::error_already_set& e) {
        py_err.emplace(std::move(e));
        hooks->cancel = true;
      }
    }
    {
      std::lock_guard<std::mutex> lock(hooks->m);
      hooks->delivered = upto;
    }
    hooks->cv.notify_all();
    if (done) break;
  }
  {
    py::gil_scoped_release release;
    worker.join();
  }
  if (py_err) {
    // The library was asked to stop because of this exception; whatever it threw (normally
    // relief::Cancelled) is secondary. A genuine error (bad input) still wins if it came first.
    if (err) {
      try {
        std::rethrow_exception(err);
      } catch (const relief::Cancelled&) {
      } catch (...) {
      }
    }
    throw *py_err;
  }
  if (err) std::rethrow_exception(err);
  return std::move(*result);
}

// ---- recipes -------------------------------------------------------------------------------
json recipe_document(const py::object& recipe) {
  if (recipe.is_none()) return preset_doc("island");
  if (py::isinstance<py::dict>(recipe)) {
    json doc = to_json(recipe, "recipe");
    if (!doc.is_object()) throw relief::Error("recipe", "expected a JSON object");
    return doc;
  }
  std::string src;
  const bool is_path = py::isinstance(recipe, py::module_::import("pathlib").attr("PurePath"));
  if (is_path) src = py::cast<std::string>(py::str(recipe));
  else if (py::isinstance<py::str>(recipe)) src = py::cast<std::string>(recipe);
  else throw relief::Error("recipe", "expected a preset name, a JSON file path or a dict, got " + py::cast<std::string>(py::str(py::type::of(recipe).attr("__name__"))));
  const bool file_like = is_path || src.find('/') != std::string::npos || src.ends_with(".json") || std::filesystem::exists(src);
  if (!file_like) return preset_doc(src);
  json doc = relief::read_recipe_file(src);  // its file names resolve against its folder
  if (!doc.is_object()) throw relief::Error("recipe", "expected a JSON object in '" + src + "'");
  return doc;
}

// seed, size and set=… applied to a recipe document, in the CLI's order (size, seed, overrides).
relief::Recipe resolve_recipe(const py::object& recipe, const py::object& seed, const py::object& size, const py::object& set) {
  json doc = recipe_document(recipe);
  if (!size.is_none()) {
    long long nx = 0, nz = 0;
    auto num = [](const py::handle& v, const char* path) -> long long {
      if (py::isinstance<py::bool_>(v) || !py::isinstance<py::int_>(v))
        throw relief::Error(path, "expected an integer or a pair of integers (nx, nz), got " + py::cast<std::string>(py::repr(v)));
      return py::cast<long long>(v);
    };
    if (py::isinstance<py::int_>(size)) nx = nz = num(size, "size");
    else if (py::isinstance<py::tuple>(size) || py::isinstance<py::list>(size)) {
      py::sequence s = size;
      if (s.size() != 2) throw relief::Error("size", "expected an integer or a pair of integers (nx, nz), got " + py::cast<std::string>(py::repr(size)));
      nx = num(s[0], "size[0]");
      nz = num(s[1], "size[1]");
    } else {
      num(size, "size");
    }
    if (nx < relief::kMinSize || nz < relief::kMinSize || nx > relief::kMaxSize || nz > relief::kMaxSize)
      throw relief::Error("size", "expected " + std::to_string(relief::kMinSize) + ".." + std::to_string(relief::kMaxSize) +
                                      " samples per axis, got " + py::cast<std::string>(py::repr(size)));
    if (!doc.contains("world") || !doc["world"].is_object()) doc["world"] = json::object();
    doc["world"]["size"] = json::array({nx, nz});
  }
  if (!seed.is_none()) {
    if (py::isinstance<py::bool_>(seed) || !py::isinstance<py::int_>(seed))
      throw relief::Error("seed", "expected an integer in 0..9007199254740991, got " + py::cast<std::string>(py::repr(seed)));
    py::int_ v = seed;
    if (v < py::int_(0) || v > py::int_(relief::kMaxSeed))
      throw relief::Error("seed", "expected an integer in 0..9007199254740991, got " + py::cast<std::string>(py::repr(seed)));
    doc["seed"] = py::cast<std::uint64_t>(v);
  }
  if (!set.is_none()) {
    if (py::isinstance<py::dict>(set)) {
      for (auto [k, v] : py::cast<py::dict>(set)) {
        const std::string path = py::cast<std::string>(py::str(k));
        const json value = to_json(v, path);
        relief::apply_override(doc, path + "=" + value.dump());
      }
    } else if (py::isinstance<py::str>(set)) {
      relief::apply_override(doc, py::cast<std::string>(set));
    } else {
      for (auto a : set) {
        if (!py::isinstance<py::str>(a)) throw relief::Error("set", "expected a dict {PATH: value} or strings 'PATH=VALUE'");
        relief::apply_override(doc, py::cast<std::string>(a));
      }
    }
  }
  return relief::parse_recipe(doc);
}

// ---- Terrain -------------------------------------------------------------------------------
struct PyTerrain {
  std::shared_ptr<relief::Terrain> terrain;
  relief::Recipe recipe;  // as run: seed set
  std::vector<relief::StageTiming> timings;
  double generate_ms = 0;
};

py::array layer_view(const std::shared_ptr<relief::Terrain>& t, const std::string& name) {
  auto it = t->layers.find(name);
  if (it == t->layers.end()) throw py::key_error(name);
  relief::Layer& l = it->second;
  const auto nx = py::ssize_t(t->frame.nx), nz = py::ssize_t(t->frame.nz), ch = py::ssize_t(l.channels);
  auto* owner = new std::shared_ptr<relief::Terrain>(t);
  py::capsule base(owner, [](void* p) { delete static_cast<std::shared_ptr<relief::Terrain>*>(p); });
  const py::ssize_t f = sizeof(float);
  if (ch == 1) return py::array_t<float>({nz, nx}, {nx * f, f}, l.data.data(), base);
  return py::array_t<float>({nz, nx, ch}, {nx * ch * f, ch * f, f}, l.data.data(), base);
}

py::dict point_dict(const relief::Point& p) {
  py::dict d;
  d["kind"] = p.kind;
  d["type"] = p.type;
  d["x_m"] = p.x_m;
  d["y_m"] = p.y_m;
  d["z_m"] = p.z_m;
  d["rotation_deg"] = p.rotation_deg;
  d["scale"] = p.scale;
  return d;
}

std::string formats_arg(const py::object& formats) {
  if (py::isinstance<py::str>(formats)) return py::cast<std::string>(formats);
  std::string s;
  for (auto f : formats) {
    if (!py::isinstance<py::str>(f)) throw relief::Error("formats", "expected writer names (strings), got " + py::cast<std::string>(py::repr(f)));
    s += (s.empty() ? "" : ",") + py::cast<std::string>(f);
  }
  if (s.empty()) throw relief::Error("formats", "expected at least one writer name");
  return s;
}

// Settings to encode an existing terrain through relief::generate (the CLI's writing path).
relief::GenerateSettings write_settings(const PyTerrain& t, const py::object& formats, const py::object& options, int threads) {
  relief::GenerateSettings g;
  g.recipe = t.recipe;
  g.terrain = t.terrain.get();
  g.timings = t.timings;
  g.threads = threads;
  if (!formats.is_none()) {
    g.formats = formats_arg(formats);
    g.formats_path = "formats";
  }
  if (!options.is_none()) {
    json block = t.recipe.export_settings ? relief::export_settings_json(*t.recipe.export_settings) : json::object();
    json o = to_json(options, "options");
    if (!o.is_object()) throw relief::Error("options", "expected a dict of writer options");
    for (auto& [k, v] : o.items()) block[k] = v;
    block.erase("formats");
    g.options = relief::parse_export_settings(block, "options").options;
    g.option_path = [](const std::string& name) { return "options." + name; };
  }
  return g;
}

py::dict report_dict(const relief::GenerateReport& r) {
  py::dict d;
  py::list files;
  for (auto& f : r.files) {
    py::dict e;
    e["name"] = f.name;
    e["writer"] = f.writer;
    e["bytes"] = f.bytes;
    files.append(e);
  }
  d["files"] = files;
  d["seed"] = r.seed;
  d["skipped"] = r.skipped;
  d["total_ms"] = r.total_ms;
  return d;
}

PyTerrain generate(const py::object& recipe, const py::object& seed, const py::object& size, int threads, const py::object& set,
                   const py::object& progress) {
  relief::Recipe r = resolve_recipe(recipe, seed, size, set);
  relief::check_memory(r, false);
  std::function<PyTerrain(Hooks&)> work = [&r, threads](Hooks& h) {
    relief::RunOptions opt;
    opt.threads = threads;
    opt.progress = [&h](std::string_view st, double f) { h.progress(std::string("stage ") + std::string(st), f); };
    opt.cancelled = [&h] { return h.cancelled(); };
    relief::RunResult res = relief::run(r, opt);
    PyTerrain t;
    t.terrain = std::make_shared<relief::Terrain>(std::move(res.terrain));
    t.recipe = r;
    t.recipe.seed = res.seed;
    t.timings = std::move(res.timings);
    t.generate_ms = res.total_ms;
    return t;
  };
  return run_interruptible<PyTerrain>(progress, work);
}

}  // namespace relief_py

using namespace relief_py;

PYBIND11_MODULE(_relief, m) {
  m.doc() = "Relief: procedural terrain (compiled core; use the `relief` package)";
  m.attr("__version__") = RELIEF_VERSION;

  // relief.Error(ValueError) with .path and .message; relief.Cancelled.
  g_error_type = PyErr_NewExceptionWithDoc("relief.Error",
                                           "Bad input: .path names the field (e.g. 'stages[0].octaves'), .message says what was "
                                           "expected and what was given; str() is 'PATH: MESSAGE'.",
                                           PyExc_ValueError, nullptr);
  g_cancelled_type = PyErr_NewExceptionWithDoc("relief.Cancelled", "A run was cancelled; no file was changed.", PyExc_Exception, nullptr);
  m.attr("Error") = py::handle(g_error_type);
  m.attr("Cancelled") = py::handle(g_cancelled_type);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const relief::Error& e) {
      py::object exc = py::reinterpret_steal<py::object>(PyObject_CallFunction(g_error_type, "s", e.what()));
      if (!exc) return;  // the call set an error
      exc.attr("path") = e.path();
      exc.attr("message") = e.message();
      PyErr_SetObject(g_error_type, exc.ptr());
    } catch (const relief::Cancelled& e) {
      PyErr_SetString(g_cancelled_type, e.what());
    }
  });

  py::class_<PyTerrain>(m, "Terrain", "A generated terrain: layers as numpy views of the library's memory, points as plain data.")
      .def_property_readonly("size", [](const PyTerrain& t) { return py::make_tuple(t.terrain->frame.nx, t.terrain->frame.nz); },
                             "(nx, nz): samples along x and z, corners included")
      .def_property_readonly("seed", [](const PyTerrain& t) { return *t.recipe.seed; })
      .def_property_readonly("layer_names", [](const PyTerrain& t) {
        std::vector<std::string> n;
        for (auto& [k, v] : t.terrain->layers) n.push_back(k);
        return n;
      })
      .def("layer", [](const PyTerrain& t, const std::string& name) { return layer_view(t.terrain, name); }, py::arg("name"),
           "The layer `name` as a float32 array of shape (nz, nx) or (nz, nx, channels) viewing the library's memory "
           "(no copy; it keeps the terrain alive). Row j, column i is sample (i, j): x = i·cell_m, z = j·cell_m.")
      .def_property_readonly("frame", [](const PyTerrain& t) {
        const relief::Frame& f = t.terrain->frame;
        py::dict d;
        d["nx"] = f.nx;
        d["nz"] = f.nz;
        d["cell_m"] = f.cell_m();
        d["width_m"] = f.width_m();
        d["depth_m"] = f.depth_m();
        d["world_width_m"] = f.world_width_m;
        d["world_depth_m"] = f.world_depth_m;
        d["height_m"] = f.height_m;
        d["sea_level"] = f.sea_level;
        d["ix0"] = f.ix0;
        d["iz0"] = f.iz0;
        return d;
      })
      .def_property_readonly("points", [](const PyTerrain& t) {
        py::list l;
        for (auto& p : t.terrain->points) l.append(point_dict(p));
        return l;
      })
      .def_property_readonly("rivers", [](const PyTerrain& t) {
        py::list l;
        for (auto& r : t.terrain->rivers) {
          py::dict d;
          d["order"] = r.order;
          d["end"] = r.end;
          py::list vs;
          for (auto& v : r.vertices) {
            py::dict e;
            e["x_m"] = v.x_m;
            e["y_m"] = v.y_m;
            e["z_m"] = v.z_m;
            e["discharge_m3s"] = v.discharge_m3s;
            e["width_m"] = v.width_m;
            vs.append(e);
          }
          d["vertices"] = vs;
          l.append(d);
        }
        return l;
      })
      .def_property_readonly("lakes", [](const PyTerrain& t) {
        py::list l;
        for (auto& k : t.terrain->lakes) {
          py::dict d;
          d["level_m"] = k.level_m;
          d["area_m2"] = k.area_m2;
          d["volume_m3"] = k.volume_m3;
          d["max_depth_m"] = k.max_depth_m;
          d["x_m"] = k.x_m;
          d["z_m"] = k.z_m;
          d["bbox_m"] = py::make_tuple(k.x0_m, k.z0_m, k.x1_m, k.z1_m);
          d["outlet_m"] = py::make_tuple(k.outlet_x_m, k.outlet_z_m);
          d["samples"] = k.samples;
          l.append(d);
        }
        return l;
      })
      .def_property_readonly("biomes", [](const PyTerrain& t) {
        py::list l;
        for (auto& b : t.terrain->biomes) {
          py::dict d;
          d["name"] = b.name;
          d["color"] = py::make_tuple(b.r, b.g, b.b);
          l.append(d);
        }
        return l;
      })
      .def_property_readonly("recipe", [](const PyTerrain& t) { return from_json(t.recipe.to_json()); },
                             "The resolved recipe as run (every parameter, the seed), as a dict")
      .def_property_readonly("timings", [](const PyTerrain& t) {
        py::list l;
        for (auto& s : t.timings) {
          py::dict d;
          d["stage"] = s.name;
          d["label"] = s.label;
          d["ms"] = s.ms;
          d["fused"] = s.fused;
          l.append(d);
        }
        return l;
      })
      .def(
          "write",
          [](const PyTerrain& t, const std::string& folder, const py::object& formats, const py::object& options, int threads, bool sync,
             const py::object& progress) {
            relief::GenerateSettings g = write_settings(t, formats, options, threads);
            const auto mode = sync ? relief::FileOutput::Sync::Durable : relief::FileOutput::Sync::Atomic;
            relief::FileOutput out(folder, relief::FileOutput::Mode::OnCommit, mode);
            std::function<relief::GenerateReport(Hooks&)> work = [&g, &out](Hooks& h) {
              g.progress = [&h](std::string_view w, double f) { h.progress(w, f); };
              g.cancelled = [&h] { return h.cancelled(); };
              return relief::generate(std::move(g), out);
            };
            py::dict rep = report_dict(run_interruptible<relief::GenerateReport>(progress, work));
            py::list paths;
            for (auto& p : out.written()) paths.append(p);
            rep["paths"] = paths;
            return rep;
          },
          py::arg("folder"), py::arg("formats") = py::none(), py::arg("options") = py::none(), py::arg("threads") = 0,
          py::arg("sync") = false, py::arg("progress") = py::none())
      .def(
          "encode",
          [](const PyTerrain& t, const std::string& name, const py::object& options, int threads) -> py::object {
            // A writer name, or the name of a file a writer writes.
            std::string writer = name;
            if (!relief::find_writer(name)) {
              for (const relief::WriterDef& w : relief::writer_registry())
                for (const std::string& f : w.files)
                  if (f == name) writer = w.name;
            }
            relief::GenerateSettings g = write_settings(t, py::str(writer), options, threads);
            relief::MemoryOutput out;
            std::function<int(Hooks&)> work = [&g, &out](Hooks& h) {
              g.cancelled = [&h] { return h.cancelled(); };
              relief::generate(std::move(g), out);
              return 0;
            };
            run_interruptible<int>(py::none(), work);
            if (writer != name) {
              auto it = out.files.find(name);
              if (it == out.files.end()) throw relief::Error("format", "the " + writer + " writer did not write " + name);
              return py::bytes(it->second);
            }
            if (out.files.size() == 1) return py::bytes(out.files.begin()->second);
            py::dict d;
            for (auto& [k, v] : out.files) d[py::str(k)] = py::bytes(v);
            return d;
          },
          py::arg("format"), py::arg("options") = py::none(), py::arg("threads") = 0);

  m.def("generate", &relief_py::generate, py::arg("recipe") = py::none(), py::arg("seed") = py::none(), py::arg("size") = py::none(),
        py::arg("threads") = 0, py::arg("set") = py::none(), py::arg("progress") = py::none());
  m.def("resolve", [](const py::object& recipe, const py::object& seed, const py::object& size, const py::object& set) {
    return from_json(resolve_recipe(recipe, seed, size, set).to_json());
  }, py::arg("recipe") = py::none(), py::arg("seed") = py::none(), py::arg("size") = py::none(), py::arg("set") = py::none());
  m.def("presets", [] {
    py::list l;
    for (auto& p : preset_list()) {
      py::dict d;
      d["name"] = p.name;
      d["description"] = p.description;
      d["origin"] = p.origin;
      l.append(d);
    }
    return l;
  });
  m.def("release_cached_buffers", [] { return relief::release_cached_buffers(); },
        "Frees the process-wide cache of large layer buffers (those of Terrains already gone, kept so that "
        "the next generate() of that size touches memory already mapped); returns the bytes released.");
  m.def("preset", [](const std::string& name) { return from_json(preset_doc(name)); }, py::arg("name"));
  m.def("explain", [](const std::string& stage) { return from_json(relief::parameter_table_json(stage)); }, py::arg("stage") = "");
  m.def("writers", [] {
    py::list l;
    for (const relief::WriterDef& w : relief::writer_registry()) {
      py::dict d;
      d["name"] = w.name;
      d["description"] = w.description;
      d["files"] = w.files;
      d["default"] = w.in_default_set;
      l.append(d);
    }
    return l;
  });

  init_noise(m);
}
