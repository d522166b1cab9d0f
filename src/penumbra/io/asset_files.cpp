#include "penumbra/io/asset_files.h"

#include <fmt/format.h>

#include <sys/stat.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

namespace penumbra {

namespace fs = std::filesystem;

namespace {

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// RFC 3986 sec. 3.1: scheme = ALPHA *( ALPHA / DIGIT / "+" / "-" / "." ), then ':', before any
// '/', '?' or '#'.
bool hasScheme(std::string_view uri) {
  const size_t colon = uri.find(':');
  if (colon == std::string_view::npos || colon == 0) return false;
  if (uri.find_first_of("/?#") < colon) return false;
  if (!std::isalpha(static_cast<unsigned char>(uri[0]))) return false;
  for (size_t i = 1; i < colon; ++i) {
    const unsigned char c = static_cast<unsigned char>(uri[i]);
    if (!std::isalnum(c) && c != '+' && c != '-' && c != '.') return false;
  }
  return true;
}

// The value of a base64 digit (RFC 4648 sec. 4), -1 for any other byte.
int base64Value(unsigned char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+') return 62;
  if (c == '/') return 63;
  return -1;
}

Expected<std::string> decodeBase64(std::string_view text, const std::string& file,
                                   const std::string& place) {
  while (!text.empty() && text.back() == '=') text.remove_suffix(1);
  if (text.size() % 4 == 1) {
    return inputError(file, place, "the data URI's base64 text is cut short");
  }
  std::string out;
  out.reserve(text.size() / 4 * 3 + 2);
  uint32_t acc = 0;
  int bits = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const int v = base64Value(static_cast<unsigned char>(text[i]));
    if (v < 0) {
      return inputError(file, place,
                        fmt::format("the data URI's base64 text holds a character that is not "
                                    "base64 (byte {} of the data)",
                                    i));
    }
    acc = (acc << 6) | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((acc >> bits) & 0xffu));
    }
  }
  return out;
}

// Whether the lexically normal relative path `rel` climbs out of its starting folder.
bool climbsOut(const fs::path& rel) {
  const fs::path normal = rel.lexically_normal();
  return !normal.empty() && *normal.begin() == "..";
}

// Whether `inner` (canonical) lies inside the folder `outer` (canonical).
bool isInside(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;  // a trailing separator
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

std::string outsideMessage(const std::string& what) {
  return fmt::format("{}: not read (--allow-outside-files reads it)", what);
}

}  // namespace

Expected<std::string> percentDecode(std::string_view uri, const std::string& file,
                                    const std::string& place) {
  std::string out;
  out.reserve(uri.size());
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] != '%') {
      out.push_back(uri[i]);
      continue;
    }
    const int hi = i + 2 < uri.size() ? hexValue(uri[i + 1]) : -1;
    const int lo = i + 2 < uri.size() ? hexValue(uri[i + 2]) : -1;
    if (hi < 0 || lo < 0) {
      return inputError(file, place,
                        fmt::format("uri '{}': '%' at byte {} is not followed by two hexadecimal "
                                    "digits (write a percent sign as %25)",
                                    uri, i));
    }
    // A NUL is data in a data URI; in a file name resolveAssetFile refuses it.
    out.push_back(static_cast<char>(hi * 16 + lo));
    i += 2;
  }
  return out;
}

std::string percentEncodePath(std::string_view path) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  out.reserve(path.size());
  for (const char ch : path) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~' || c == '/') {
      out.push_back(ch);
    } else {
      out.push_back('%');
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    }
  }
  return out;
}

bool isDataUri(std::string_view uri) {
  return uri.size() >= 5 && (uri[0] == 'd' || uri[0] == 'D') && (uri[1] == 'a' || uri[1] == 'A') &&
         (uri[2] == 't' || uri[2] == 'T') && (uri[3] == 'a' || uri[3] == 'A') && uri[4] == ':';
}

