// Files an asset names: a glTF file's buffers and images, an OBJ file's material libraries and
// their textures. Penumbra resolves and reads them itself (design doc sec. 5, "Reading files from
// the web"); a parser library gets bytes, never paths. Rules:
//   - a reference is a URI reference (RFC 3986): it is percent-decoded (sec. 2.1; '+' is a plus,
//     not a space) and resolved against the folder of the asset that names it, made absolute, so
//     the current directory never takes part;
//   - data: URIs (RFC 2397) hold their bytes; any other scheme (http:, file:) and network paths
//     ("//host/...") fetch nothing and are refused;
//   - an absolute path, or one that leaves the asset's folder (by "..", or through a symbolic link
//     that points out of it), is refused unless the user allows it (--allow-outside-files): a
//     downloaded file must not copy the host's files into a bake;
//   - only regular files are read (core/file_util.h: readFile), their size known before.
#pragma once

#include "penumbra/core/expected.h"

#include <cstdint>
#include <string>
#include <string_view>

namespace penumbra {

struct AssetPolicy {
  // Whether files outside the asset's folder (absolute paths, "..", links out of it) are read.
  bool allow_outside = false;
};

// RFC 3986 sec. 2.1: every "%XY" becomes the byte 0xXY; '+' stays. Refused: a '%' without two
// hexadecimal digits after it, and an encoded NUL ("%00"), which no file name holds. Errors name
// `file` and `place`.
Expected<std::string> percentDecode(std::string_view uri, const std::string& file,
                                    const std::string& place);

// A relative path as a URI reference: each byte other than RFC 3986's unreserved characters
// (ALPHA DIGIT - . _ ~) and the separator '/' is percent-encoded ("a b#1%.png" ->
// "a%20b%231%25.png"), so that the name reads back as itself in Penumbra, browsers and three.js.
std::string percentEncodePath(std::string_view path);

// RFC 2397: "data:[<mediatype>][;base64],<data>".
bool isDataUri(std::string_view uri);
struct DataUri {
  std::string media_type;  // "image/png", lower case; "" when absent
  std::string bytes;
};
// Decodes a data URI: base64 (RFC 4648 sec. 4, padding optional, no other characters) or, without
// ";base64", percent-encoded text. Refused before decoding when it would hold more than
// `max_bytes`.
Expected<DataUri> decodeDataUri(std::string_view uri, uint64_t max_bytes, const std::string& file,
                                const std::string& place);

// The file that `uri` (a URI reference in `asset_file`, percent-encoded when `encoded`: glTF URIs
// are, OBJ and MTL file names are not) names, by the rules above. The path returned is the
// asset's folder (as `asset_file` gives it) joined with the decoded reference, lexically
// normalised; errors name `asset_file` and `place` ("images[3]").
Expected<std::string> resolveAssetFile(const std::string& asset_file, std::string_view uri,
                                       bool encoded, const AssetPolicy& policy,
                                       const std::string& place);

// `path` (a file an asset names, already joined with a folder of the asset's, or absolute) when
// the policy lets the asset read it: inside the folder of `asset_file`, lexically and through
// links, unless policy.allow_outside. Errors name `asset_file` and `place`.
Expected<std::string> confineAssetPath(const std::string& asset_file, const std::string& path,
                                       const AssetPolicy& policy, const std::string& place);

// The size of the regular file at `path` (following links), or an input error naming `asset_file`,
// `place` and `path`: missing ("no such file"), not a regular file, or unreadable.
Expected<uint64_t> assetFileSize(const std::string& asset_file, const std::string& path,
                                 const std::string& place);

}  // namespace penumbra
