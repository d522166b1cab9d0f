#include "penumbra/io/gltf/gltf_asset.h"

#include "penumbra/core/file_util.h"
#include "penumbra/io/gltf/gltf_extensions.h"
#include "penumbra/io/gltf/gltf_meshopt.h"
#include "penumbra/io/gltf_values.h"
#include "penumbra/io/json_guard.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

namespace penumbra {

using Json = nlohmann::json;

namespace {

uint32_t readLe32(std::string_view bytes, size_t at) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data() + at);
  return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
}

constexpr uint32_t kChunkJson = 0x4E4F534Au;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942u;   // "BIN\0"

uint64_t unsignedValue(const Json& obj, const char* key, uint64_t fallback = 0) {
  return obj.contains(key) ? obj.at(key).get<uint64_t>() : fallback;
}

// The image's file extension from its MIME type, for decoders that go by name (TGA).
std::string extensionForMime(const std::string& mime) {
  if (mime == "image/png") return ".png";
  if (mime == "image/jpeg") return ".jpg";
  if (mime == "image/webp") return ".webp";
  if (mime == "image/ktx2") return ".ktx2";
  return "";
}

// The meshopt extension of a buffer view, if any: its object and whether it is the KHR one.
const Json* meshoptExtension(const Json& view, bool& khr) {
  if (!view.contains("extensions") || !view["extensions"].is_object()) return nullptr;
  const Json& ext = view["extensions"];
  if (ext.contains("KHR_meshopt_compression")) {
    khr = true;
    return &ext["KHR_meshopt_compression"];
  }
  if (ext.contains("EXT_meshopt_compression")) {
    khr = false;
    return &ext["EXT_meshopt_compression"];
  }
  return nullptr;
}

}  // namespace

Expected<GltfAsset> GltfAsset::open(const std::string& path, const AssetPolicy& policy) {
  GltfAsset asset;
  asset.path_ = path;
  asset.policy_ = policy;
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  if (bytes->empty()) return inputError(path, "", "the file is empty");
  asset.file_ = std::make_unique<std::string>(std::move(*bytes));
  PENUMBRA_TRY(asset.readContainer());
  return asset;
}

Status GltfAsset::readContainer() {
  std::string_view text = *file_;
  if (file_->size() >= 4 && file_->compare(0, 4, "glTF") == 0) {
    // GLB (glTF 2.0 sec. 4.4): a 12-byte header, the JSON chunk, then optionally the BIN chunk.
    const std::string_view bytes = *file_;
    if (bytes.size() < 20) return inputError(path_, "GLB header", "the file is cut short");
    const uint32_t version = readLe32(bytes, 4);
    if (version != 2) {
      return inputError(path_, "GLB header",
                        fmt::format("GLB version {} is not supported (glTF 2.0 files are GLB "
                                    "version 2)",
                                    version));
    }
    if (readLe32(bytes, 8) != bytes.size()) {
      return inputError(path_, "GLB header",
                        fmt::format("the header gives a length of {} bytes, the file has {}",
                                    readLe32(bytes, 8), bytes.size()));
    }
    const uint64_t json_length = readLe32(bytes, 12);
    if (readLe32(bytes, 16) != kChunkJson) {
      return inputError(path_, "GLB header", "the first chunk is not JSON");
    }
    if (json_length > bytes.size() - 20) {
      return inputError(path_, "GLB JSON chunk",
                        fmt::format("its length {} runs past the end of the file", json_length));
    }
    text = bytes.substr(20, json_length);
    // The BIN chunk follows, the JSON chunk padded to 4 bytes.
    const uint64_t next = 20 + (json_length + 3) / 4 * 4;
    if (next + 8 <= bytes.size() && readLe32(bytes, next + 4) == kChunkBin) {
      const uint64_t bin_length = readLe32(bytes, next);
      if (bin_length > bytes.size() - next - 8) {
        return inputError(path_, "GLB BIN chunk",
                          fmt::format("its length {} runs past the end of the file", bin_length));
      }
      bin_chunk_ = bytes.substr(next + 8, bin_length);
      has_bin_chunk_ = true;
    }
  }
  return parse(text);
}

