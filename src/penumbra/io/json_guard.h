// Limits checked on JSON text before a recursive parser sees it. nlohmann::json (the scene
// format and glTF) descends one stack frame per nesting level, so a
// small file nested tens of thousands deep overflows the stack; here the nesting is counted in
// one flat pass and refused with the line and column where the limit is passed.
#pragma once

#include "penumbra/core/expected.h"

#include <cstddef>
#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

namespace penumbra {

// The deepest nesting of arrays and objects accepted: glTF and scene files need fewer than
// ten levels; 256 is far above any real file and far below what overflows a stack.
constexpr size_t kMaxJsonDepth = 256;

// "line L, column C" of the byte at 0-based `offset` of `text`.
std::string lineAndColumn(std::string_view text, size_t offset);

// An input error naming `path` and the place when `text` nests arrays and objects deeper than
// `max_depth`. Strings (with escapes) and, when `comments` is set, // and /* */ comments are
// skipped; nothing else about the JSON is checked (the parser does that).
Status checkJsonNesting(const std::string& path, std::string_view text, bool comments,
                        size_t max_depth = kMaxJsonDepth);

// What a JSON value is, for error messages: "null", "a boolean", "a string", "an array",
// "an object", "a number".
const char* jsonTypeName(const nlohmann::json& j);

}  // namespace penumbra
