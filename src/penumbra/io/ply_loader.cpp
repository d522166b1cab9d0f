// PLY loading (ASCII, binary little- and big-endian).
//
// The file is read in one walk (header, then every element of the body, value by value): vertex i
// and face j are the file's, with nothing merged or reordered. Polygons are fan-triangulated
// (v0 v1 v2, v0 v2 v3, ...), points and lines are skipped with a warning. The walk checks what it
// reads: truncation, non-finite coordinates, list lengths outside their type, out-of-range
// indices, each named by vertex or face (and the line in an ASCII file). Positions come from
// x/y/z, normals from nx/ny/nz, texture coordinates from u/v (or s/t, texture_u/texture_v,
// texture_s/texture_t); every other property is read and ignored.
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/io/scene_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

namespace {

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

enum class PlyType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

std::optional<PlyType> plyType(std::string_view s) {
  if (s == "char" || s == "int8") return PlyType::kInt8;
  if (s == "uchar" || s == "uint8") return PlyType::kUInt8;
  if (s == "short" || s == "int16") return PlyType::kInt16;
  if (s == "ushort" || s == "uint16") return PlyType::kUInt16;
  if (s == "int" || s == "int32") return PlyType::kInt32;
  if (s == "uint" || s == "uint32") return PlyType::kUInt32;
  if (s == "float" || s == "float32") return PlyType::kFloat32;
  if (s == "double" || s == "float64") return PlyType::kFloat64;
  return std::nullopt;
}

size_t sizeOf(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUInt8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUInt16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUInt32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 1;
}

// The largest value an integer type holds (lists' counts).
double largestValue(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
      return 127.0;
    case PlyType::kUInt8:
      return 255.0;
    case PlyType::kInt16:
      return 32767.0;
    case PlyType::kUInt16:
      return 65535.0;
    case PlyType::kInt32:
      return 2147483647.0;
    case PlyType::kUInt32:
      return 4294967295.0;
    default:
      return 0.0;  // counts are integers (checked in the header)
  }
}

struct PlyProperty {
  std::string name;
  bool is_list = false;
  PlyType count_type = PlyType::kUInt8;  // lists only
  PlyType type = PlyType::kFloat32;
};

struct PlyElement {
  std::string name;
  size_t count = 0;
  std::vector<PlyProperty> properties;
};

std::vector<std::string_view> splitWords(std::string_view line) {
  std::vector<std::string_view> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

// Reads the body value by value, from ASCII tokens or binary bytes, tracking the place.
class PlyBodyReader {
 public:
  PlyBodyReader(const std::string& text, size_t offset, PlyFormat format, size_t first_line)
      : text_(text), pos_(offset), format_(format), line_(first_line) {}

  // False at the end of the data or, for ASCII, when the token is not a number.
  bool next(PlyType type, double* value, std::string* bad_token) {
    if (format_ == PlyFormat::kAscii) {
      while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) {
        if (text_[pos_] == '\n') ++line_;
        ++pos_;
      }
      if (pos_ >= text_.size()) return false;
      const size_t start = pos_;
      while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
      const std::string token = text_.substr(start, pos_ - start);
      char* end = nullptr;
      *value = std::strtod(token.c_str(), &end);
      if (end != token.c_str() + token.size()) {
        *bad_token = token;
        return false;
      }
      return true;
    }
    const size_t n = sizeOf(type);
    if (n > text_.size() - pos_) {
      pos_ = text_.size();
      return false;
    }
    unsigned char b[8];
    std::memcpy(b, text_.data() + pos_, n);
    pos_ += n;
    const bool swap =
        (format_ == PlyFormat::kBinaryBig) == (std::endian::native == std::endian::little);
    if (swap) {
      for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    }
    switch (type) {
      case PlyType::kInt8:
        *value = static_cast<int8_t>(b[0]);
        break;
      case PlyType::kUInt8:
        *value = b[0];
        break;
      case PlyType::kInt16: {
        int16_t v;
        std::memcpy(&v, b, 2);
        *value = v;
        break;
      }
      case PlyType::kUInt16: {
        uint16_t v;
        std::memcpy(&v, b, 2);
        *value = v;
        break;
      }
      case PlyType::kInt32: {
        int32_t v;
        std::memcpy(&v, b, 4);
        *value = v;
        break;
      }
      case PlyType::kUInt32: {
        uint32_t v;
        std::memcpy(&v, b, 4);
        *value = v;
        break;
      }
      case PlyType::kFloat32: {
        float v;
        std::memcpy(&v, b, 4);
        *value = v;
        break;
      }
      case PlyType::kFloat64: {
        double v;
        std::memcpy(&v, b, 8);
        *value = v;
        break;
      }
    }
    return true;
  }

  bool ascii() const { return format_ == PlyFormat::kAscii; }
  size_t line() const { return line_; }

 private:
  const std::string& text_;
  size_t pos_;
  PlyFormat format_;
  size_t line_;
};