Status GltfAsset::parse(std::string_view text) {
  PENUMBRA_TRY(checkJsonNesting(path_, text, /*comments=*/false));
  try {
    json_ = Json::parse(text);
  } catch (const Json::parse_error& e) {
    std::string message = e.what();
    const size_t colon = message.find(": ", message.find("parse error"));
    if (colon != std::string::npos) message = message.substr(colon + 2);
    return inputError(path_, lineAndColumn(text, e.byte > 0 ? e.byte - 1 : 0),
                      fmt::format("not a valid glTF 2.0 file: JSON {}", message));
  }
  if (!json_.is_object()) {
    return inputError(path_, "", "not a valid glTF 2.0 file: the JSON is not an object");
  }
  if (!json_.contains("asset") || !json_["asset"].is_object() ||
      !json_["asset"].contains("version")) {
    return inputError(path_, "asset.version", "is missing: not a glTF 2.0 file");
  }
  const Json& v = json_["asset"]["version"];
  const std::string version = v.is_string() ? v.get<std::string>() : v.dump();
  if (version.rfind("2.", 0) != 0) {
    return inputError(path_, "asset.version",
                      fmt::format("'{}': only glTF 2.0 is supported", version));
  }
  PENUMBRA_TRY(checkRequiredExtensions(path_, json_));
  PENUMBRA_TRY(checkGltfValues(path_, json_));
  return checkViewRanges();
}

// glTF 2.0 sec. 3.6.1: every buffer view lies inside the byteLength its buffer declares (and a
// meshopt view's compressed range inside its own buffer's), checked on the JSON before anything
// is read, whether or not the view is used.
Status GltfAsset::checkViewRanges() const {
  const size_t buffers = count("buffers");
  auto inside = [&](const Json& v, const std::string& place) -> Status {
    const int64_t b = v.at("buffer").get<int64_t>();
    if (b < 0 || size_t(b) >= buffers) {
      return inputError(path_, place,
                        fmt::format("buffer {} does not exist (the file has {})", b, buffers));
    }
    const uint64_t length = unsignedValue(json_["buffers"][size_t(b)], "byteLength");
    const uint64_t offset = unsignedValue(v, "byteOffset"), size = unsignedValue(v, "byteLength");
    if (offset > length || size > length - offset) {
      return inputError(path_, place,
                        fmt::format("byteOffset {} + byteLength {} lie outside buffer {} ({} "
                                    "bytes)",
                                    offset, size, b, length));
    }
    return {};
  };
  for (size_t i = 0; i < count("bufferViews"); ++i) {
    const Json& v = json_["bufferViews"][i];
    const std::string place = fmt::format("bufferViews[{}]", i);
    PENUMBRA_TRY(inside(v, place));
    bool khr = false;
    if (const Json* ext = meshoptExtension(v, khr)) {
      if (!ext->is_object() || !ext->contains("buffer") || !(*ext)["buffer"].is_number_integer()) {
        continue;  // readMeshoptView names what is wrong when the view is read
      }
      PENUMBRA_TRY(inside(*ext, place + (khr ? ".extensions.KHR_meshopt_compression"
                                             : ".extensions.EXT_meshopt_compression")));
    }
  }
  return {};
}

size_t GltfAsset::count(const char* key) const {
  return json_.contains(key) && json_[key].is_array() ? json_[key].size() : 0;
}

Expected<const Json*> GltfAsset::entry(const char* key, int64_t index,
                                       const std::string& place) const {
  const size_t n = count(key);
  if (index < 0 || uint64_t(index) >= n) {
    std::string singular(key);
    if (!singular.empty() && singular.back() == 's') singular.pop_back();
    return inputError(path_, place,
                      fmt::format("{} {} does not exist (the file has {})", singular, index, n));
  }
  return &json_[key][size_t(index)];
}

Expected<std::string_view> GltfAsset::buffer(int64_t index, const std::string& place) {
  Expected<const Json*> b = entry("buffers", index, place);
  if (!b) return b.error();
  auto it = buffers_.find(size_t(index));
  if (it != buffers_.end()) return it->second;
  Expected<std::string_view> bytes = readBuffer(size_t(index), place);
  if (bytes) buffers_[size_t(index)] = *bytes;
  return bytes;
}

