// glTF: JSON (.gltf) or binary (.glb, by its magic).
#include "fuzz_util.h"
#include "penumbra/io/scene_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const bool binary = in.substr(0, 4) == "glTF";
  const std::string path = fuzz::writeInput(binary ? "x.glb" : "x.gltf", in);
  fuzz::expectContract(loadGltf(path), path);
  return 0;
}
