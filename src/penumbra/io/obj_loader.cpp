// Wavefront OBJ loading through tinyobjloader.
//
// tinyobjloader is lenient: it skips lines it does not know, reads a malformed or "nan" number
// as 0, resolves a relative index that points before the first vertex to a negative index, and
// only warns (with the last line's number) about indices past the end. So the text is first
// checked line by line here (statements, numbers, finite coordinates, index ranges), with
// errors naming the line, and only then handed to tinyobjloader with triangulation off. Polygons
// are fan-triangulated here (v0 v1 v2, v0 v2 v3, ...) so that triangle i is the i-th triangle in
// file order. MTL files are read here too (so a missing one is a warning, not a failure):
// Kd -> reflectance, Ke -> emission; illum 3 and 5 (ray-traced reflection) make a mirror of Ks,
// illum 4, 6, 7 and 9 (ray-traced refraction) glass of index Ni filtered by Tf. Textures:
// map_Kd gives the reflectance in place of Kd (as Blender's importer reads it: Blender's exporter
// writes Kd 0.8 beside a texture), map_Ke the emission (times Ke when Ke is not zero), map_d a
// cut-out (covered where its alpha, or its grey for a file without alpha, is at least 0.5);
// d < 1 without map_d is partial coverage. Their -o, -s and -clamp options apply. Texture files
// are looked for beside the OBJ file, then beside each material library, with '\\' read as '/'.
#include "penumbra/core/file_util.h"
#include "penumbra/io/asset_files.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/io/texture_loader.h"

#include <tiny_obj_loader.h>

#include <glm/common.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

namespace penumbra {

namespace {

void splitTokens(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
}

// The next line of `text` from *pos, without its "\n" or "\r\n"; false at the end.
bool nextLine(std::string_view text, size_t* pos, std::string_view* line) {
  if (*pos >= text.size()) return false;
  size_t eol = text.find('\n', *pos);
  if (eol == std::string_view::npos) eol = text.size();
  *line = text.substr(*pos, eol - *pos);
  *pos = eol + 1;
  if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
  return true;
}

// A decimal number as OBJ writes it; "nan" and "inf" spellings, and numbers too large for a
// double, are read as non-finite values so that the caller can report them. Returns false when
// `token` is not a number at all.
bool parseNumber(std::string_view token, double* out) {
  const bool plus = !token.empty() && token[0] == '+';
  const char* first = token.data() + (plus ? 1 : 0);
  const char* last = token.data() + token.size();
  if (first == last || *first == '+' || (plus && *first == '-')) return false;
  const auto [ptr, ec] = std::from_chars(first, last, *out, std::chars_format::general);
  if (ptr != last) return false;
  if (ec == std::errc::result_out_of_range) {
    // Overflow or underflow: only an overflow (a large exponent) matters.
    *out = std::strtod(std::string(token).c_str(), nullptr);
    return true;
  }
  return ec == std::errc();
}

bool parseInteger(std::string_view token, long* out) {
  const char* first = token.data() + (!token.empty() && token[0] == '+' ? 1 : 0);
  const char* last = token.data() + token.size();
  if (first == last) return false;
  const auto [ptr, ec] = std::from_chars(first, last, *out);
  return ptr == last && ec == std::errc();
}

// What the line-by-line check learned.
struct ObjScan {
  size_t faces = 0;
  std::vector<std::pair<std::string, size_t>> material_libraries;  // name, line
  std::vector<std::pair<std::string, size_t>> material_uses;       // name, line
  std::vector<std::string> warnings;
};

// Keywords that OBJ defines for free-form geometry and display attributes, which are ignored.
bool isIgnoredStatement(std::string_view k) {
  static const char* const kIgnored[] = {
      "vp",    "cstype",   "deg",      "bmat", "step",   "curv",   "curv2",      "surf",
      "parm",  "trim",     "hole",     "scrv", "sp",     "end",    "con",        "mg",
      "bevel", "c_interp", "d_interp", "lod",  "maplib", "usemap", "shadow_obj", "trace_obj",
      "ctech", "stech",    "call",     "csh",  "vw",     "t"};
  for (const char* s : kIgnored) {
    if (k == s) return true;
  }
  return false;
}

// The most corners tinyobjloader keeps for one face (it stores the count in a byte).
constexpr size_t kMaxLoaderCorners = 255;

// The line-by-line check of scanObj, one line at a time: the counts of vertex data and the
// pending indices carry from line to line.
class ObjLineChecker {
 public:
  ObjLineChecker(const std::string& path, ObjScan* scan, std::string* clean)
      : path_(path), scan_(scan), clean_(clean) {}

