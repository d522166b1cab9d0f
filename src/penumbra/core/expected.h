// Bad input and environment failures are values: Expected<T> holds either a T or an Error that
// names the file, the place in it and what is wrong. The command line turns an Error into one
// line on stderr and exit code 2 (bad input) or 1 (run-time failure).
#pragma once

#include <fmt/core.h>

#include <string>
#include <utility>
#include <variant>

namespace penumbra {

enum class ErrorKind {
  kInput,    // bad file, bad option value, unknown scene: exit code 2
  kRuntime,  // the work could not be done (out of memory, I/O failure): exit code 1
};

struct Error {
  ErrorKind kind = ErrorKind::kInput;
  std::string file;   // the file the problem is in, empty when none
  std::string place;  // where in the file ("line 12", "vertex 3", "meshes[0].material")
  std::string message;
  // In a run over several processes (cluster/communicator.h), only rank 0 prints errors, except
  // one that only this rank has (agreeReady sets it).
  bool report_on_this_rank = false;

  // "file: place: message", leaving out what is empty.
  std::string describe() const {
    std::string out;
    if (!file.empty()) out += file + ": ";
    if (!place.empty()) out += place + ": ";
    out += message;
    return out;
  }
};

inline Error inputError(std::string file, std::string place, std::string message) {
  return Error{ErrorKind::kInput, std::move(file), std::move(place), std::move(message)};
}
inline Error runtimeError(std::string file, std::string message) {
  return Error{ErrorKind::kRuntime, std::move(file), {}, std::move(message)};
}

// A minimal std::expected (C++23) for C++20.
template <typename T>
class [[nodiscard]] Expected {
 public:
  Expected(T value) : v_(std::in_place_index<0>, std::move(value)) {}
  Expected(Error error) : v_(std::in_place_index<1>, std::move(error)) {}

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & { return std::get<0>(v_); }
  const T& value() const& { return std::get<0>(v_); }
  T&& value() && { return std::get<0>(std::move(v_)); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  const Error& error() const { return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

// Expected<void>: success or an Error.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}
  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const { return error_; }

 private:
  Error error_;
  bool ok_ = true;
};

}  // namespace penumbra

// Propagate an error from an expression returning Status or Expected<T>.
#define PENUMBRA_TRY(expr)                                 \
  do {                                                     \
    auto&& penumbra_try_ = (expr);                         \
    if (!penumbra_try_.ok()) return penumbra_try_.error(); \
  } while (false)