// What the walk over the file found.
struct PlyScan {
  size_t vertices = 0;
  size_t faces = 0;
  size_t points_and_lines = 0;
  Mesh mesh;  // positions, normals and uvs as the file holds them; triangles fanned
};

// Where a vertex property goes: a position, normal or texture coordinate component, or nowhere.
enum class VertexSlot { kNone, kX, kY, kZ, kNx, kNy, kNz, kU, kV };

VertexSlot vertexSlot(const std::string& name) {
  if (name == "x") return VertexSlot::kX;
  if (name == "y") return VertexSlot::kY;
  if (name == "z") return VertexSlot::kZ;
  if (name == "nx") return VertexSlot::kNx;
  if (name == "ny") return VertexSlot::kNy;
  if (name == "nz") return VertexSlot::kNz;
  if (name == "u" || name == "s" || name == "texture_u" || name == "texture_s") {
    return VertexSlot::kU;
  }
  if (name == "v" || name == "t" || name == "texture_v" || name == "texture_t") {
    return VertexSlot::kV;
  }
  return VertexSlot::kNone;
}

// The header: the body's format, the elements with their properties, and where the body starts.
struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t body = 0;   // offset of the body's first byte
  size_t lines = 0;  // the header's lines, 'end_header' included
};

// "format <type> <version>", once.
Status readPlyFormat(const std::string& path, const std::string& place,
                     const std::vector<std::string_view>& w, std::optional<PlyFormat>& format) {
  if (w.size() != 3) return inputError(path, place, "'format' needs a type and a version");
  if (format) return inputError(path, place, "a second 'format' line");
  if (w[1] == "ascii") {
    format = PlyFormat::kAscii;
  } else if (w[1] == "binary_little_endian") {
    format = PlyFormat::kBinaryLittle;
  } else if (w[1] == "binary_big_endian") {
    format = PlyFormat::kBinaryBig;
  } else {
    return inputError(path, place, fmt::format("unknown format '{}'", w[1]));
  }
  return {};
}

// "element <name> <count>": a new element, its name not used before.
Status readPlyElement(const std::string& path, const std::string& place,
                      const std::vector<std::string_view>& w, std::vector<PlyElement>& elements) {
  if (w.size() != 3) return inputError(path, place, "'element' needs a name and a count");
  PlyElement e;
  e.name = std::string(w[1]);
  for (const PlyElement& other : elements) {
    if (other.name == e.name) {
      return inputError(path, place, fmt::format("a second element '{}'", e.name));
    }
  }
  const std::string count(w[2]);
  char* end = nullptr;
  errno = 0;
  const unsigned long long n = std::strtoull(count.c_str(), &end, 10);
  if (end != count.c_str() + count.size() || errno != 0 || count[0] == '-') {
    return inputError(path, place, fmt::format("element count '{}' is not a number", count));
  }
  e.count = static_cast<size_t>(n);
  elements.push_back(std::move(e));
  return {};
}

// "property <type> <name>" or "property list <count type> <type> <name>", of the last element.
Status readPlyProperty(const std::string& path, const std::string& place,
                       const std::vector<std::string_view>& w, std::vector<PlyElement>& elements) {
  if (elements.empty()) return inputError(path, place, "'property' before any 'element'");
  PlyProperty p;
  if (w.size() == 5 && w[1] == "list") {
    const auto ct = plyType(w[2]), it = plyType(w[3]);
    if (!ct || !it) return inputError(path, place, "unknown property type");
    if (*ct == PlyType::kFloat32 || *ct == PlyType::kFloat64) {
      return inputError(path, place, "a list count must be an integer type");
    }
    p.is_list = true;
    p.count_type = *ct;
    p.type = *it;
    p.name = std::string(w[4]);
  } else if (w.size() == 3) {
    const auto t = plyType(w[1]);
    if (!t) return inputError(path, place, fmt::format("unknown property type '{}'", w[1]));
    p.type = *t;
    p.name = std::string(w[2]);
  } else {
    return inputError(path, place, "malformed 'property' line");
  }
  elements.back().properties.push_back(std::move(p));
  return {};
}

