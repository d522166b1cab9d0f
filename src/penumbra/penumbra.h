// Penumbra's public C++ API: what a program that links the installed library (find_package
// (Penumbra), pkg-config penumbra) may rely on. It includes only the standard library: no JSON,
// TBB, GL or glm headers, so a caller's build needs nothing but this file and the library.
//
// Every call does what the command-line tool's command of the same name does, with the same
// options (docs/cli.md), the same checks and the same messages: the library runs the method, and
// the CLI, this API and the bindings only pass options to it. Scenes and results stay in memory;
// files are written only where the options name them (-o, --stats; `bake` writes its output
// directory as the CLI does).
//
// Errors are exceptions of type penumbra::api::Error carrying the library's one-line message
// (the file and the place in it, for bad input). Calls run one at a time in a process (a second
// caller waits); each uses every core unless its options say --threads N.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace penumbra {
struct Scene;
}

namespace penumbra::api {

// The library's version, "MAJOR.MINOR.PATCH".
std::string version();

enum class ErrorKind {
  kInput,        // bad input or options: the CLI's exit code 2
  kRuntime,      // the work failed (no GPU context, a write failed): exit code 1
  kInterrupted,  // interruptRequested() stopped the work: exit code 130
  kInternal,     // a broken internal check (a bug in Penumbra), reported instead of aborting
};

class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message);
  ErrorKind kind() const { return kind_; }
  // The exit code the CLI gives for this kind of error.
  int exitCode() const;

 private:
  ErrorKind kind_;
};

// A linear RGB image (radiance in W m^-2 sr^-1, or lux where a render asks for illuminance):
// `height` rows of `width` pixels, the top row first, three floats per pixel.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;
};

// Called during long work with the stage's name ("rendering", "shooting", ...) and the
// fraction of it done, in [0, 1], from whichever thread made the progress; at most a few
// times per second per stage. It must not call back into the library.
using ProgressCallback = std::function<void(const std::string& stage, double fraction)>;

// A scene in memory. Cheap to copy (the data is shared and never changed).
// How a scene file is read (the command line's --allow-outside-files, --max-texture-size and
// --gltf-scene).
struct LoadOptions {
  // Files a glTF or OBJ file names outside its own folder (absolute paths, "..", links) are read;
  // by default they are refused.
  bool allow_outside_files = false;
  int max_texture_size = 8192;  // the largest side a texture keeps (larger ones are reduced)
  int gltf_scene = -1;          // a glTF file's scene; -1: its own `scene`, else the first
};

class Scene {
 public:
  Scene();
  // A built-in scene ("cornell", "sss", "lpv") or a file: .json, .obj, .gltf, .glb, .ply
  // (docs/scene-format.md).
  static Scene load(const std::string& name_or_path);
  static Scene load(const std::string& name_or_path, const LoadOptions& options);
  // One mesh from arrays: `positions` holds x, y, z per vertex (metres), `indices` three vertex
  // indices per triangle (counter-clockwise is the front face), `material_ids` one index into
  // the description's materials per triangle (empty: material 0 everywhere). `description` is a
  // scene file's JSON without the meshes (docs/scene-format.md), except that "materials" may be
  // an array, in the order `material_ids` counts them; meshes named in it by file are added
  // too. The result is checked as a loaded file is (finite values, indices in range, ...);
  // messages name `source`.
  static Scene fromArrays(std::span<const float> positions, std::span<const uint32_t> indices,
                          std::span<const uint32_t> material_ids, const std::string& description,
                          const std::string& source = "arrays");

  const std::string& source() const;  // the file, "builtin:NAME" or fromArrays' source
  size_t triangleCount() const;
  size_t vertexCount() const;
  size_t lightCount() const;
  size_t materialCount() const;
  // What the loader wanted a user to know (ignored features, degenerate triangles).
  std::vector<std::string> warnings() const;
  // All triangles as one list, in the numbering trace() reports: x, y, z per vertex and three
  // indices per triangle.
  std::vector<float> flatPositions() const;
  std::vector<uint32_t> flatIndices() const;

