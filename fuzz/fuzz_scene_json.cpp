// The JSON scene format; a small mesh file "m.obj" sits beside it for "meshes" to name.
#include "fuzz_util.h"
#include "penumbra/io/scene_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  static const std::string mesh =
      fuzz::writeInput("m.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  const std::string path =
      fuzz::writeInput("x.json", std::string_view(reinterpret_cast<const char*>(data), size));
  fuzz::expectContract(loadSceneJson(path), path);
  return 0;
}