Expected<DataUri> decodeDataUri(std::string_view uri, uint64_t max_bytes, const std::string& file,
                                const std::string& place) {
  const size_t comma = uri.find(',');
  if (!isDataUri(uri) || comma == std::string_view::npos) {
    return inputError(file, place, "the data URI has no ',' before its data");
  }
  std::string header(uri.substr(5, comma - 5));
  for (char& c : header) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const std::string_view data = uri.substr(comma + 1);
  DataUri out;
  bool base64 = false;
  const size_t semicolon = header.find(';');
  out.media_type = header.substr(0, semicolon);
  if (semicolon != std::string::npos) {
    std::string_view params = std::string_view(header).substr(semicolon);
    base64 = params.size() >= 7 && params.substr(params.size() - 7) == ";base64";
  }
  const auto tooLarge = [&](uint64_t bytes) {
    return inputError(file, place,
                      fmt::format("the data URI holds about {} bytes, more than the {} it should",
                                  bytes, max_bytes));
  };
  if (base64) {
    // What the data decodes to, from its length (3 bytes per 4 digits, padding aside), before
    // any is decoded.
    size_t digits = data.size();
    while (digits > 0 && data[digits - 1] == '=') --digits;
    if (uint64_t(digits) * 3 / 4 > max_bytes) return tooLarge(uint64_t(digits) * 3 / 4);
    Expected<std::string> bytes = decodeBase64(data, file, place);
    if (!bytes) return bytes.error();
    out.bytes = std::move(*bytes);
  } else {
    // Percent-encoded data decodes to at most its own length (held already): measured after.
    Expected<std::string> bytes = percentDecode(data, file, place);
    if (!bytes) return bytes.error();
    if (bytes->size() > max_bytes) return tooLarge(bytes->size());
    out.bytes = std::move(*bytes);
  }
  return out;
}

Expected<std::string> resolveAssetFile(const std::string& asset_file, std::string_view uri,
                                       bool encoded, const AssetPolicy& policy,
                                       const std::string& place) {
  if (uri.empty()) return inputError(asset_file, place, "an empty uri names no file");
  std::string reference(uri);
  if (encoded) {
    if (hasScheme(uri) || uri.substr(0, 2) == "//") {
      return inputError(asset_file, place,
                        fmt::format("uri '{}' is not a file beside the asset: URLs and other "
                                    "schemes are not fetched",
                                    uri));
    }
    // RFC 3986 sec. 3.3: the path ends at a query ('?') or a fragment ('#'); a file name holding
    // either is written %3F or %23.
    reference = reference.substr(0, reference.find_first_of("?#"));
    Expected<std::string> decoded = percentDecode(reference, asset_file, place);
    if (!decoded) return decoded.error();
    reference = std::move(*decoded);
    if (reference.empty()) {
      return inputError(asset_file, place, fmt::format("uri '{}' names no file", uri));
    }
  }
  if (reference.find('\0') != std::string::npos) {
    return inputError(asset_file, place, "the file name holds a NUL byte");
  }
  const fs::path ref(reference);
  if (ref.is_absolute()) return confineAssetPath(asset_file, reference, policy, place);
  const fs::path folder = fs::path(asset_file).parent_path();
  if (climbsOut(ref) && !policy.allow_outside) {
    return inputError(
        asset_file, place,
        outsideMessage(fmt::format("'{}' climbs out of the asset's folder", reference)));
  }
  return confineAssetPath(asset_file, (folder / ref).lexically_normal().string(), policy, place);
}

Expected<std::string> confineAssetPath(const std::string& asset_file, const std::string& path,
                                       const AssetPolicy& policy, const std::string& place) {
  const fs::path joined = fs::path(path).lexically_normal();
  if (policy.allow_outside) return joined.string();
  // Compared as absolute paths: the asset may be named by an absolute path, and so its files.
  const fs::path folder = fs::path(asset_file).parent_path();
  const fs::path abs_folder = fs::absolute(folder.empty() ? fs::path(".") : folder);
  // Both normalised: a scene named '../asset/scene.gltf' has its files at '../asset/...'.
  if (climbsOut(fs::absolute(joined).lexically_normal().lexically_relative(
          abs_folder.lexically_normal()))) {
    return inputError(asset_file, place,
                      outsideMessage(fmt::format("'{}' lies outside the asset's folder", path)));
  }
  // A link inside the folder that points out of it: compared on the real paths.
  std::error_code ec;
  const fs::path real = fs::canonical(joined, ec);
  if (!ec) {
    std::error_code ec_dir;
    const fs::path real_folder = fs::canonical(folder.empty() ? fs::path(".") : folder, ec_dir);
    if (!ec_dir && !isInside(real, real_folder)) {
      return inputError(
          asset_file, place,
          outsideMessage(fmt::format("'{}' is a link to '{}', outside the asset's folder", path,
                                     real.string())));
    }
  }
  return joined.string();
}

Expected<uint64_t> assetFileSize(const std::string& asset_file, const std::string& path,
                                 const std::string& place) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    return inputError(asset_file, place,
                      err == ENOENT ? fmt::format("'{}': no such file", path)
                                    : fmt::format("'{}': {}", path, std::strerror(err)));
  }
  if (S_ISDIR(st.st_mode)) {
    return inputError(asset_file, place, fmt::format("'{}' is a directory, not a file", path));
  }
  if (!S_ISREG(st.st_mode)) {
    return inputError(asset_file, place,
                      fmt::format("'{}' is not a regular file (a FIFO, device or socket)", path));
  }
  return uint64_t(st.st_size);
}

}  // namespace penumbra
