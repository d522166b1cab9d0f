// A glTF 2.0 asset as read from disk: its JSON and, on demand, the bytes of its buffers, buffer
// views and images. Penumbra reads every file itself (io/asset_files.h): buffers and images are
// read when first asked for, so an image no texture uses is never read, and a buffer no accessor
// uses neither. Checked before any pointer is taken:
//   - the GLB container (glTF 2.0 sec. 4.4): header, chunk lengths, the BIN chunk;
//   - each buffer's bytes against its byteLength (a data URI or file at least that long);
//   - each buffer view's byteOffset + byteLength inside its buffer;
//   - EXT_meshopt_compression and KHR_meshopt_compression views (io/gltf/gltf_meshopt.h) are
//     decoded into their own storage; their fallback buffers, which may have no bytes at all, are
//     never read.
// The JSON's values have been checked against the schema (io/gltf_values.h) and the extensions it
// requires against what Penumbra implements (io/gltf/gltf_extensions.h) when open() returns.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/asset_files.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

// `obj[key]` when `obj` is an object holding it, else `fallback` (a member that may be absent;
// its type was checked by checkGltfValues).
template <typename T>
T valueOr(const nlohmann::json& obj, const char* key, T fallback) {
  return obj.is_object() && obj.contains(key) ? obj.at(key).get<T>() : fallback;
}

// `obj[key]`, or null when `obj` is not an object holding it.
inline const nlohmann::json& member(const nlohmann::json& obj, const char* key) {
  static const nlohmann::json kNull;
  return obj.is_object() && obj.contains(key) ? obj.at(key) : kNull;
}

class GltfAsset {
 public:
  // Reads and checks the .gltf or .glb file at `path`.
  static Expected<GltfAsset> open(const std::string& path, const AssetPolicy& policy);

  const std::string& path() const { return path_; }
  const nlohmann::json& json() const { return json_; }
  const AssetPolicy& policy() const { return policy_; }

  // The number of entries of a top-level array ("accessors"), 0 when absent.
  size_t count(const char* key) const;
  // Entry `index` of a top-level array; an input error at `place` when it does not exist.
  Expected<const nlohmann::json*> entry(const char* key, int64_t index,
                                        const std::string& place) const;

  // The bytes of buffer `index` (read on first use), exactly byteLength long; `place` names the
  // use in messages.
  Expected<std::string_view> buffer(int64_t index, const std::string& place);
  // The bytes of buffer view `index`: its range of its buffer, or its decoded data when a meshopt
  // extension compresses it.
  Expected<std::string_view> bufferView(int64_t index, const std::string& place);

  // Where an image's bytes come from, known without reading them.
  struct ImageSource {
    std::string name;       // for messages and sharing: the file, or "<asset> image N"
    std::string file;       // the file to read, empty for a data URI or a buffer view
    std::string extension;  // ".png", ".jpg" ... of the file name, or from the MIME type
    uint64_t bytes = 0;     // the size to be read
  };
  Expected<ImageSource> imageSource(int64_t index, const std::string& place);
  // The image's bytes, read on first use (a file read once however many textures use it).
  Expected<std::string_view> imageBytes(int64_t index, const std::string& place);

  // Bytes held for the asset so far (file, buffers, decoded views, images).
  uint64_t heldBytes() const;

 private:
  GltfAsset() = default;
  Status parse(std::string_view text);
  Status readContainer();
  Status checkViewRanges() const;
  Expected<std::string_view> readBuffer(size_t index, const std::string& place);

  std::string path_;
  AssetPolicy policy_;
  std::unique_ptr<std::string> file_;  // the .gltf or .glb as read
  std::string_view bin_chunk_;         // the GLB's BIN chunk, if any
  bool has_bin_chunk_ = false;
  nlohmann::json json_;
  // What has been read or decoded; the views point into file_ or storage_, which never move.
  std::map<size_t, std::string_view> buffers_;
  std::map<size_t, std::string_view> views_;
  std::map<size_t, std::string_view> images_;
  std::vector<std::unique_ptr<std::string>> storage_;
};

}  // namespace penumbra