  const penumbra::Scene& internal() const { return *impl_; }

 private:
  std::shared_ptr<const penumbra::Scene> impl_;
};

// What render() and bake() give back.
struct Result {
  // render: the image, or each frame of a sequence (--frames, --relight-frames); bake: the
  // lightmap atlas.
  std::vector<Image> images;
  // The statistics `--stats FILE` writes, as JSON text.
  std::string stats_json;
  // The run was interrupted and stopped cleanly (progressive and stochastic radiosity write
  // their current solution and a checkpoint). Only set when the call does not throw.
  bool interrupted = false;
};

// An option's value, of the kind docs/cli.md gives the option: true or false for a flag, a whole
// number, a number, numbers (--boundary), a word or a path; a repeatable option (-o) also takes
// several paths.
using OptionValue =
    std::variant<bool, int64_t, double, std::vector<double>, std::string, std::vector<std::string>>;

// Options by name, typed: Options{{"method", "matrix"}, {"elements", 4000}}. A name is the
// command line's without the dashes, with '-' or '_' ("max_depth"). Each value is checked as the
// command line's is: its kind, its range for the method, and that the method takes it; an error
// names the option.
struct Options {
  Options() = default;
  Options(std::initializer_list<std::pair<std::string, OptionValue>> list) : values(list) {}
  Options& set(const std::string& name, OptionValue value) {
    values.emplace_back(name, std::move(value));
    return *this;
  }
  std::vector<std::pair<std::string, OptionValue>> values;
};

// The methods and their options, from the library's own descriptions (the CLI's --help and
// docs/cli.md are made from the same): what bindings build their keyword arguments and help from.
struct MethodDescription {
  std::string name;     // as --method takes it
  std::string summary;  // one line
  std::string source;   // the paper it implements, or why it is here
  bool bakes = false;   // bake takes it too
};
struct OptionDescription {
  std::string name;  // as the command line's, without the dashes ("max-depth")
  std::string kind;  // flag, int, unsigned, real, reals, choice or text
  std::string help;
  std::string unit;                  // "m", "s", ... or empty
  std::string range;                 // "[1, 65536]", or empty
  std::vector<std::string> choices;  // kind choice
  // The methods that take it, each with its default as users read it ("" when it has none or
  // it is computed) and its own range where it differs from `range`; empty when every method of
  // the command takes it.
  struct Use {
    std::string method;
    std::string default_value;
    std::string range;
  };
  std::vector<Use> methods;
  bool repeatable = false;  // may be given several times (-o a.png -o a.exr)
};
std::vector<MethodDescription> methods();
// The options of `command` ("render" or "bake"), then those every command takes (threads, quiet,
// dry-run).
std::vector<OptionDescription> options(const std::string& command);

// `penumbra render` with typed options: render(scene, Options{{"method", "matrix"}}). Images are
// written only where "output" names them; the result holds them in memory.
Result render(const Scene& scene, const Options& options, const ProgressCallback& progress = {});
// The same with the command line's words, e.g. {"--method", "matrix", "--elements", "4000"}: a
// convenience parsed by the same descriptions.
Result render(const Scene& scene, const std::vector<std::string>& options = {},
              const ProgressCallback& progress = {});

// `penumbra bake`: writes the lightmap files into "output" DIR (default ".") as the CLI does and
// returns the atlas.
Result bake(const Scene& scene, const Options& options, const ProgressCallback& progress = {});
Result bake(const Scene& scene, const std::vector<std::string>& options = {},
            const ProgressCallback& progress = {});