  // The next line of the file.
  Status check(std::string_view line) {
    ++line_no_;
    if (line.find('\0') != std::string_view::npos) {
      return inputError(path_, place(), "binary data: this is not a text OBJ file");
    }
    const size_t comment = line.find('#');
    if (comment != std::string_view::npos) line = line.substr(0, comment);
    clean_->append(line);
    clean_->push_back('\n');
    splitTokens(line, tok_);
    if (tok_.empty()) return {};
    if (!tok_.back().empty() && tok_.back().back() == '\\') {
      return inputError(path_, place(), "line continuation ('\\') is not supported");
    }
    const std::string_view key = tok_[0];
    if (key == "v" || key == "vn" || key == "vt") return vertexData(key);
    if (key == "f" || key == "l" || key == "p") return element(key, line);
    if (key == "mtllib") {
      for (size_t i = 1; i < tok_.size(); ++i) {
        scan_->material_libraries.emplace_back(std::string(tok_[i]), line_no_);
      }
      return {};
    }
    if (key == "usemtl") {
      if (tok_.size() >= 2) scan_->material_uses.emplace_back(std::string(tok_[1]), line_no_);
      return {};
    }
    if (key == "g" || key == "o" || key == "s") return {};
    if (isIgnoredStatement(key)) {
      if (!warned_ignored_) {
        scan_->warnings.push_back(
            fmt::format("{}: {}: '{}' (free-form geometry or display attribute) is ignored", path_,
                        place(), key));
        warned_ignored_ = true;
      }
      return {};
    }
    std::string shown(key.substr(0, 32));
    for (char& c : shown) {
      if (!std::isprint(static_cast<unsigned char>(c))) c = '?';
    }
    return inputError(path_, place(),
                      fmt::format("unknown statement '{}'{}", shown,
                                  line_no_ == 1 ? " (is this an OBJ file?)" : ""));
  }

  // After the last line: the positive indices against the final counts.
  Status finish() const {
    struct Final {
      const Pending* pending;
      const char* name;
      const char* plural;
      size_t count;
    };
    const Final finals[3] = {{&max_v_, "vertex", "vertices", num_v_},
                             {&max_vt_, "texture coordinate", "texture coordinates", num_vt_},
                             {&max_vn_, "normal", "normals", num_vn_}};
    for (const Final& f : finals) {
      if (f.pending->index > 0 && static_cast<size_t>(f.pending->index) > f.count) {
        return inputError(path_, fmt::format("line {}", f.pending->line),
                          fmt::format("{} index {} is out of range (the file has {} {})", f.name,
                                      f.pending->index, f.count, f.count == 1 ? f.name : f.plural));
      }
    }
    return {};
  }

 private:
  // Positive indices may refer to vertices defined later in the file (tinyobjloader allows it),
  // so they are checked against the final counts; the first offender of each kind is kept.
  struct Pending {
    long index = 0;
    size_t line = 0;
  };

  std::string place() const { return fmt::format("line {}", line_no_); }

  // v, vn or vt: its numbers, the coordinates finite.
  Status vertexData(std::string_view key) {
    const size_t min_n = key == "vt" ? 1 : 3;
    const size_t max_n = key == "v" ? 7 : 3;  // v: x y z [w] or x y z r g b
    const size_t n = tok_.size() - 1;
    if (n < min_n || n > max_n) {
      return inputError(path_, place(),
                        fmt::format("'{}' needs {} to {} numbers, found {}", key, min_n, max_n, n));
    }
    const size_t checked = key == "vt" ? std::min<size_t>(n, 2) : 3;
    size_t& count = key == "v" ? num_v_ : key == "vn" ? num_vn_ : num_vt_;
    for (size_t i = 1; i < tok_.size(); ++i) {
      double value = 0.0;
      if (!parseNumber(tok_[i], &value)) {
        return inputError(path_, place(), fmt::format("'{}' is not a number", tok_[i]));
      }
      if (i <= checked && !std::isfinite(static_cast<float>(value))) {
        const char* what = key == "v" ? "vertex" : key == "vn" ? "normal" : "texture coordinate";
        return inputError(path_, fmt::format("{}, {} {}", place(), what, count + 1),
                          fmt::format("coordinate '{}' is not a finite number", tok_[i]));
      }
    }
    ++count;
    return {};
  }