Expected<std::string_view> GltfAsset::readBuffer(size_t index, const std::string& place) {
  const Json& b = json_["buffers"][index];
  const std::string where = fmt::format("buffers[{}]", index);
  const uint64_t length = unsignedValue(b, "byteLength");
  auto short_of = [&](uint64_t have, const std::string& what) {
    return inputError(path_, where,
                      fmt::format("byteLength is {} but {} holds {} bytes", length, what, have));
  };
  if (!b.contains("uri")) {
    if (index == 0 && has_bin_chunk_) {
      // The BIN chunk may carry up to 3 bytes of padding past byteLength.
      if (bin_chunk_.size() < length) return short_of(bin_chunk_.size(), "the GLB's BIN chunk");
      return bin_chunk_.substr(0, length);
    }
    const bool fallback = b.contains("extensions") && b["extensions"].is_object() &&
                          (b["extensions"].contains("EXT_meshopt_compression") ||
                           b["extensions"].contains("KHR_meshopt_compression"));
    return inputError(path_, place,
                      fallback ? fmt::format("{} is a meshopt fallback buffer without data, read "
                                             "by a buffer view that is not compressed",
                                             where)
                               : fmt::format("{} has no uri and is not the GLB's binary chunk: it "
                                             "holds no data",
                                             where));
  }
  const std::string uri = b["uri"].get<std::string>();
  auto owned = std::make_unique<std::string>();
  if (isDataUri(uri)) {
    Expected<DataUri> data = decodeDataUri(uri, length, path_, where);
    if (!data) return data.error();
    if (data->bytes.size() < length) return short_of(data->bytes.size(), "its data URI");
    *owned = std::move(data->bytes);
  } else {
    Expected<std::string> file = resolveAssetFile(path_, uri, true, policy_, where);
    if (!file) return file.error();
    Expected<uint64_t> size = assetFileSize(path_, *file, where);
    if (!size) return size.error();
    if (*size < length) return short_of(*size, fmt::format("'{}'", *file));
    Expected<std::string> bytes = readFile(*file, length);
    if (!bytes) return bytes.error();
    if (bytes->size() < length) return short_of(bytes->size(), fmt::format("'{}'", *file));
    *owned = std::move(*bytes);
  }
  owned->resize(length);
  storage_.push_back(std::move(owned));
  return std::string_view(*storage_.back());
}

Expected<std::string_view> GltfAsset::bufferView(int64_t index, const std::string& place) {
  Expected<const Json*> entry_json = entry("bufferViews", index, place);
  if (!entry_json) return entry_json.error();
  auto it = views_.find(size_t(index));
  if (it != views_.end()) return it->second;
  const Json& v = **entry_json;
  const std::string where = fmt::format("bufferViews[{}]", index);
  const uint64_t offset = unsignedValue(v, "byteOffset"), length = unsignedValue(v, "byteLength");
  bool khr = false;
  if (const Json* ext = meshoptExtension(v, khr)) {
    const std::string ext_place = where + (khr ? ".extensions.KHR_meshopt_compression"
                                               : ".extensions.EXT_meshopt_compression");
    Expected<MeshoptView> m = readMeshoptView(*ext, khr, length, path_, ext_place);
    if (!m) return m.error();
    Expected<std::string_view> source = buffer(m->buffer, ext_place);
    if (!source) return source.error();
    if (m->byte_offset > source->size() || m->byte_length > source->size() - m->byte_offset) {
      return inputError(path_, ext_place,
                        fmt::format("byteOffset {} + byteLength {} lie outside buffer {} ({} "
                                    "bytes)",
                                    m->byte_offset, m->byte_length, m->buffer, source->size()));
    }
    Expected<std::string> decoded =
        decodeMeshoptView(*m, source->substr(m->byte_offset, m->byte_length), path_, ext_place);
    if (!decoded) return decoded.error();
    storage_.push_back(std::make_unique<std::string>(std::move(*decoded)));
    return views_[size_t(index)] = std::string_view(*storage_.back());
  }
  Expected<std::string_view> b = buffer(v.at("buffer").get<int64_t>(), where);
  if (!b) return b.error();
  if (offset > b->size() || length > b->size() - offset) {
    return inputError(path_, place,
                      fmt::format("bufferView {} (byteOffset {}, byteLength {}) lies outside "
                                  "buffer {} ({} bytes)",
                                  index, offset, length, v.at("buffer").get<int64_t>(), b->size()));
  }
  return views_[size_t(index)] = b->substr(offset, length);
}

