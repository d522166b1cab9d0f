// OBJ with its MTL: the input's text before a line "#MTL" is the OBJ, after it the MTL
// ("mtllib m.mtl" in the OBJ reads it).
#include "fuzz_util.h"
#include "penumbra/io/scene_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const size_t split = in.find("\n#MTL\n");
  fuzz::writeInput("m.mtl",
                   split == std::string_view::npos ? std::string_view() : in.substr(split + 6));
  const std::string path = fuzz::writeInput("x.obj", in.substr(0, split));
  fuzz::expectContract(loadObj(path), path);
  return 0;
}
