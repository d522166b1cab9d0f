// The Python module `penumbra._penumbra`, on the library's public API (penumbra.h); the package
// around it (python/penumbra/__init__.py) turns keyword arguments into the CLI's options.
// Work runs with the GIL released; Ctrl-C during a call asks the library to stop (as SIGINT
// asks the CLI) and the call raises KeyboardInterrupt.
#include "penumbra/penumbra.h"

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <csignal>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace py = pybind11;
using penumbra::api::ErrorKind;

namespace {

PyObject* g_error = nullptr;        // penumbra.Error
PyObject* g_input_error = nullptr;  // penumbra.InputError (also a ValueError)

// A NumPy array that owns `values` (moved, not copied) with the given shape.
template <typename T>
py::array_t<T> ownedArray(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<T>(std::move(values));
  py::capsule free_when_done(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, owned->data(), free_when_done);
}

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<uint32_t, py::array::c_style | py::array::forcecast>;

[[noreturn]] void inputError(const std::string& message) {
  throw penumbra::api::Error(ErrorKind::kInput, message);
}

// Any array-like (a NumPy array is taken as it is, a list is converted).
py::array asArray(const py::object& obj, const std::string& what) {
  py::array a = py::array::ensure(obj);
  if (!a) {
    PyErr_Clear();
    inputError(what + " must be an array of numbers");
  }
  return a;
}

// Whether reading `a` as C-contiguous float32 copies it.
bool needsCopy(const py::array& a) {
  return !(a.dtype().is(py::dtype::of<float>()) &&
           (a.flags() & py::array::c_style) == py::array::c_style);
}

// `a` as C-contiguous float32, its shape checked first (N x `columns`) and the memory of a copy
// checked before NumPy makes it: a broadcast view of 10^12 rows would otherwise fail inside the
// conversion with a TypeError that names no array.
FloatArray floatRows(const py::object& obj, py::ssize_t columns, const std::string& what) {
  const py::array a = asArray(obj, what);
  if (a.ndim() != 2 || a.shape(1) != columns) {
    inputError(what + " must be an N x " + std::to_string(columns) + " array");
  }
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    inputError(what + " must hold numbers, not dtype " + std::string(py::str(a.dtype())));
  }
  const uint64_t rows = uint64_t(a.shape(0));
  if (needsCopy(a)) {
    penumbra::api::checkMemory(rows * uint64_t(columns) * 4,
                               what + ": " + std::to_string(rows) + " rows as float32");
  }
  FloatArray out = FloatArray::ensure(a);
  if (!out) throw py::error_already_set();
  return out;
}

// Indices (triangles, material ids) as uint32: whole numbers from 0 to 2^32 - 1. A float array
// is accepted when every value is whole (2.7 is refused, not truncated to 2), a signed one when
// none is negative (-1 would wrap).
IndexArray indexArray(const py::object& obj, const std::string& what) {
  const py::array a = asArray(obj, what);
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    inputError(what + " must hold whole numbers, not dtype " + std::string(py::str(a.dtype())));
  }
  penumbra::api::checkMemory(uint64_t(a.size()) * 8,
                             what + ": " + std::to_string(a.size()) + " indices");
  if (kind != 'u') {
    const auto values = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
    if (!values) throw py::error_already_set();
    const double* v = values.data();
    for (py::ssize_t i = 0; i < values.size(); ++i) {
      if (!(v[i] >= 0.0 && v[i] <= 4294967295.0 && v[i] == double(int64_t(v[i])))) {
        inputError(what + ": value " + std::to_string(i) + " (" +
                   std::string(py::repr(py::float_(v[i]))) +
                   ") is not a whole number from 0 to 2^32 - 1");
      }
    }
  } else if (a.itemsize() > 4) {
    const auto values = py::array_t<uint64_t, py::array::c_style | py::array::forcecast>::ensure(a);
    if (!values) throw py::error_already_set();
    for (py::ssize_t i = 0; i < values.size(); ++i) {
      if (values.data()[i] > 4294967295u) {
        inputError(what + ": value " + std::to_string(i) + " is larger than 2^32 - 1");
      }
    }
  }
  IndexArray out = IndexArray::ensure(a);
  if (!out) throw py::error_already_set();
  return out;
}

py::array_t<float> imageArray(penumbra::api::Image&& image) {
  const py::ssize_t h = image.height, w = image.width;
  return ownedArray(std::move(image.rgb), {h, w, 3});
}

