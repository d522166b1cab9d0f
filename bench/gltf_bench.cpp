// Reading compressed glTF, each figure a ratio against a peer in the same run (design doc sec. 7):
//   - KHR_meshopt_compression's version-1 attribute stream through Penumbra's own decoder, against
//     the same elements through Debian's meshoptimizer decoding its version-0 stream (the
//     library's own encoder wrote it from the same data): bytes decoded per second;
//   - loading the Avocado (tests/data/gltf-corpus) plain, Draco-, meshopt- and
//     quantized-compressed: the whole loader (files, decoding, textures), against the plain file.
#include "penumbra/core/file_util.h"
#include "penumbra/io/gltf/gltf_meshopt.h"
#include "penumbra/io/scene_io.h"

#include <benchmark/benchmark.h>
#include <meshoptimizer.h>

#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra {
namespace {

// The whole file (empty when it cannot be read: the caller's check fails then).
std::string readBytes(const std::string& path) {
  Expected<std::string> bytes = readFile(path);
  return bytes ? std::move(*bytes) : std::string();
}

uint32_t le32(const std::string& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

// The floats fixture (700 positions of 16 bytes), as a version-1 stream and, encoded here by the
// library, a version-0 one.
struct Streams {
  MeshoptView view;
  std::string v1;
  std::vector<unsigned char> v0;
  std::string raw;
};

const Streams& streams() {
  static const Streams s = [] {
    Streams out;
    const std::string b = readBytes(std::string(PENUMBRA_BENCH_DATA) + "/meshopt/v1_floats.bin");
    out.view.count = le32(b, 0);
    out.view.byte_stride = le32(b, 4);
    out.v1 = b.substr(16, le32(b, 8));
    out.raw = b.substr(16 + le32(b, 8), le32(b, 12));
    out.v0.resize(meshopt_encodeVertexBufferBound(out.view.count, out.view.byte_stride));
    out.v0.resize(meshopt_encodeVertexBuffer(out.v0.data(), out.v0.size(), out.raw.data(),
                                             out.view.count, out.view.byte_stride));
    return out;
  }();
  return s;
}

void BM_MeshoptVersion1Penumbra(benchmark::State& state) {
  const Streams& s = streams();
  for (auto _ : state) {
    Expected<std::string> d = decodeMeshoptView(s.view, s.v1, "bench", "v1");
    benchmark::DoNotOptimize(d);
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(s.raw.size()));
}
BENCHMARK(BM_MeshoptVersion1Penumbra);

void BM_MeshoptVersion0Library(benchmark::State& state) {
  const Streams& s = streams();
  std::vector<unsigned char> out(s.raw.size());
  for (auto _ : state) {
    const int rc = meshopt_decodeVertexBuffer(out.data(), s.view.count, s.view.byte_stride,
                                              s.v0.data(), s.v0.size());
    benchmark::DoNotOptimize(rc);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(s.raw.size()));
}
BENCHMARK(BM_MeshoptVersion0Library);

void BM_LoadAvocado(benchmark::State& state, const char* file) {
  const std::string path = std::string(PENUMBRA_BENCH_DATA) + "/gltf-corpus/avocado/" + file;
  for (auto _ : state) {
    Expected<Scene> s = loadGltf(path);
    if (!s) state.SkipWithError(s.error().describe().c_str());
    benchmark::DoNotOptimize(s);
  }
}
BENCHMARK_CAPTURE(BM_LoadAvocado, plain, "Avocado.glb")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoadAvocado, draco, "Avocado.draco.glb")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoadAvocado, meshopt, "Avocado.meshopt.glb")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoadAvocado, khr_meshopt, "Avocado.khr-meshopt.glb")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LoadAvocado, quantized, "Avocado.quantized.glb")
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace penumbra

BENCHMARK_MAIN();