// The header, line by line up to 'end_header'.
Status readPlyHeader(const std::string& path, const std::string& text, PlyHeader& header) {
  if (text.compare(0, 3, "ply") != 0 || text.size() < 4 || (text[3] != '\n' && text[3] != '\r')) {
    return inputError(path, "line 1", "not a PLY file (it does not start with 'ply')");
  }
  std::optional<PlyFormat> format;
  size_t pos = 0, line_no = 0;
  bool ended = false;
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    const std::string_view line(text.data() + pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    const std::string place = fmt::format("line {}", line_no);
    // The header is text: printable ASCII, spaces and tabs.
    for (char c : line) {
      const auto u = static_cast<unsigned char>(c);
      if ((u < 0x20 && c != '\t' && c != '\r') || u > 0x7e) {
        return inputError(path, place, "the header holds a byte that is not text");
      }
    }
    const std::vector<std::string_view> w = splitWords(line);
    if (line_no == 1 || w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "end_header") {
      ended = true;
      break;
    }
    if (w[0] == "format") {
      PENUMBRA_TRY(readPlyFormat(path, place, w, format));
    } else if (w[0] == "element") {
      PENUMBRA_TRY(readPlyElement(path, place, w, header.elements));
    } else if (w[0] == "property") {
      PENUMBRA_TRY(readPlyProperty(path, place, w, header.elements));
    } else {
      return inputError(path, place, fmt::format("unknown header keyword '{}'", w[0]));
    }
  }
  if (!ended) return inputError(path, "header", "no 'end_header' (the file is truncated?)");
  if (!format) return inputError(path, "header", "no 'format' line");
  header.format = *format;
  header.body = pos;
  header.lines = line_no;
  return {};
}