// While a call runs on the main thread, SIGINT asks the library to stop instead of going to
// Python's handler (which could only run once the call returns); the old handler comes back
// after. Calls from other threads leave signals alone.
class SigintToLibrary {
 public:
  SigintToLibrary() {
    if (std::this_thread::get_id() != mainThread()) return;
    struct sigaction sa = {};
    sa.sa_handler = [](int) { penumbra::api::requestInterrupt(); };
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    installed_ = sigaction(SIGINT, &sa, &previous_) == 0;
  }
  ~SigintToLibrary() {
    if (installed_) sigaction(SIGINT, &previous_, nullptr);
  }
  SigintToLibrary(const SigintToLibrary&) = delete;
  SigintToLibrary& operator=(const SigintToLibrary&) = delete;

  static std::thread::id& mainThread() {
    static std::thread::id id;
    return id;
  }

 private:
  struct sigaction previous_ = {};
  bool installed_ = false;
};

// A Python progress callable behind the library's callback: called with the GIL, its exception
// kept (and the work asked to stop) to be raised once the call returns.
struct ProgressBridge {
  py::object callable;
  std::mutex mutex;
  std::optional<py::error_already_set> raised;

  penumbra::api::ProgressCallback callback() {
    if (callable.is_none()) return {};
    return [this](const std::string& stage, double fraction) {
      py::gil_scoped_acquire gil;
      {
        std::lock_guard lock(mutex);
        if (raised) return;
      }
      try {
        callable(stage, fraction);
      } catch (py::error_already_set& e) {
        std::lock_guard lock(mutex);
        raised.emplace(std::move(e));
        penumbra::api::requestInterrupt();
      }
    };
  }
  // Raises what the callable raised, if it did.
  void rethrow() {
    if (raised) {
      py::error_already_set e = std::move(*raised);
      raised.reset();
      throw e;
    }
  }
  ~ProgressBridge() {
    py::gil_scoped_acquire gil;
    raised.reset();
    callable = py::none();
  }
};

[[noreturn]] void raiseKeyboardInterrupt() {
  PyErr_SetNone(PyExc_KeyboardInterrupt);
  throw py::error_already_set();
}

// Runs a render or bake with the GIL released; Ctrl-C raises KeyboardInterrupt once the work has
// stopped (progressive radiosity has then written its checkpoint, as the CLI does).
py::tuple runCommand(penumbra::api::Result (*command)(const penumbra::api::Scene&,
                                                      const penumbra::api::Options&,
                                                      const penumbra::api::ProgressCallback&),
                     const penumbra::api::Scene& scene, const penumbra::api::Options& options,
                     py::object progress) {
  ProgressBridge bridge{std::move(progress)};
  penumbra::api::Result result;
  bool interrupted = false;
  {
    SigintToLibrary sigint;
    py::gil_scoped_release release;
    try {
      result = command(scene, options, bridge.callback());
      interrupted = result.interrupted;
    } catch (const penumbra::api::Error& e) {
      if (e.kind() != ErrorKind::kInterrupted) {
        py::gil_scoped_acquire gil;
        bridge.rethrow();  // the callable's own exception stopped the work
        throw;
      }
      interrupted = true;
    }
  }
  bridge.rethrow();
  if (interrupted) raiseKeyboardInterrupt();
  py::list images;
  for (penumbra::api::Image& image : result.images) images.append(imageArray(std::move(image)));
  return py::make_tuple(images, result.stats_json);
}

}  // namespace

