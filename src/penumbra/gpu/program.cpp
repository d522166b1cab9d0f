#include "penumbra/gpu/program.h"

#include "penumbra/core/check.h"
#include "penumbra/gpu/shader_sources.h"

#include <fmt/format.h>

#include <algorithm>
#include <regex>
#include <sstream>

namespace penumbra::gl {

namespace {

// Sources given directly (computeProgramFromSource) shadow the embedded set while they compile.
thread_local const EmbeddedShader* g_override = nullptr;

const EmbeddedShader* findShader(const std::string& name) {
  if (g_override && g_override->name == name) return g_override;
  for (const EmbeddedShader& s : embeddedShaders()) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

Status expandInto(const std::string& name, ExpandedSource& out, int depth) {
  if (depth > 16) return runtimeError("shaders/" + name, "#include nesting deeper than 16");
  const EmbeddedShader* shader = findShader(name);
  if (!shader) return runtimeError("shaders/" + name, "no such embedded shader");
  const int file_index = int(out.files.size());
  out.files.push_back(name);
  if (depth > 0) out.text += fmt::format("#line 1 {}\n", file_index);
  std::istringstream in{std::string(shader->source)};
  std::string line;
  int line_no = 0;
  static const std::regex include_re(R"(^\s*#\s*include\s+"([^"]+)\"\s*$)");
  while (std::getline(in, line)) {
    ++line_no;
    std::smatch m;
    if (std::regex_match(line, m, include_re)) {
      const Status s = expandInto(m[1].str(), out, depth + 1);
      if (!s.ok()) {
        return runtimeError("shaders/" + name,
                            fmt::format("line {}: {}", line_no, s.error().describe()));
      }
      out.text += fmt::format("#line {} {}\n", line_no + 1, file_index);
      continue;
    }
    out.text += line;
    out.text += '\n';
    if (line_no == 1 && depth == 0) {
      if (line.rfind("#version", 0) != 0) {
        return runtimeError("shaders/" + name, "line 1: must be the #version directive");
      }
      out.text += fmt::format("#line 2 {}\n", file_index);
    }
  }
  return {};
}

}  // namespace

Expected<ExpandedSource> expandShader(const std::string& name,
                                      const std::vector<std::string>& defines) {
  ExpandedSource out;
  const Status s = expandInto(name, out, 0);
  if (!s.ok()) return s.error();
  if (!defines.empty()) {
    // Insert after the #version line (the first line).
    const size_t eol = out.text.find('\n');
    std::string block;
    for (const std::string& d : defines) block += "#define " + d + "\n";
    out.text.insert(eol + 1, block);
  }
  return out;
}

std::string mapInfoLog(const std::string& log, const std::vector<std::string>& files) {
  // Mesa: "0:12(5): error: ..."; NVIDIA: "0(12) : error ..."
  static const std::regex mesa_re(R"((\d+):(\d+)\((\d+)\):)");
  static const std::regex nvidia_re(R"((\d+)\((\d+)\) :)");
  std::istringstream in(log);
  std::string line, out;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::smatch m;
    std::string mapped = line;
    auto fileName = [&](const std::string& index) {
      const size_t k = std::stoul(index);
      return k < files.size() ? "shaders/" + files[k] : "shader string " + index;
    };
    if (std::regex_search(line, m, mesa_re)) {
      mapped = fileName(m[1].str()) + ":" + m[2].str() + ":" + m.suffix().str();
    } else if (std::regex_search(line, m, nvidia_re)) {
      mapped = fileName(m[1].str()) + ":" + m[2].str() + ":" + m.suffix().str();
    }
    if (!out.empty()) out += "; ";
    out += mapped;
  }
  return out;
}

namespace {

Expected<GLuint> compileStage(GLenum stage, const std::string& name,
                              const std::vector<std::string>& defines) {
  Expected<ExpandedSource> src = expandShader(name, defines);
  if (!src) return src.error();
  const GLuint shader = glCreateShader(stage);
  const char* text = src->text.c_str();
  glShaderSource(shader, 1, &text, nullptr);
  glCompileShader(shader);
  GLint ok = GL_FALSE;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint len = 0;
    glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &len);
    std::string log(size_t(std::max(len, 1)), '\0');
    glGetShaderInfoLog(shader, len, nullptr, log.data());
    glDeleteShader(shader);
    return runtimeError("", "shader compilation failed: " + mapInfoLog(log.c_str(), src->files));
  }
  return shader;
}

Expected<Program> link(const std::vector<GLuint>& shaders, const std::string& what) {
  Program program(glCreateProgram());
  for (GLuint s : shaders) glAttachShader(program.id(), s);
  glLinkProgram(program.id());
  for (GLuint s : shaders) glDeleteShader(s);
  GLint ok = GL_FALSE;
  glGetProgramiv(program.id(), GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint len = 0;
    glGetProgramiv(program.id(), GL_INFO_LOG_LENGTH, &len);
    std::string log(size_t(std::max(len, 1)), '\0');
    glGetProgramInfoLog(program.id(), len, nullptr, log.data());
    return runtimeError("shaders/" + what, "link failed: " + std::string(log.c_str()));
  }
  return program;
}

}  // namespace

Expected<Program> computeProgram(const std::string& name, const std::vector<std::string>& defines) {
  Expected<GLuint> cs = compileStage(GL_COMPUTE_SHADER, name, defines);
  if (!cs) return cs.error();
  return link({*cs}, name);
}

Expected<Program> computeProgramFromSource(const std::string& name, const std::string& source) {
  const EmbeddedShader shader{name, source};
  g_override = &shader;
  Expected<Program> p = computeProgram(name);
  g_override = nullptr;
  return p;
}

Expected<Program> renderProgram(const std::string& vertex, const std::string& fragment,
                                const std::vector<std::string>& defines) {
  Expected<GLuint> vs = compileStage(GL_VERTEX_SHADER, vertex, defines);
  if (!vs) return vs.error();
  Expected<GLuint> fs = compileStage(GL_FRAGMENT_SHADER, fragment, defines);
  if (!fs) {
    glDeleteShader(*vs);
    return fs.error();
  }
  return link({*vs, *fs}, vertex + " + " + fragment);
}

GLint uniformLocation(GLuint program, const char* name) {
  const GLint location = glGetUniformLocation(program, name);
  PENUMBRA_CHECK_MSG(location >= 0, "the shader program has no active uniform '{}'", name);
  return location;
}

}  // namespace penumbra::gl