Expected<GltfAsset::ImageSource> GltfAsset::imageSource(int64_t index, const std::string& place) {
  Expected<const Json*> entry_json = entry("images", index, place);
  if (!entry_json) return entry_json.error();
  const Json& image = **entry_json;
  const std::string where = place.empty() ? fmt::format("images[{}]", index)
                                          : fmt::format("{} (images[{}])", place, index);
  ImageSource s;
  const std::string mime = image.value("mimeType", std::string());
  s.extension = extensionForMime(mime);
  s.name = fmt::format("{} image {}", path_, index);
  if (image.contains("uri") && image.contains("bufferView")) {
    return inputError(path_, where, "has both a uri and a bufferView (glTF 2.0 sec. 5.17)");
  }
  if (image.contains("uri")) {
    const std::string uri = image["uri"].get<std::string>();
    if (isDataUri(uri)) {
      s.bytes = uri.size() / 4 * 3;
      return s;
    }
    Expected<std::string> file = resolveAssetFile(path_, uri, true, policy_, where);
    if (!file) return file.error();
    Expected<uint64_t> size = assetFileSize(path_, *file, where);
    if (!size) return size.error();
    if (*size == 0) return inputError(path_, where, fmt::format("'{}' is an empty file", *file));
    s.file = *file;
    s.name = *file;
    s.bytes = *size;
    const std::string ext = extensionOf(*file);
    if (!ext.empty()) s.extension = ext;
    return s;
  }
  if (!image.contains("bufferView")) {
    return inputError(path_, where, "has neither a uri nor a bufferView");
  }
  Expected<const Json*> view = entry("bufferViews", image["bufferView"].get<int64_t>(), where);
  if (!view) return view.error();
  if ((*view)->contains("byteStride")) {
    return inputError(path_, where,
                      "its buffer view has a byteStride: an image's bytes are one run (glTF 2.0 "
                      "sec. 3.6.1.2)");
  }
  s.bytes = unsignedValue(**view, "byteLength");
  return s;
}

Expected<std::string_view> GltfAsset::imageBytes(int64_t index, const std::string& place) {
  auto it = images_.find(size_t(index));
  if (it != images_.end()) return it->second;
  Expected<ImageSource> source = imageSource(index, place);
  if (!source) return source.error();
  const Json& image = json_["images"][size_t(index)];
  const std::string where = place.empty() ? fmt::format("images[{}]", index)
                                          : fmt::format("{} (images[{}])", place, index);
  std::string_view bytes;
  if (!source->file.empty()) {
    Expected<std::string> read = readFile(source->file);
    if (!read) return read.error();
    if (read->empty()) {
      return inputError(path_, where, fmt::format("'{}' is an empty file", source->file));
    }
    storage_.push_back(std::make_unique<std::string>(std::move(*read)));
    bytes = *storage_.back();
  } else if (image.contains("uri")) {
    const std::string uri = image["uri"].get<std::string>();
    Expected<DataUri> data = decodeDataUri(uri, uri.size(), path_, where);
    if (!data) return data.error();
    if (data->bytes.empty()) return inputError(path_, where, "the data URI holds no bytes");
    storage_.push_back(std::make_unique<std::string>(std::move(data->bytes)));
    bytes = *storage_.back();
  } else {
    Expected<std::string_view> view = bufferView(image["bufferView"].get<int64_t>(), where);
    if (!view) return view.error();
    bytes = *view;
  }
  return images_[size_t(index)] = bytes;
}

uint64_t GltfAsset::heldBytes() const {
  uint64_t total = file_ ? file_->size() : 0;
  for (const std::unique_ptr<std::string>& s : storage_) total += s->size();
  return total;
}

}  // namespace penumbra