  // f, l or p: its corners; faces are counted, lines and points are ignored with a warning.
  Status element(std::string_view key, std::string_view line) {
    const size_t min_corners = key == "f" ? 3 : key == "l" ? 2 : 1;
    if (tok_.size() - 1 < min_corners) {
      return inputError(path_, place(),
                        fmt::format("'{}' needs at least {} vertices, found {}", key, min_corners,
                                    tok_.size() - 1));
    }
    for (size_t i = 1; i < tok_.size(); ++i) PENUMBRA_TRY(checkCorner(tok_[i]));
    if (key == "f" && tok_.size() - 1 > kMaxLoaderCorners) {
      splitFace(line);
    } else if (key == "f") {
      ++scan_->faces;
    } else if (!warned_lines_) {
      scan_->warnings.push_back(
          fmt::format("{}: {}: line and point elements are ignored", path_, place()));
      warned_lines_ = true;
    }
    return {};
  }

  // A corner: v, v/vt, v//vn or v/vt/vn, each index within the vertices defined so far
  // (relative) or pending the final counts (absolute).
  Status checkCorner(std::string_view corner) {
    std::string_view parts[3];
    size_t np = 0;
    size_t start = 0;
    for (;;) {
      const size_t slash = corner.find('/', start);
      if (np == 3) {
        return inputError(path_, place(),
                          fmt::format("'{}' is not a vertex reference (v, v/vt, v//vn or "
                                      "v/vt/vn)",
                                      corner));
      }
      parts[np++] = corner.substr(
          start, slash == std::string_view::npos ? std::string_view::npos : slash - start);
      if (slash == std::string_view::npos) break;
      start = slash + 1;
    }
    const char* const kNames[3] = {"vertex", "texture coordinate", "normal"};
    const size_t counts[3] = {num_v_, num_vt_, num_vn_};
    Pending* const pendings[3] = {&max_v_, &max_vt_, &max_vn_};
    for (size_t k = 0; k < np; ++k) {
      if (k > 0 && parts[k].empty() && !(k == 1 && np == 3)) {
        return inputError(path_, place(), fmt::format("'{}' has an empty index", corner));
      }
      if (parts[k].empty()) continue;  // the vt of v//vn
      long index = 0;
      if (!parseInteger(parts[k], &index)) {
        return inputError(path_, place(), fmt::format("'{}' is not a vertex reference", corner));
      }
      if (index == 0) {
        return inputError(
            path_, place(),
            fmt::format("{} index 0 in '{}' (OBJ indices start at 1)", kNames[k], corner));
      }
      if (index < 0) {
        if (static_cast<size_t>(-index) > counts[k]) {
          return inputError(path_, place(),
                            fmt::format("relative {} index {} in '{}' points before the first "
                                        "{} ({} defined so far)",
                                        kNames[k], index, corner, kNames[k], counts[k]));
        }
      } else if (index > pendings[k]->index) {
        *pendings[k] = Pending{index, line_no_};
      }
    }
    return {};
  }

  // tinyobjloader counts a face's corners in 8 bits: a polygon of 256 or more corners (CAD
  // exports have them) is written as consecutive polygons of at most 255 corners that share
  // corner 0, whose fans are the same triangles in the same order. `line` is the face's line as
  // written to `clean`, which they replace.
  void splitFace(std::string_view line) {
    clean_->resize(clean_->size() - line.size() - 1);
    const size_t n = tok_.size() - 1;
    for (size_t k = 1; k + 1 < n;) {
      const size_t end = std::min(k + kMaxLoaderCorners - 2, n - 1);
      clean_->append("f ");
      clean_->append(tok_[1]);
      for (size_t i = k; i <= end; ++i) {
        clean_->push_back(' ');
        clean_->append(tok_[i + 1]);
      }
      clean_->push_back('\n');
      ++scan_->faces;
      k = end;
    }
  }

