// The glTF extensions Penumbra knows, and what it does with each (docs/scene-format.md, "glTF
// 2.0"): read, read through a fallback the file carries, or not implemented. A file that
// requires an extension not read is refused by name before anything else is read; one that only
// uses it loads with one warning per extension saying what it would have changed.
#pragma once

#include "penumbra/core/expected.h"

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

enum class ExtensionSupport {
  kRead,      // implemented
  kFallback,  // an image format without a decoder: the texture's fallback image is read
  kMetadata,  // changes nothing Penumbra computes (licences, XMP)
  kIgnored,   // not implemented: what it changes is left out
};

struct GltfExtensionInfo {
  std::string_view name;
  ExtensionSupport support;
  // kFallback, kIgnored: what the extension would have changed ("a clear coat's specular
  // reflection"); kRead: how it is read, for `penumbra info`.
  std::string_view effect;
};

// The entry for `name`, or null for an extension Penumbra does not know.
const GltfExtensionInfo* gltfExtension(std::string_view name);

// Refuses a document whose extensionsRequired names an extension that is not read (kFallback ones
// are decided per texture: a texture without a fallback image is refused where it is used).
Status checkRequiredExtensions(const std::string& path, const nlohmann::json& root);

// One warning per extension in extensionsUsed that is not read or not known.
std::vector<std::string> extensionWarnings(const std::string& path, const nlohmann::json& root);

}  // namespace penumbra
