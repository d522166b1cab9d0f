// Shader programs from the GLSL sources embedded at build time (shaders/). A source may pull in
// others with `#include "common/name.glsl"`; `#line` directives keep every line attributable,
// so a compile error names the shader file and line: "shaders/raytrace/x.comp:12: ...".
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"

#include <string>
#include <utility>
#include <vector>

namespace penumbra::gl {

// A source with its #includes expanded, `defines` ("NAME VALUE") inserted after #version, and
// the table from GLSL source-string numbers to file names.
struct ExpandedSource {
  std::string text;
  std::vector<std::string> files;  // files[k] is source-string number k
};
Expected<ExpandedSource> expandShader(const std::string& name,
                                      const std::vector<std::string>& defines = {});

// Rewrites a driver's info log ("0:12(5): error: ...", Mesa; "0(12) : error ...", NVIDIA) so
// that each message names shaders/<file>:<line>.
std::string mapInfoLog(const std::string& log, const std::vector<std::string>& files);

// Compiles and links a compute program from `source` given directly (its #includes come from
// the embedded set); `name` is how errors refer to it.
Expected<Program> computeProgramFromSource(const std::string& name, const std::string& source);

// Compiles and links a compute program.
Expected<Program> computeProgram(const std::string& name,
                                 const std::vector<std::string>& defines = {});
// Compiles and links a vertex + fragment program.
Expected<Program> renderProgram(const std::string& vertex, const std::string& fragment,
                                const std::vector<std::string>& defines = {});

// The location of the active uniform `name` of `program`. A name the program does not have (a
// rename on one side only, or a uniform the compiler dropped as unused) is a programming error:
// it stops with a report naming the uniform instead of setting nothing silently.
GLint uniformLocation(GLuint program, const char* name);

}  // namespace penumbra::gl
