// KHR_meshopt_compression and EXT_meshopt_compression streams (io/gltf/gltf_meshopt.h): the first
// four bytes choose the mode, the filter, the stride and the element count, the rest is the
// compressed stream. A stream decodes to exactly count x stride bytes or gives an input error;
// never a read past its end (ASan), a crash or a hang.
#include "fuzz_util.h"
#include "penumbra/io/gltf/gltf_meshopt.h"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  if (size < 4) return 0;
  MeshoptView v;
  v.mode = MeshoptView::Mode(data[0] % 3);
  v.filter = MeshoptView::Filter(data[1] % 5);
  const size_t strides[] = {2, 4, 8, 12, 16, 20, 32, 64, 256};
  v.byte_stride = strides[data[2] % 9];
  v.count = 1 + data[3] * 3;
  if (v.mode != MeshoptView::Mode::kAttributes) {
    v.byte_stride = v.byte_stride == 2 ? 2 : 4;
    v.filter = MeshoptView::Filter::kNone;
    if (v.mode == MeshoptView::Mode::kTriangles) v.count = 3 * (1 + data[3]);
  }
  const bool stride_ok = v.mode != MeshoptView::Mode::kAttributes ||
                         (v.byte_stride % 4 == 0 &&
                          (v.filter == MeshoptView::Filter::kNone ||
                           ((v.filter == MeshoptView::Filter::kOctahedral ||
                             v.filter == MeshoptView::Filter::kColor) &&
                            (v.byte_stride == 4 || v.byte_stride == 8)) ||
                           (v.filter == MeshoptView::Filter::kQuaternion && v.byte_stride == 8) ||
                           v.filter == MeshoptView::Filter::kExponential));
  if (!stride_ok) return 0;  // readMeshoptView refuses these layouts before decoding
  const std::string_view stream(reinterpret_cast<const char*>(data + 4), size - 4);
  Expected<std::string> out = decodeMeshoptView(v, stream, "x.glb", "bufferViews[0]");
  if (out.ok() && out->size() != v.count * v.byte_stride) std::abort();
  fuzz::expectContract(out, "x.glb");
  return 0;
}