  const std::string& path_;
  ObjScan* scan_;
  std::string* clean_;
  size_t num_v_ = 0, num_vn_ = 0, num_vt_ = 0;
  Pending max_v_, max_vn_, max_vt_;
  bool warned_lines_ = false, warned_ignored_ = false;
  size_t line_no_ = 0;
  std::vector<std::string_view> tok_;  // the tokens of the current line
};

// Checks `text` and writes to `clean` the same lines without comments (tinyobjloader does not
// accept a comment after a statement), so line numbers stay the same (except after a polygon
// of more than kMaxLoaderCorners corners, which takes several lines).
Status scanObj(const std::string& path, const std::string& text, ObjScan* scan,
               std::string* clean) {
  clean->reserve(text.size());
  ObjLineChecker checker(path, scan, clean);
  size_t pos = 0;
  std::string_view line;
  while (nextLine(text, &pos, &line)) PENUMBRA_TRY(checker.check(line));
  return checker.finish();
}

// Checks the numbers of a material library's colour and scalar statements (tinyobjloader reads
// "nan", "inf" and words as 0): each must be a finite number, and colours not negative. Other
// statements (texture maps, illum, names) are left to tinyobjloader.
Status scanMtl(const std::string& path, const std::string& text) {
  static const char* const kColours[] = {"Ka", "Kd", "Ks", "Ke", "Tf"};
  static const char* const kScalars[] = {"Ns", "Ni", "d", "Tr"};
  size_t line_no = 0, pos = 0;
  std::vector<std::string_view> tok;
  std::string_view line;
  while (nextLine(text, &pos, &line)) {
    ++line_no;
    const size_t comment = line.find('#');
    if (comment != std::string_view::npos) line = line.substr(0, comment);
    splitTokens(line, tok);
    if (tok.empty()) continue;
    bool colour = false, scalar = false;
    for (const char* k : kColours) colour = colour || tok[0] == k;
    for (const char* k : kScalars) scalar = scalar || tok[0] == k;
    if (!colour && !scalar) continue;
    const auto place = [&] { return fmt::format("line {}", line_no); };
    if (colour && tok.size() >= 2 && (tok[1] == "spectral" || tok[1] == "xyz")) {
      return inputError(
          path, place(),
          fmt::format("'{} {}' colours are not supported (give RGB numbers)", tok[0], tok[1]));
    }
    const size_t max_n = colour ? 3 : 1;
    if (tok.size() < 2 || tok.size() - 1 > max_n) {
      return inputError(path, place(),
                        fmt::format("'{}' needs {} number{}, found {}", tok[0],
                                    colour ? "1 to 3" : "1", colour ? "s" : "", tok.size() - 1));
    }
    for (size_t i = 1; i < tok.size(); ++i) {
      double value = 0.0;
      if (!parseNumber(tok[i], &value)) {
        return inputError(path, place(), fmt::format("'{}' is not a number", tok[i]));
      }
      if (!std::isfinite(static_cast<float>(value))) {
        return inputError(path, place(),
                          fmt::format("{} value '{}' is not a finite number", tok[0], tok[i]));
      }
      if (colour && value < 0.0) {
        return inputError(path, place(), fmt::format("{} value {} is negative", tok[0], tok[i]));
      }
    }
  }
  return {};
}

struct CornerKey {
  int v, vn, vt;
  bool operator==(const CornerKey&) const = default;
};
struct CornerKeyHash {
  size_t operator()(const CornerKey& k) const {
    size_t h = std::hash<int>()(k.v);
    h = h * 1000003u ^ std::hash<int>()(k.vn);
    return h * 1000003u ^ std::hash<int>()(k.vt);
  }
};

// An MTL map statement's -s, -o and -t take one to three numbers (the others default to 1, 0 and
// 0); tinyobjloader reads three, taking the file name as the third when two are given. The
// missing ones are written out here, so "map_Kd -s 2 2 wood.png" keeps its texture.
std::string completeMapOptions(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  size_t pos = 0;
  std::string_view line;
  std::vector<std::string_view> tok;
  while (nextLine(text, &pos, &line)) {
    splitTokens(line, tok);
    const bool map = !tok.empty() && (tok[0].rfind("map_", 0) == 0 || tok[0] == "bump" ||
                                      tok[0] == "disp" || tok[0] == "decal" || tok[0] == "refl");
    if (!map) {
      out.append(line);
      out.push_back('\n');
      continue;
    }
    std::string rebuilt(tok[0]);
    for (size_t i = 1; i < tok.size(); ++i) {
      rebuilt += ' ';
      rebuilt += tok[i];
      if (tok[i] != "-s" && tok[i] != "-o" && tok[i] != "-t") continue;
      size_t numbers = 0;
      double value = 0.0;
      while (numbers < 3 && i + 1 + numbers < tok.size() - 1 &&
             parseNumber(tok[i + 1 + numbers], &value)) {
        ++numbers;
      }
      for (size_t k = 0; k < numbers; ++k) {
        rebuilt += ' ';
        rebuilt += tok[i + 1 + k];
      }
      for (size_t k = numbers; k < 3 && numbers > 0; ++k) rebuilt += tok[i] == "-s" ? " 1" : " 0";
      i += numbers;
    }
    out += rebuilt;
    out.push_back('\n');
  }
  return out;
}

// The material libraries the file names, read here so that a missing one is only a warning (and
// sets `library_missing`): their texts, one after another.
Expected<std::string> readMaterialLibraries(const std::string& path, const ObjScan& scan,
                                            const AssetPolicy& policy, Scene& scene,
                                            bool& library_missing) {
  std::string mtl_text;
  for (const auto& [name, line] : scan.material_libraries) {
    Expected<std::string> resolved =
        resolveAssetFile(path, name, false, policy, fmt::format("line {}: mtllib", line));
    if (!resolved) return resolved.error();
    const std::string& mtl_path = *resolved;
    Expected<std::string> mtl = readFile(mtl_path);
    if (!mtl.ok()) {
      scene.warnings.push_back(
          fmt::format("{}: line {}: material library '{}' cannot be read ({}); its materials "
                      "are replaced by the default material",
                      path, line, name, mtl.error().message));
      library_missing = true;
      continue;
    }
    PENUMBRA_TRY(scanMtl(mtl_path, *mtl));
    mtl_text += completeMapOptions(*mtl);
    mtl_text += "\n";
  }
  return mtl_text;
}

// The checked text and its materials through tinyobjloader, without triangulation.
Status parseWithTinyObj(const std::string& path, const std::string& clean,
                        const std::string& mtl_text, tinyobj::ObjReader& reader) {
  tinyobj::ObjReaderConfig config;
  config.triangulate = false;
  config.vertex_color = false;
  bool parsed = false;
  try {
    parsed = reader.ParseFromString(clean, mtl_text, config);
  } catch (const std::exception& e) {
    return inputError(path, "", fmt::format("tinyobjloader failed: {}", e.what()));
  }
  if (!parsed) {
    std::string message = reader.Error();
    while (!message.empty() && (message.back() == '\n' || message.back() == '\r')) {
      message.pop_back();
    }
    return inputError(path, "", fmt::format("tinyobjloader: {}", message));
  }
  return {};
}

// Where an MTL texture file is: `name` ('\\' read as '/') in the first of `dirs` that has it, else
// in the first (for the message).
std::string findTextureFile(std::string name, const std::vector<std::string>& dirs) {
  std::replace(name.begin(), name.end(), '\\', '/');
  if (std::filesystem::path(name).is_absolute()) return name;
  for (const std::string& dir : dirs) {
    const std::filesystem::path candidate = std::filesystem::path(dir) / name;
    std::error_code ec;
    if (std::filesystem::is_regular_file(candidate, ec)) return candidate.string();
  }
  return (std::filesystem::path(dirs.front()) / name).string();
}

// Where an OBJ file's textures are looked for and how they are read: the folders of the file and
// of its material libraries, inside the file's folder unless the policy allows otherwise.
struct ObjTextures {
  std::vector<std::string> dirs;
  AssetPolicy policy;
  TextureCache cache;
};

// The file of an MTL map statement, confined to the OBJ file's folder (io/asset_files.h).
Expected<std::string> objTextureFile(const std::string& path, const std::string& name,
                                     const ObjTextures& textures, const std::string& place) {
  return confineAssetPath(path, findTextureFile(name, textures.dirs), textures.policy, place);
}

// An MTL map statement's texture as a binding: the file, -clamp, and -s / -o as the UV transform
// u' = s u + o.
Expected<TextureBinding> objTexture(const std::string& path, const std::string& material,
                                    const char* statement, const std::string& name,
                                    const tinyobj::texture_option_t& option, bool colour,
                                    ObjTextures& textures) {
  const std::string place = fmt::format("material '{}' {}", material, statement);
  for (int k = 0; k < 2; ++k) {
    if (!std::isfinite(option.scale[k]) || !std::isfinite(option.origin_offset[k]) ||
        std::abs(option.scale[k]) > 1e6 || std::abs(option.origin_offset[k]) > 1e6) {
      return inputError(path, place, "-s and -o must be finite numbers within 1e6");
    }
  }
  Expected<std::string> file = objTextureFile(path, name, textures, place);
  if (!file) return file.error();
  Expected<std::shared_ptr<const Texture>> t = textures.cache.file(*file, colour, path, place);
  if (!t) return t.error();
  TextureBinding b;
  b.texture = *t;
  b.row_u = glm::vec3(option.scale[0], 0.0f, option.origin_offset[0]);
  b.row_v = glm::vec3(0.0f, option.scale[1], option.origin_offset[1]);
  if (option.clamp) {
    b.sampler.wrap_s = TextureWrap::kClampToEdge;
    b.sampler.wrap_t = TextureWrap::kClampToEdge;
  }
  return b;
}

// One MTL material: Kd -> reflectance, Ke -> emission, the textures (see the top of the file);
// illum 3 and 5 a mirror of Ks, illum 4, 6, 7 and 9 glass of index Ni filtered by Tf.
Expected<Material> objMaterial(const std::string& path, const tinyobj::material_t& m,
                               ObjTextures& textures, Scene& scene) {
  Material mat;
  mat.name = m.name;
  mat.reflectance = glm::vec3(m.diffuse[0], m.diffuse[1], m.diffuse[2]);
  mat.emission = glm::vec3(m.emission[0], m.emission[1], m.emission[2]);
  if (!m.diffuse_texname.empty()) {
    Expected<TextureBinding> b =
        objTexture(path, m.name, "map_Kd", m.diffuse_texname, m.diffuse_texopt, true, textures);
    if (!b) return b.error();
    mat.reflectance_texture = std::move(*b);
    mat.reflectance = glm::vec3(1.0f);
  }
  if (!m.emissive_texname.empty()) {
    Expected<TextureBinding> b =
        objTexture(path, m.name, "map_Ke", m.emissive_texname, m.emissive_texopt, true, textures);
    if (!b) return b.error();
    mat.emission_texture = std::move(*b);
    if (mat.emission == glm::vec3(0.0f)) mat.emission = glm::vec3(1.0f);
  }
  // map_Kd's own alpha is not coverage in MTL; map_d (or d) is.
  mat.alpha_from_reflectance = false;
  if (!m.alpha_texname.empty()) {
    Expected<TextureBinding> b =
        objTexture(path, m.name, "map_d", m.alpha_texname, m.alpha_texopt, false, textures);
    if (!b) return b.error();
    mat.coverage_texture = std::move(*b);
    mat.alpha_mode = AlphaMode::kMask;
    mat.alpha_cutoff = 0.5f;
  } else if (m.dissolve < 1.0f) {
    if (!(m.dissolve >= 0.0f)) {
      return inputError(path, fmt::format("material '{}'", m.name),
                        fmt::format("d {} is outside [0, 1]", m.dissolve));
    }
    mat.alpha_mode = AlphaMode::kBlend;
    mat.alpha = float(m.dissolve);
    scene.warnings.push_back(
        fmt::format("{}: material '{}': d {} lets {:.0f}% of the light through it", path, m.name,
                    m.dissolve, 100.0 * (1.0 - m.dissolve)));
  }
  const auto colour = [](const tinyobj::real_t* c) {
    return glm::clamp(glm::vec3(c[0], c[1], c[2]), glm::vec3(0.0f), glm::vec3(1.0f));
  };
  if (m.illum == 3 || m.illum == 5) {
    // A mirror of Ks (white when the file gives none).
    mat.scattering = Scattering::kMirror;
    mat.specular = colour(m.specular);
    if (mat.specular == glm::vec3(0.0f)) mat.specular = glm::vec3(1.0f);
    mat.reflectance = diffuseStandIn(mat);
  } else if (m.illum == 4 || m.illum == 6 || m.illum == 7 || m.illum == 9) {
    // Glass of index Ni, the light it lets in filtered by Tf (clear when the file gives none).
    mat.scattering = Scattering::kDielectric;
    mat.ior = float(m.ior);
    if (!(mat.ior > 1.0f)) {
      scene.warnings.push_back(
          fmt::format("{}: material '{}': illum {} (glass) with Ni {} read as Ni 1.5", path, m.name,
                      m.illum, m.ior));
      mat.ior = 1.5f;
    }
    if (mat.ior > 4.0f) {
      return inputError(path, fmt::format("material '{}'", m.name),
                        fmt::format("Ni {} is outside [1, 4]", m.ior));
    }
    mat.specular = colour(m.transmittance);
    if (mat.specular == glm::vec3(0.0f)) mat.specular = glm::vec3(1.0f);
    mat.reflectance = diffuseStandIn(mat);
  }
  return mat;
}

// A warning for each usemtl that names a material no library defines (none when a library is
// missing: its materials are unknown).
void warnUndefinedMaterials(const std::string& path, const ObjScan& scan,
                            const std::vector<tinyobj::material_t>& obj_materials,
                            bool library_missing, Scene& scene) {
  for (const auto& [name, line] : scan.material_uses) {
    bool found = false;
    for (const tinyobj::material_t& m : obj_materials) found = found || m.name == name;
    if (!found && !library_missing) {
      scene.warnings.push_back(
          fmt::format("{}: line {}: material '{}' is not defined in the material library; the "
                      "default material is used",
                      path, line, name));
    }
  }
}

// The scene material of a face's tinyobjloader material: the same index, or for a face without
// one a default material, added to the scene when first used.
class ObjMaterialIds {
 public:
  ObjMaterialIds(size_t obj_materials, Scene& scene)
      : obj_materials_(obj_materials), scene_(scene) {}