PYBIND11_MODULE(_penumbra, m) {
  m.doc() = "Penumbra's library: scenes, renders, bakes, rays and images (docs/python.md)";
  SigintToLibrary::mainThread() = std::this_thread::get_id();

  static py::exception<penumbra::api::Error> error(m, "Error", PyExc_RuntimeError);
  g_error = error.ptr();
  py::object input_error_type = py::reinterpret_steal<py::object>(
      PyErr_NewException("penumbra._penumbra.InputError",
                         py::make_tuple(error, py::handle(PyExc_ValueError)).ptr(), nullptr));
  g_input_error = input_error_type.ptr();
  m.attr("InputError") = input_error_type;
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const penumbra::api::Error& e) {
      if (e.kind() == ErrorKind::kInterrupted) {
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        return;
      }
      PyObject* type = e.kind() == ErrorKind::kInput ? g_input_error : g_error;
      py::object instance = py::reinterpret_borrow<py::object>(type)(e.what());
      const char* kind = e.kind() == ErrorKind::kInput     ? "input"
                         : e.kind() == ErrorKind::kRuntime ? "runtime"
                                                           : "internal";
      instance.attr("kind") = kind;
      instance.attr("exit_code") = e.exitCode();
      PyErr_SetObject(type, instance.ptr());
    }
  });

  m.def("version", &penumbra::api::version);

  py::class_<penumbra::api::Scene>(m, "Scene", py::dynamic_attr())
      .def_static(
          "load",
          [](const std::string& name_or_path, bool allow_outside_files, int max_texture_size,
             int gltf_scene) {
            penumbra::api::LoadOptions options;
            options.allow_outside_files = allow_outside_files;
            options.max_texture_size = max_texture_size;
            options.gltf_scene = gltf_scene;
            return penumbra::api::Scene::load(name_or_path, options);
          },
          py::arg("name_or_path"), py::arg("allow_outside_files") = false,
          py::arg("max_texture_size") = 8192, py::arg("gltf_scene") = -1,
          py::call_guard<py::gil_scoped_release>())
      .def_static(
          "from_arrays",
          [](const py::object& positions_in, const py::object& indices_in,
             std::optional<py::object> material_ids_in, const std::string& description,
             const std::string& source) {
            const FloatArray positions = floatRows(positions_in, 3, source + ": positions");
            const py::array index_rows = asArray(indices_in, source + ": indices");
            if (index_rows.ndim() != 2 || index_rows.shape(1) != 3) {
              inputError(source + ": indices must be a T x 3 array");
            }
            const IndexArray indices = indexArray(index_rows, source + ": indices");
            std::optional<IndexArray> material_ids;
            std::span<const uint32_t> ids;
            if (material_ids_in) {
              const py::array id_list = asArray(*material_ids_in, source + ": material_ids");
              if (id_list.ndim() != 1) inputError(source + ": material_ids must be a 1-D array");
              material_ids = indexArray(id_list, source + ": material_ids");
              ids = {material_ids->data(), size_t(material_ids->size())};
            }
            const std::span<const float> p(positions.data(), size_t(positions.size()));
            const std::span<const uint32_t> t(indices.data(), size_t(indices.size()));
            py::gil_scoped_release release;
            return penumbra::api::Scene::fromArrays(p, t, ids, description, source);
          },
          py::arg("positions"), py::arg("indices"), py::arg("material_ids") = py::none(),
          py::arg("description") = "", py::arg("source") = "arrays")
      .def_property_readonly("source", &penumbra::api::Scene::source)
      .def_property_readonly("triangle_count", &penumbra::api::Scene::triangleCount)
      .def_property_readonly("vertex_count", &penumbra::api::Scene::vertexCount)
      .def_property_readonly("light_count", &penumbra::api::Scene::lightCount)
      .def_property_readonly("material_count", &penumbra::api::Scene::materialCount)
      .def_property_readonly("warnings", &penumbra::api::Scene::warnings)
      .def("flat_positions",
           [](const penumbra::api::Scene& s) {
             std::vector<float> p = s.flatPositions();
             const py::ssize_t n = py::ssize_t(p.size() / 3);
             return ownedArray(std::move(p), {n, 3});
           })
      .def("flat_indices",
           [](const penumbra::api::Scene& s) {
             std::vector<uint32_t> t = s.flatIndices();
             const py::ssize_t n = py::ssize_t(t.size() / 3);
             return ownedArray(std::move(t), {n, 3});
           })
      .def("__repr__", [](const penumbra::api::Scene& s) {
        return "<penumbra.Scene '" + s.source() + "': " + std::to_string(s.triangleCount()) +
               " triangles, " + std::to_string(s.lightCount()) + " lights>";
      });

  // Keyword arguments as typed values (bool, int, float, a list of floats, str, a list of str),
  // checked by the library's descriptions of the options (InputError naming the option).
  m.def(
      "_render",
      [](const penumbra::api::Scene& scene,
         const std::vector<std::pair<std::string, penumbra::api::OptionValue>>& options,
         py::object progress) {
        penumbra::api::Options typed;
        typed.values = options;
        return runCommand(&penumbra::api::render, scene, typed, std::move(progress));
      },
      py::arg("scene"), py::arg("options"), py::arg("progress") = py::none());
  m.def(
      "_bake",
      [](const penumbra::api::Scene& scene,
         const std::vector<std::pair<std::string, penumbra::api::OptionValue>>& options,
         py::object progress) {
        penumbra::api::Options typed;
        typed.values = options;
        return runCommand(&penumbra::api::bake, scene, typed, std::move(progress));
      },
      py::arg("scene"), py::arg("options"), py::arg("progress") = py::none());
  m.def("_methods", [] {
    py::list out;
    for (const penumbra::api::MethodDescription& d : penumbra::api::methods()) {
      py::dict method;
      method["name"] = d.name, method["summary"] = d.summary, method["source"] = d.source;
      method["bakes"] = d.bakes;
      out.append(method);
    }
    return out;
  });
  m.def(
      "_options",
      [](const std::string& command) {
        py::list out;
        for (const penumbra::api::OptionDescription& d : penumbra::api::options(command)) {
          py::dict o;
          o["name"] = d.name, o["kind"] = d.kind, o["help"] = d.help, o["unit"] = d.unit;
          py::list uses;
          for (const penumbra::api::OptionDescription::Use& u : d.methods) {
            uses.append(py::make_tuple(u.method, u.default_value, u.range));
          }
          o["range"] = d.range, o["choices"] = d.choices, o["methods"] = uses;
          o["repeatable"] = d.repeatable;
          out.append(o);
        }
        return out;
      },
      py::arg("command"));

  m.def(
      "_trace",
      [](const penumbra::api::Scene& scene, const py::object& rays_obj, const std::string& device,
         bool occlusion, int threads, uint32_t t_min, uint32_t t_max, uint32_t r_min,
         uint32_t cache_rays, bool quiet) {
        const py::array rays_in = asArray(rays_obj, "rays");
        if (rays_in.ndim() != 2 || rays_in.shape(1) != 8) {
          inputError("rays must be an N x 8 float32 array (ox oy oz tmin dx dy dz tmax)");
        }
        // The copy (when the array is not C-contiguous float32) and what tracing holds per ray
        // (api.cpp: 64 bytes), before either is made.
        penumbra::api::checkMemory(uint64_t(rays_in.shape(0)) * (needsCopy(rays_in) ? 32 + 64 : 64),
                                   "tracing " + std::to_string(rays_in.shape(0)) + " rays");
        const FloatArray rays = floatRows(rays_in, 8, "rays");
        penumbra::api::TraceOptions options;
        options.device = device;
        options.occlusion = occlusion;
        options.threads = threads;
        options.t_min = t_min;
        options.t_max = t_max;
        options.r_min = r_min;
        options.cache_rays = cache_rays;
        options.quiet = quiet;
        // Read in place: a C-contiguous float32 array is not copied on the way in.
        const std::span<const float> values(rays.data(), size_t(rays.size()));
        penumbra::api::Hits hits;
        {
          SigintToLibrary sigint;
          py::gil_scoped_release release;
          hits = penumbra::api::trace(scene, values, options);
        }
        py::dict out;
        const py::ssize_t n = rays.shape(0);
        if (occlusion) {
          out["occluded"] = ownedArray(std::move(hits.occluded), {n}).attr("astype")("bool");
        } else {
          out["triangle"] = ownedArray(std::move(hits.triangle), {n});
          out["t"] = ownedArray(std::move(hits.t), {n});
          out["u"] = ownedArray(std::move(hits.u), {n});
          out["v"] = ownedArray(std::move(hits.v), {n});
        }
        out["stats"] = hits.stats_json;
        return out;
      },
      py::arg("scene"), py::arg("rays"), py::arg("device") = "auto", py::arg("occlusion") = false,
      py::arg("threads") = 0, py::arg("t_min") = 64, py::arg("t_max") = 1024,
      py::arg("r_min") = 256, py::arg("cache_rays") = 0, py::arg("quiet") = true);

  m.def(
      "_read_image",
      [](const std::string& path) {
        penumbra::api::Image image;
        {
          py::gil_scoped_release release;
          image = penumbra::api::readImage(path);
        }
        return imageArray(std::move(image));
      },
      py::arg("path"));
  m.def(
      "_write_image",
      [](const std::string& path, py::array_t<float, py::array::c_style | py::array::forcecast> a,
         const std::string& tonemap, double exposure) {
        if (a.ndim() != 3 || a.shape(2) != 3) {
          throw penumbra::api::Error(ErrorKind::kInput,
                                     path + ": the image must be an H x W x 3 array");
        }
        penumbra::api::Image image;
        image.height = int(a.shape(0));
        image.width = int(a.shape(1));
        image.rgb.assign(a.data(), a.data() + a.size());
        py::gil_scoped_release release;
        penumbra::api::writeImage(path, image, tonemap, exposure);
      },
      py::arg("path"), py::arg("image"), py::arg("tonemap") = "reinhard",
      py::arg("exposure") = 0.0);
}
