// EXT_meshopt_compression and KHR_meshopt_compression: buffer views compressed by meshoptimizer's
// codecs (KHR_meshopt_compression, Appendix A "Bitstream" and B "Filters"; EXT_meshopt_compression
// is its version-0 subset).
//
// Debian's libmeshoptimizer (0.18) decodes the version-0 attribute stream, both index streams
// and the octahedral, quaternion and exponential filters: those go through it. It predates
// KHR_meshopt_compression, so the version-1 attribute stream (control modes per byte, channel
// modes per 4 bytes) and the COLOR filter are decoded here, from the extension's Appendices A and
// B.
#pragma once

#include "penumbra/core/expected.h"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <string>
#include <string_view>

namespace penumbra {

// The parameters of a compressed buffer view, checked (the extension's "JSON schema updates").
struct MeshoptView {
  enum class Mode : uint8_t { kAttributes, kTriangles, kIndices };
  enum class Filter : uint8_t { kNone, kOctahedral, kQuaternion, kExponential, kColor };
  int64_t buffer = 0;
  uint64_t byte_offset = 0, byte_length = 0;
  uint64_t byte_stride = 0, count = 0;
  Mode mode = Mode::kAttributes;
  Filter filter = Filter::kNone;
};

// Reads the extension object `ext` of a buffer view whose own byteLength is `view_byte_length`;
// `khr` for KHR_meshopt_compression (which alone allows the COLOR filter). Errors name `file` and
// `place`.
Expected<MeshoptView> readMeshoptView(const nlohmann::json& ext, bool khr,
                                      uint64_t view_byte_length, const std::string& file,
                                      const std::string& place);

// The decoded bytes (count x byte_stride) of `view` from its compressed bytes `compressed`. A
// stream that is cut short, holds bytes past its data, or decodes to indices that the stream
// itself cannot reach is an input error naming `file` and `place`.
Expected<std::string> decodeMeshoptView(const MeshoptView& view, std::string_view compressed,
                                        const std::string& file, const std::string& place);

// The version-1 attribute codec alone (Appendix A, mode 0, header 0xa1), for tests: `count`
// elements of `stride` bytes into `out` (count x stride bytes). False for a malformed stream.
bool decodeAttributesV1(unsigned char* out, size_t count, size_t stride, const unsigned char* data,
                        size_t size);

}  // namespace penumbra