  uint32_t operator()(int obj_material) {
    if (obj_material >= 0 && static_cast<size_t>(obj_material) < obj_materials_) {
      return static_cast<uint32_t>(obj_material);
    }
    if (default_material_ < 0) {
      default_material_ = static_cast<int>(scene_.materials.size());
      scene_.materials.push_back(Material{"default", glm::vec3(0.8f), glm::vec3(0.0f)});
    }
    return static_cast<uint32_t>(default_material_);
  }

 private:
  size_t obj_materials_;
  Scene& scene_;
  int default_material_ = -1;
};

// Which attributes a shape's corners have.
struct ObjCorners {
  bool normals = true, uvs = true, any_normals = false;
};

// The attributes of a shape's corners, each index checked against the attribute arrays.
Expected<ObjCorners> objCorners(const std::string& path, const tinyobj::attrib_t& attrib,
                                const tinyobj::mesh_t& sm) {
  ObjCorners corners;
  const size_t nv = attrib.vertices.size() / 3, nn = attrib.normals.size() / 3,
               nt = attrib.texcoords.size() / 2;
  for (const tinyobj::index_t& idx : sm.indices) {
    // The scan checked every index; this guards against tinyobjloader resolving one otherwise.
    if (idx.vertex_index < 0 || static_cast<size_t>(idx.vertex_index) >= nv ||
        (idx.normal_index >= 0 && static_cast<size_t>(idx.normal_index) >= nn) ||
        (idx.texcoord_index >= 0 && static_cast<size_t>(idx.texcoord_index) >= nt)) {
      return inputError(path, "", "tinyobjloader produced an index out of range");
    }
    corners.normals = corners.normals && idx.normal_index >= 0;
    corners.any_normals = corners.any_normals || idx.normal_index >= 0;
    corners.uvs = corners.uvs && idx.texcoord_index >= 0;
  }
  return corners;
}

// A shape as a mesh: its faces fanned in file order, corners with the same indices sharing a
// vertex.
Status addObjShape(const std::string& path, const tinyobj::attrib_t& attrib,
                   const tinyobj::shape_t& shape, const std::string& stem,
                   ObjMaterialIds& material_for, Scene& scene) {
  const tinyobj::mesh_t& sm = shape.mesh;
  // Normals and texture coordinates are kept only when every corner of the shape has them.
  Expected<ObjCorners> corners = objCorners(path, attrib, sm);
  if (!corners) return corners.error();
  const bool has_normals = corners->normals, has_uvs = corners->uvs;
  const std::string mesh_name = shape.name.empty() ? stem : shape.name;
  if (corners->any_normals && !has_normals) {
    scene.warnings.push_back(
        fmt::format("{}: '{}': some faces have no normals, so the shape's normals are dropped",
                    path, mesh_name));
  }

  Mesh mesh;
  mesh.name = mesh_name;
  std::unordered_map<CornerKey, uint32_t, CornerKeyHash> vertex_of;
  auto vertexFor = [&](const tinyobj::index_t& idx) -> uint32_t {
    const CornerKey key{idx.vertex_index, has_normals ? idx.normal_index : -1,
                        has_uvs ? idx.texcoord_index : -1};
    auto [it, inserted] = vertex_of.try_emplace(key, static_cast<uint32_t>(mesh.positions.size()));
    if (inserted) {
      const size_t v = static_cast<size_t>(key.v);
      mesh.positions.emplace_back(attrib.vertices[3 * v], attrib.vertices[3 * v + 1],
                                  attrib.vertices[3 * v + 2]);
      if (has_normals) {
        const size_t n = static_cast<size_t>(key.vn);
        mesh.normals.emplace_back(attrib.normals[3 * n], attrib.normals[3 * n + 1],
                                  attrib.normals[3 * n + 2]);
      }
      if (has_uvs) {
        const size_t t = static_cast<size_t>(key.vt);
        mesh.uvs.emplace_back(attrib.texcoords[2 * t], attrib.texcoords[2 * t + 1]);
      }
    }
    return it->second;
  };

  size_t offset = 0;
  for (size_t f = 0; f < sm.num_face_vertices.size(); ++f) {
    const size_t n = sm.num_face_vertices[f];
    const uint32_t material = material_for(f < sm.material_ids.size() ? sm.material_ids[f] : -1);
    const uint32_t v0 = vertexFor(sm.indices[offset]);
    uint32_t prev = vertexFor(sm.indices[offset + 1]);
    for (size_t k = 2; k < n; ++k) {
      const uint32_t cur = vertexFor(sm.indices[offset + k]);
      mesh.triangles.emplace_back(v0, prev, cur);
      mesh.material_ids.push_back(material);
      prev = cur;
    }
    offset += n;
  }
  scene.meshes.push_back(std::move(mesh));
  return {};
}

}  // namespace

// Whether a usemtl line names material `name` (a material no face uses reads no texture: its
// files need not exist).
bool usedByFaces(const ObjScan& scan, const std::string& name) {
  for (const auto& [use, line] : scan.material_uses) {
    if (use == name) return true;
  }
  return false;
}

// Every texture the used materials read, planned before any is decoded (io/texture_loader.h).
Status planObjTextures(const std::string& path, const ObjScan& scan,
                       const std::vector<tinyobj::material_t>& materials, ObjTextures& textures) {
  for (const tinyobj::material_t& m : materials) {
    if (!usedByFaces(scan, m.name)) continue;
    const std::tuple<const std::string*, bool, const char*> maps[] = {
        {&m.diffuse_texname, true, "map_Kd"},
        {&m.emissive_texname, true, "map_Ke"},
        {&m.alpha_texname, false, "map_d"}};
    for (const auto& [name, colour, statement] : maps) {
      if (name->empty()) continue;
      const std::string place = fmt::format("material '{}' {}", m.name, statement);
      Expected<std::string> file = objTextureFile(path, *name, textures, place);
      if (!file) return file.error();
      PENUMBRA_TRY(textures.cache.planFile(
          *file, colour ? TextureKind::kColour : TextureKind::kData, path, place));
    }
  }
  return {};
}

Expected<Scene> loadObj(const std::string& path, const SceneLoadOptions& options) {
  Expected<std::string> text = readFile(path);
  if (!text.ok()) return text.error();

  ObjScan scan;
  std::string clean;
  PENUMBRA_TRY(scanObj(path, *text, &scan, &clean));
  text->clear();
  if (scan.faces == 0) return inputError(path, "", "no faces: the file has no polygons");

  Scene scene;
  scene.source = path;
  scene.warnings = std::move(scan.warnings);
  bool library_missing = false;
  Expected<std::string> mtl_text =
      readMaterialLibraries(path, scan, options.files, scene, library_missing);
  if (!mtl_text) return mtl_text.error();
  tinyobj::ObjReader reader;
  PENUMBRA_TRY(parseWithTinyObj(path, clean, *mtl_text, reader));

  const std::vector<tinyobj::material_t>& obj_materials = reader.GetMaterials();
  ObjTextures textures{{std::filesystem::path(path).parent_path().string()},
                       options.files,
                       TextureCache(options.textures)};
  for (const auto& [name, line] : scan.material_libraries) {
    textures.dirs.push_back(
        std::filesystem::path(resolveRelativeTo(path, name)).parent_path().string());
  }
  PENUMBRA_TRY(planObjTextures(path, scan, obj_materials, textures));
  for (const tinyobj::material_t& m : obj_materials) {
    if (!usedByFaces(scan, m.name)) {
      // Kept for its index (faces name materials by it), without its textures.
      tinyobj::material_t bare = m;
      bare.diffuse_texname.clear();
      bare.emissive_texname.clear();
      bare.alpha_texname.clear();
      Expected<Material> mat = objMaterial(path, bare, textures, scene);
      if (!mat) return mat.error();
      scene.materials.push_back(std::move(*mat));
      continue;
    }
    Expected<Material> mat = objMaterial(path, m, textures, scene);
    if (!mat) return mat.error();
    scene.materials.push_back(std::move(*mat));
  }
  warnUndefinedMaterials(path, scan, obj_materials, library_missing, scene);
  for (const std::string& w : textures.cache.warnings()) scene.warnings.push_back(w);

  ObjMaterialIds material_for(obj_materials.size(), scene);
  const std::string stem = std::filesystem::path(path).stem().string();
  size_t faces_read = 0;
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    if (shape.mesh.num_face_vertices.empty()) continue;
    faces_read += shape.mesh.num_face_vertices.size();
    PENUMBRA_TRY(addObjShape(path, reader.GetAttrib(), shape, stem, material_for, scene));
  }
  if (faces_read != scan.faces) {
    return inputError(path, "",
                      fmt::format("tinyobjloader read {} faces where the file has {}; the file "
                                  "uses a construct that cannot be loaded in file order",
                                  faces_read, scan.faces));
  }

  PENUMBRA_TRY(validateScene(scene));
  return scene;
}

}  // namespace penumbra