// The 'vertex' element, with one scalar x, y and z; every 'face' element with entries has
// vertex indices, and there are no 'tristrips'.
Expected<const PlyElement*> findPlyVertices(const std::string& path,
                                            const std::vector<PlyElement>& elements) {
  const PlyElement* vertex_element = nullptr;
  for (const PlyElement& e : elements) {
    if (e.name == "vertex") vertex_element = &e;
    if (e.name == "tristrips") {
      return inputError(path, "header", "'tristrips' elements are not supported");
    }
  }
  if (!vertex_element) return inputError(path, "header", "no 'vertex' element");
  for (const PlyElement& e : elements) {
    if (e.name != "face" || e.count == 0) continue;
    bool indices = false;
    for (const PlyProperty& p : e.properties) {
      indices = indices || (p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index"));
    }
    if (!indices) {
      return inputError(path, "header", "the 'face' element has no 'vertex_indices' list");
    }
  }
  // Positions need x, y and z, each once and not a list.
  for (const char* axis : {"x", "y", "z"}) {
    int found = 0;
    for (const PlyProperty& p : vertex_element->properties) {
      if (p.name == axis) found += p.is_list ? 2 : 1;
    }
    if (found != 1) {
      return inputError(path, "header",
                        fmt::format("the 'vertex' element needs one scalar property '{}'", axis));
    }
  }
  return vertex_element;
}

// Counts against the file's size, before any loop over them. An element with entries but no
// properties holds nothing to read (and nothing would end a loop over a hostile count); every
// entry of any other element takes at least one byte, so a count larger than the rest of the
// file is refused here. Smaller shortfalls are found by the walk over the body, which stops at
// the first missing value and names it.
Status checkPlyCounts(const std::string& path, const std::string& text, const PlyHeader& header) {
  for (const PlyElement& e : header.elements) {
    if (e.count > 0 && e.properties.empty()) {
      return inputError(
          path, "header",
          fmt::format("element '{}' has {} entries but no properties", e.name, e.count));
    }
  }
  const size_t body_bytes = text.size() - std::min(header.body, text.size());
  for (const PlyElement& e : header.elements) {
    if (e.count > body_bytes) {
      return inputError(path, "header",
                        fmt::format("element '{}' declares {} entries, more than the file's {} "
                                    "bytes of data can hold",
                                    e.name, e.count, body_bytes));
    }
  }
  return {};
}

// Whether the vertex element has every one of `slots`, once, as a scalar.
bool hasScalars(const PlyElement& vertex_element, std::initializer_list<VertexSlot> slots) {
  for (VertexSlot slot : slots) {
    int found = 0;
    for (const PlyProperty& p : vertex_element.properties) {
      if (vertexSlot(p.name) == slot) found += p.is_list ? 2 : 1;
    }
    if (found != 1) return false;
  }
  return true;
}

// The mesh's vertex arrays at the file's vertex count, within the memory there is.
Status allocatePlyMesh(const std::string& path, const std::vector<PlyElement>& elements,
                       bool has_normals, bool has_uvs, PlyScan* scan) {
  if (scan->vertices > UINT32_MAX) {
    return inputError(
        path, "header",
        fmt::format("{} vertices; at most {} are supported", scan->vertices, UINT32_MAX));
  }
  // Vertices as stored, and triangles at least one per face entry (fans add more as they come).
  size_t face_entries = 0;
  for (const PlyElement& e : elements) face_entries += e.name == "face" ? e.count : 0;
  PENUMBRA_TRY(
      checkMemory(scan->vertices * (sizeof(glm::vec3) * (has_normals ? 2 : 1) + (has_uvs ? 8 : 0)) +
                      face_entries * (sizeof(glm::uvec3) + sizeof(uint32_t)),
                  fmt::format("the mesh of {}", path)));
  Mesh& mesh = scan->mesh;
  mesh.positions.resize(scan->vertices);
  if (has_normals) mesh.normals.resize(scan->vertices);
  if (has_uvs) mesh.uvs.resize(scan->vertices);
  return {};
}

// The walk over the body: every entry of every element, property by property, into a scan whose
// vertex arrays are sized.
class PlyBodyWalk {
 public:
  PlyBodyWalk(const std::string& path, const std::string& text, const PlyHeader& header,
              bool has_normals, bool has_uvs, PlyScan* scan)
      : path_(path),
        body_(text, header.body, header.format, header.lines + 1),
        has_normals_(has_normals),
        has_uvs_(has_uvs),
        scan_(scan) {}

  Status walk(const std::vector<PlyElement>& elements) {
    for (const PlyElement& e : elements) {
      element_ = &e;
      is_vertex_ = e.name == "vertex";
      is_face_ = e.name == "face";
      for (entry_ = 0; entry_ < e.count; ++entry_) {
        for (const PlyProperty& p : e.properties) {
          PENUMBRA_TRY(p.is_list ? list(p) : scalar(p));
        }
      }
    }
    return {};
  }

 private:
  // The entry being read, with its line in an ASCII file.
  std::string where() const {
    std::string s = fmt::format("{} {}", element_->name, entry_);
    if (body_.ascii()) s = fmt::format("line {}, {}", body_.line(), s);
    return s;
  }

  // A value of property p that could not be read: `bad` is the token that is not a number, or
  // empty at the end of the data.
  Status fail(const PlyProperty& p, const std::string& bad) const {
    if (!bad.empty()) {
      return inputError(path_, where(),
                        fmt::format("'{}' is not a number (property '{}')", bad, p.name));
    }
    // No line number: the reader is past the last line.
    return inputError(path_, fmt::format("{} {}", element_->name, entry_),
                      fmt::format("the file ends early, in property '{}' (truncated?)", p.name));
  }

  // A scalar: a vertex's position, normal or texture coordinate component is kept.
  Status scalar(const PlyProperty& p) {
    double value = 0.0;
    std::string bad;
    if (!body_.next(p.type, &value, &bad)) return fail(p, bad);
    if (!is_vertex_) return {};
    Mesh& mesh = scan_->mesh;
    const size_t i = entry_;
    const auto f = static_cast<float>(value);
    switch (vertexSlot(p.name)) {
      case VertexSlot::kX:
      case VertexSlot::kY:
      case VertexSlot::kZ:
        if (!std::isfinite(f)) {
          return inputError(
              path_, where(),
              fmt::format("coordinate {} is not a finite number ({})", p.name, value));
        }
        mesh.positions[i][static_cast<int>(vertexSlot(p.name)) - static_cast<int>(VertexSlot::kX)] =
            f;
        break;
      case VertexSlot::kNx:
      case VertexSlot::kNy:
      case VertexSlot::kNz:
        if (has_normals_) {
          mesh.normals[i][static_cast<int>(vertexSlot(p.name)) -
                          static_cast<int>(VertexSlot::kNx)] = f;
        }
        break;
      case VertexSlot::kU:
      case VertexSlot::kV:
        if (has_uvs_) {
          mesh.uvs[i][static_cast<int>(vertexSlot(p.name)) - static_cast<int>(VertexSlot::kU)] = f;
        }
        break;
      case VertexSlot::kNone:
        break;
    }
    return {};
  }

  // A list: a face's vertex indices become a polygon, fanned into triangles; other lists are read
  // and dropped.
  Status list(const PlyProperty& p) {
    double value = 0.0;
    std::string bad;
    if (!body_.next(p.count_type, &value, &bad)) return fail(p, bad);
    // A count within its declared type (an ASCII file can write any number).
    if (!(value >= 0.0) || value != std::floor(value) || value > largestValue(p.count_type)) {
      return inputError(path_, where(),
                        fmt::format("list length {} of '{}' is not a count", value, p.name));
    }
    const size_t n = static_cast<size_t>(value);
    const bool indices = is_face_ && (p.name == "vertex_indices" || p.name == "vertex_index");
    polygon_.clear();
    for (size_t k = 0; k < n; ++k) {
      if (!body_.next(p.type, &value, &bad)) return fail(p, bad);
      if (!indices) continue;
      if (!(value >= 0.0 && value < static_cast<double>(scan_->vertices) &&
            value == std::floor(value))) {
        return inputError(
            path_, where(),
            fmt::format("vertex index {} is out of range ({} vertices)", value, scan_->vertices));
      }
      polygon_.push_back(static_cast<uint32_t>(value));
    }
    if (!indices) return {};
    ++scan_->faces;
    if (n < 3) {
      ++scan_->points_and_lines;
      return {};
    }
    Mesh& mesh = scan_->mesh;
    for (size_t k = 2; k < n; ++k) {
      mesh.triangles.emplace_back(polygon_[0], polygon_[k - 1], polygon_[k]);
      mesh.material_ids.push_back(0);
    }
    return {};
  }

  const std::string& path_;
  PlyBodyReader body_;
  bool has_normals_, has_uvs_;
  PlyScan* scan_;
  std::vector<uint32_t> polygon_;
  // The entry being read: entry_ of element_.
  const PlyElement* element_ = nullptr;
  bool is_vertex_ = false, is_face_ = false;
  size_t entry_ = 0;
};

Status scanPly(const std::string& path, const std::string& text, PlyScan* scan) {
  PlyHeader header;
  PENUMBRA_TRY(readPlyHeader(path, text, header));
  Expected<const PlyElement*> vertex_element = findPlyVertices(path, header.elements);
  if (!vertex_element) return vertex_element.error();
  scan->vertices = (*vertex_element)->count;
  PENUMBRA_TRY(checkPlyCounts(path, text, header));
  // Normals and texture coordinates are read when every component is there, once, as a scalar.
  const bool has_normals =
      hasScalars(**vertex_element, {VertexSlot::kNx, VertexSlot::kNy, VertexSlot::kNz});
  const bool has_uvs = hasScalars(**vertex_element, {VertexSlot::kU, VertexSlot::kV});
  PENUMBRA_TRY(allocatePlyMesh(path, header.elements, has_normals, has_uvs, scan));
  PlyBodyWalk body(path, text, header, has_normals, has_uvs, scan);
  return body.walk(header.elements);
}

}  // namespace

Expected<Scene> loadPly(const std::string& path) {
  Expected<std::string> text = readFile(path);
  if (!text.ok()) return text.error();
  return loadPlyBytes(path, *text);
}

Expected<Scene> loadPlyBytes(const std::string& path, const std::string& bytes) {
  PlyScan scan;
  PENUMBRA_TRY(scanPly(path, bytes, &scan));

  Scene scene;
  scene.source = path;
  scene.materials.push_back(Material{"default", glm::vec3(0.8f), glm::vec3(0.0f)});
  scan.mesh.name = std::filesystem::path(path).stem().string();
  if (!scan.mesh.triangles.empty()) scene.meshes.push_back(std::move(scan.mesh));
  if (scan.points_and_lines > 0) {
    scene.warnings.push_back(
        fmt::format("{}: {} point or line face(s) are skipped", path, scan.points_and_lines));
  }
  PENUMBRA_TRY(validateScene(scene));
  return scene;
}

}  // namespace penumbra