// `penumbra trace`: rays in the ray file's layout, eight floats per ray (ox oy oz tmin dx dy dz
// tmax), against the scene's triangles (the numbering of Scene::flatIndices()).
struct TraceOptions {
  std::string device = "auto";  // cpu, gpu, hybrid or auto, as --device
  bool occlusion = false;       // any hit: fills `occluded` instead of the closest hits
  int threads = 0;              // 0: every core
  bool quiet = true;            // false: the CLI's log line (rays, hits, Mrays/s) on stderr
  // hybrid: as --t-min, --t-max, --r-min and --cache-rays (0: the default, 4 r_min).
  uint32_t t_min = 64, t_max = 1024, r_min = 256, cache_rays = 0;
};
struct Hits {
  // Closest hits: triangle -1 where a ray hits nothing (then t is infinite, u and v zero).
  std::vector<int32_t> triangle;
  std::vector<float> t, u, v;
  // Occlusion: 1 where something lies between tmin and tmax.
  std::vector<uint8_t> occluded;
  std::string stats_json;  // as `trace --stats`
};
Hits trace(const Scene& scene, std::span<const float> rays, const TraceOptions& options = {});

// --- Over several processes (MPI; docs/scaling.md) ---
//
// The communicator a call runs over, by its MPI_Comm_c2f handle, so that this header needs no
// mpi.h: penumbra/penumbra_mpi.h (installed with an MPI build) makes one from an MPI_Comm. The
// caller initialises MPI (MPI_Init_thread; MPI_THREAD_SERIALIZED or better lets rank 0 hand out
// work from a thread of its own, else work is dealt out statically) and keeps the communicator
// alive. A default Communicator is this process alone.
struct Communicator {
  int64_t mpi_fortran_handle = -1;
};
// Whether this build of the library has MPI (otherwise a call with a communicator of more than
// one process throws Error{kInput}).
bool mpiAvailable();

// The calls above over a communicator: every process of it makes the same call with the same
// scene and options (collective); the work is shared out as the CLI under mpirun shares it, and
// rank 0 gets the result (the others an empty Result / Hits). The path tracer, `trace`, matrix
// radiosity with --solver jacobi and progressive radiosity give one process's result bit for
// bit; --solver gauss-seidel becomes block Gauss-Seidel (docs/scaling.md). For trace, rank 0's
// rays are traced (the others pass none). Only rank 0 writes files.
Result render(const Communicator& comm, const Scene& scene, const Options& options,
              const ProgressCallback& progress = {});
Result render(const Communicator& comm, const Scene& scene,
              const std::vector<std::string>& options = {}, const ProgressCallback& progress = {});
Result bake(const Communicator& comm, const Scene& scene, const Options& options,
            const ProgressCallback& progress = {});
Result bake(const Communicator& comm, const Scene& scene,
            const std::vector<std::string>& options = {}, const ProgressCallback& progress = {});
Hits trace(const Communicator& comm, const Scene& scene, std::span<const float> rays,
           const TraceOptions& options = {});

// Images in the formats the CLI reads and writes (.exr, .hdr, .pfm, .png). Writing a .png
// tone-maps with `tonemap` ("reinhard" or "exposure", as --tonemap) at `exposure` stops.
Image readImage(const std::string& path);
void writeImage(const std::string& path, const Image& image,
                const std::string& tonemap = "reinhard", double exposure = 0.0);

// Throws Error(kInput) when `bytes` more would not fit in the memory this process may still
// allocate, naming `what` and both amounts: the check every method makes before it allocates,
// for callers that copy data in (the Python module checks an array's copy with it).
void checkMemory(uint64_t bytes, const std::string& what);

// Asks the running call to stop, as SIGINT asks the CLI: progressive and stochastic radiosity
// stop after the current step and write what they have (during the lights' shot, before anything
// is solved, they throw Error(kInterrupted)); the other methods stop at the next pixel (the path
// tracer) or step and throw Error(kInterrupted). Async-signal-safe: a caller's SIGINT
// handler may call it. The request is cleared when the next call starts.
void requestInterrupt();

}  // namespace penumbra::api
