#include "penumbra/io/gltf/gltf_meshopt.h"

#include "penumbra/core/memory.h"

#include <meshoptimizer.h>
#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

namespace penumbra {

namespace {

constexpr size_t kGroup = 16;  // elements per delta group (Appendix A)

// Appendix A, mode 0: elements per attribute block.
size_t maxBlockElements(size_t stride) {
  return std::min((8192 / stride) & ~(kGroup - 1), size_t(256));
}

// One group of 16 byte deltas stored in `bits`-bit sentinel encoding (1, 2 or 4; 1-bit values
// least significant first, 2- and 4-bit most significant first), stored whole (8) or absent (0).
// Returns the byte after the group, or null when the stream ends first.
const unsigned char* decodeGroup(const unsigned char* p, const unsigned char* end,
                                 unsigned char* out, int bits) {
  if (bits == 0) {
    std::memset(out, 0, kGroup);
    return p;
  }
  if (bits == 8) {
    if (size_t(end - p) < kGroup) return nullptr;
    std::memcpy(out, p, kGroup);
    return p + kGroup;
  }
  const size_t packed = kGroup * size_t(bits) / 8;
  if (size_t(end - p) < packed) return nullptr;
  const unsigned char* extra = p + packed;
  const unsigned sentinel = (1u << bits) - 1u;
  const size_t per_byte = 8 / size_t(bits);
  for (size_t j = 0; j < kGroup; ++j) {
    unsigned v;
    if (bits == 1) {
      v = (p[j / 8] >> (j % 8)) & 1u;
    } else {
      v = (p[j / per_byte] >> (8 - size_t(bits) * (j % per_byte + 1))) & sentinel;
    }
    if (v == sentinel) {
      if (extra >= end) return nullptr;
      v = *extra++;
    }
    out[j] = static_cast<unsigned char>(v);
  }
  return extra;
}

// The deltas of one byte position over a block of `elements` elements (`groups` groups), under
// control mode `control` (Appendix A, version 1): 0 and 1 select the bit lengths of the groups'
// header codes, 2 is all zero, 3 literal bytes, one per element (not rounded up to whole groups,
// as meshoptimizer's own decoder reads them).
const unsigned char* decodeByteDeltas(const unsigned char* p, const unsigned char* end,
                                      unsigned char* out, size_t elements, size_t groups,
                                      unsigned control) {
  if (control == 2) {
    std::memset(out, 0, groups * kGroup);
    return p;
  }
  if (control == 3) {
    if (size_t(end - p) < elements) return nullptr;
    std::memcpy(out, p, elements);
    std::memset(out + elements, 0, groups * kGroup - elements);
    return p + elements;
  }
  static constexpr int kBits[2][4] = {{0, 1, 2, 4}, {1, 2, 4, 8}};
  const size_t header = (groups + 3) / 4;
  if (size_t(end - p) < header) return nullptr;
  const unsigned char* h = p;
  p += header;
  for (size_t g = 0; g < groups; ++g) {
    const unsigned code = (h[g / 4] >> ((g % 4) * 2)) & 3u;
    p = decodeGroup(p, end, out + g * kGroup, kBits[control][code]);
    if (!p) return nullptr;
  }
  return p;
}

uint16_t unzigzag16(uint16_t v) {
  return static_cast<uint16_t>(-(v & 1) ^ (v >> 1));
}
uint8_t unzigzag8(uint8_t v) {
  return static_cast<uint8_t>(-(v & 1) ^ (v >> 1));
}
uint32_t rotate(uint32_t v, unsigned r) {
  return (v << r) | (v >> ((32 - r) & 31));
}

// Adds the block's deltas (deltas[k * aligned + i]: byte position k of element i) to the previous
// element, channel by channel (4 bytes each) by its mode: 0 bytes, 1 16-bit halves, 2 32-bit XOR
// with a rotation.
void applyDeltas(const unsigned char* deltas, size_t aligned, size_t elements, size_t stride,
                 const unsigned char* modes, unsigned char* last, unsigned char* out) {
  for (size_t i = 0; i < elements; ++i) {
    unsigned char* element = out + i * stride;
    for (size_t c = 0; c < stride / 4; ++c) {
      const unsigned mode = modes[c] & 15u;
      const unsigned char* d = deltas + 4 * c * aligned + i;
      unsigned char* v = last + 4 * c;
      if (mode == 0) {
        for (size_t b = 0; b < 4; ++b)
          v[b] = static_cast<unsigned char>(v[b] + unzigzag8(d[b * aligned]));
      } else if (mode == 1) {
        for (size_t h = 0; h < 2; ++h) {
          const uint16_t delta =
              static_cast<uint16_t>(d[2 * h * aligned] | d[(2 * h + 1) * aligned] << 8);
          const uint16_t prev = static_cast<uint16_t>(v[2 * h] | v[2 * h + 1] << 8);
          const uint16_t now = static_cast<uint16_t>(prev + unzigzag16(delta));
          v[2 * h] = static_cast<unsigned char>(now & 0xff);
          v[2 * h + 1] = static_cast<unsigned char>(now >> 8);
        }
      } else {
        uint32_t delta = 0, prev = 0;
        for (size_t b = 0; b < 4; ++b) {
          delta |= uint32_t(d[b * aligned]) << (8 * b);
          prev |= uint32_t(v[b]) << (8 * b);
        }
        const uint32_t now = prev ^ rotate(delta, modes[c] >> 4);
        for (size_t b = 0; b < 4; ++b) v[b] = static_cast<unsigned char>(now >> (8 * b));
      }
    }
    std::memcpy(element, last, stride);
  }
}

// Appendix B, filter 4: YCoCg with K-bit components, K from the alpha's top bit; 8- or 16-bit
// components (stride 4 or 8) decoded in place to normalized RGBA.
template <typename Signed, typename Unsigned>
void decodeColorFilter(unsigned char* data, size_t count) {
  const double int_max = double(Unsigned(~Unsigned(0)));
  for (size_t i = 0; i < count; ++i) {
    Signed in[4];
    std::memcpy(in, data + i * sizeof in, sizeof in);
    const unsigned alpha = static_cast<Unsigned>(in[3]);
    int msb = -1;
    for (int b = 0; b < int(8 * sizeof(Unsigned)); ++b) {
      if (alpha & (1u << b)) msb = b;
    }
    const int as = (1 << (msb + 1)) - 1;
    const int y = static_cast<Unsigned>(in[0]), co = in[1], cg = in[2];
    const int rgb[3] = {y + co - cg, y + cg, y - co - cg};
    int a = int(alpha) & (as >> 1);
    a = (a << 1) | (a & 1);
    const double ss = as > 0 ? int_max / double(as) : 0.0;
    Unsigned out[4];
    for (int c = 0; c < 3; ++c) {
      out[c] = static_cast<Unsigned>(std::clamp(std::round(double(rgb[c]) * ss), 0.0, int_max));
    }
    out[3] = static_cast<Unsigned>(std::clamp(std::round(double(a) * ss), 0.0, int_max));
    std::memcpy(data + i * sizeof out, out, sizeof out);
  }
}

const char* modeName(MeshoptView::Mode m) {
  switch (m) {
    case MeshoptView::Mode::kAttributes:
      return "ATTRIBUTES";
    case MeshoptView::Mode::kTriangles:
      return "TRIANGLES";
    default:
      return "INDICES";
  }
}

Status checkLayout(const MeshoptView& v, uint64_t view_byte_length, const std::string& file,
                   const std::string& place) {
  auto fail = [&](const std::string& what) { return inputError(file, place, what); };
  if (v.count == 0 || v.byte_stride == 0 || v.count > (uint64_t(1) << 40) / v.byte_stride ||
      v.count * v.byte_stride != view_byte_length) {
    return fail(fmt::format("count {} x byteStride {} must equal the buffer view's byteLength {}",
                            v.count, v.byte_stride, view_byte_length));
  }
  using M = MeshoptView::Mode;
  using F = MeshoptView::Filter;
  if (v.mode == M::kAttributes &&
      (v.byte_stride % 4 != 0 || v.byte_stride < 4 || v.byte_stride > 256)) {
    return fail(
        fmt::format("ATTRIBUTES need a byteStride that is a multiple of 4 from 4 to 256, "
                    "not {}",
                    v.byte_stride));
  }
  if (v.mode == M::kTriangles && v.count % 3 != 0) {
    return fail(fmt::format("TRIANGLES need a count divisible by 3, not {}", v.count));
  }
  if (v.mode != M::kAttributes && v.byte_stride != 2 && v.byte_stride != 4) {
    return fail(
        fmt::format("{} need a byteStride of 2 or 4, not {}", modeName(v.mode), v.byte_stride));
  }
  if (v.mode != M::kAttributes && v.filter != F::kNone) {
    return fail(fmt::format("{} take no filter", modeName(v.mode)));
  }
  const bool ok = v.filter == F::kNone ||
                  ((v.filter == F::kOctahedral || v.filter == F::kColor) &&
                   (v.byte_stride == 4 || v.byte_stride == 8)) ||
                  (v.filter == F::kQuaternion && v.byte_stride == 8) ||
                  (v.filter == F::kExponential && v.byte_stride % 4 == 0);
  if (!ok) return fail(fmt::format("the filter does not take a byteStride of {}", v.byte_stride));
  return {};
}

}  // namespace

bool decodeAttributesV1(unsigned char* out, size_t count, size_t stride, const unsigned char* data,
                        size_t size) {
  if (stride == 0 || stride % 4 != 0 || stride > 256 || size < 1 || data[0] != 0xa1) return false;
  const size_t channels = stride / 4;
  const size_t tail = std::max(stride + channels, size_t(24));
  if (size < 1 + tail) return false;
  const unsigned char* end = data + size - tail;
  const unsigned char* modes = data + size - channels;
  for (size_t c = 0; c < channels; ++c) {
    const unsigned mode = modes[c] & 15u;
    if (mode > 2 || (mode < 2 && (modes[c] >> 4) != 0)) return false;
  }
  unsigned char last[256];
  std::memcpy(last, data + size - channels - stride, stride);
  const size_t block_max = maxBlockElements(stride);
  std::vector<unsigned char> deltas(stride * block_max);
  const unsigned char* p = data + 1;
  for (size_t done = 0; done < count;) {
    const size_t elements = std::min(count - done, block_max);
    const size_t groups = (elements + kGroup - 1) / kGroup;
    const size_t aligned = groups * kGroup;
    if (size_t(end - p) < channels) return false;
    const unsigned char* control = p;
    p += channels;
    for (size_t k = 0; k < stride; ++k) {
      p = decodeByteDeltas(p, end, deltas.data() + k * aligned, elements, groups,
                           (control[k / 4] >> ((k % 4) * 2)) & 3u);
      if (!p) return false;
    }
    applyDeltas(deltas.data(), aligned, elements, stride, modes, last, out + done * stride);
    done += elements;
  }
  return p == end;
}

Expected<MeshoptView> readMeshoptView(const nlohmann::json& ext, bool khr,
                                      uint64_t view_byte_length, const std::string& file,
                                      const std::string& place) {
  MeshoptView v;
  auto unsigned_value = [&](const char* key, bool required, uint64_t& out) -> Status {
    if (!ext.contains(key)) {
      if (required) return inputError(file, place, fmt::format("'{}' is missing", key));
      return {};
    }
    const nlohmann::json& j = ext.at(key);
    if (!j.is_number_unsigned() && !(j.is_number_integer() && j.get<int64_t>() >= 0)) {
      return inputError(file, place + "." + key, "must be an integer >= 0");
    }
    out = j.get<uint64_t>();
    return {};
  };
  if (!ext.is_object()) return inputError(file, place, "must be an object");
  uint64_t buffer = 0;
  PENUMBRA_TRY(unsigned_value("buffer", true, buffer));
  if (buffer > uint64_t(1) << 31) return inputError(file, place + ".buffer", "does not exist");
  v.buffer = int64_t(buffer);
  PENUMBRA_TRY(unsigned_value("byteOffset", false, v.byte_offset));
  PENUMBRA_TRY(unsigned_value("byteLength", true, v.byte_length));
  PENUMBRA_TRY(unsigned_value("byteStride", true, v.byte_stride));
  PENUMBRA_TRY(unsigned_value("count", true, v.count));
  if (!ext.contains("mode") || !ext["mode"].is_string()) {
    return inputError(file, place + ".mode", "must be ATTRIBUTES, TRIANGLES or INDICES");
  }
  const std::string mode = ext["mode"].get<std::string>();
  if (mode == "ATTRIBUTES") {
    v.mode = MeshoptView::Mode::kAttributes;
  } else if (mode == "TRIANGLES") {
    v.mode = MeshoptView::Mode::kTriangles;
  } else if (mode == "INDICES") {
    v.mode = MeshoptView::Mode::kIndices;
  } else {
    return inputError(file, place + ".mode",
                      fmt::format("'{}' is not ATTRIBUTES, TRIANGLES or INDICES", mode));
  }
  const std::string filter =
      ext.contains("filter") && ext["filter"].is_string() ? ext["filter"].get<std::string>() : "";
  if (ext.contains("filter") && !ext["filter"].is_string()) {
    return inputError(file, place + ".filter", "must be a string");
  }
  using F = MeshoptView::Filter;
  if (filter.empty() || filter == "NONE") {
    v.filter = F::kNone;
  } else if (filter == "OCTAHEDRAL") {
    v.filter = F::kOctahedral;
  } else if (filter == "QUATERNION") {
    v.filter = F::kQuaternion;
  } else if (filter == "EXPONENTIAL") {
    v.filter = F::kExponential;
  } else if (filter == "COLOR" && khr) {
    v.filter = F::kColor;
  } else {
    return inputError(file, place + ".filter",
                      fmt::format("'{}' is not a filter of this extension", filter));
  }
  PENUMBRA_TRY(checkLayout(v, view_byte_length, file, place));
  return v;
}

Expected<std::string> decodeMeshoptView(const MeshoptView& view, std::string_view compressed,
                                        const std::string& file, const std::string& place) {
  const uint64_t bytes = view.count * view.byte_stride;
  PENUMBRA_TRY(checkMemory(bytes, fmt::format("{}: decoding {}", file, place)));
  std::string out(bytes, '\0');
  auto* dst = reinterpret_cast<unsigned char*>(out.data());
  const auto* src = reinterpret_cast<const unsigned char*>(compressed.data());
  const size_t n = size_t(view.count), stride = size_t(view.byte_stride);
  int rc = 0;
  switch (view.mode) {
    case MeshoptView::Mode::kAttributes:
      if (!compressed.empty() && src[0] == 0xa1) {
        rc = decodeAttributesV1(dst, n, stride, src, compressed.size()) ? 0 : -2;
      } else if (!compressed.empty() && src[0] != 0xa0) {
        return inputError(file, place,
                          fmt::format("the attribute stream's header 0x{:02x} is neither version 0 "
                                      "(0xa0) nor 1 (0xa1)",
                                      src[0]));
      } else {
        rc = meshopt_decodeVertexBuffer(dst, n, stride, src, compressed.size());
      }
      break;
    case MeshoptView::Mode::kTriangles:
      rc = meshopt_decodeIndexBuffer(dst, n, stride, src, compressed.size());
      break;
    case MeshoptView::Mode::kIndices:
      rc = meshopt_decodeIndexSequence(dst, n, stride, src, compressed.size());
      break;
  }
  if (rc != 0) {
    return inputError(file, place,
                      fmt::format("the compressed {} stream ({} bytes for {} elements of {} "
                                  "bytes) is malformed or cut short",
                                  modeName(view.mode), compressed.size(), n, stride));
  }
  switch (view.filter) {
    case MeshoptView::Filter::kOctahedral:
      meshopt_decodeFilterOct(dst, n, stride);
      break;
    case MeshoptView::Filter::kQuaternion:
      meshopt_decodeFilterQuat(dst, n, stride);
      break;
    case MeshoptView::Filter::kExponential:
      meshopt_decodeFilterExp(dst, n, stride);
      break;
    case MeshoptView::Filter::kColor:
      if (stride == 4) {
        decodeColorFilter<int8_t, uint8_t>(dst, n);
      } else {
        decodeColorFilter<int16_t, uint16_t>(dst, n);
      }
      break;
    case MeshoptView::Filter::kNone:
      break;
  }
  return out;
}

}  // namespace penumbra
