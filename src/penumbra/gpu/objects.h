// Move-only owners of OpenGL objects. Each is created and destroyed on the thread whose context
// is current; a default-constructed owner holds nothing.
#pragma once

#include <epoxy/gl.h>

#include <cstddef>
#include <utility>

namespace penumbra::gl {

// Owns one GL name; `Deleter` releases it.
template <typename Deleter>
class Object {
 public:
  Object() = default;
  explicit Object(GLuint id) : id_(id) {}
  ~Object() { reset(); }
  Object(Object&& o) noexcept : id_(std::exchange(o.id_, 0)) {}
  Object& operator=(Object&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, 0);
    }
    return *this;
  }
  Object(const Object&) = delete;
  Object& operator=(const Object&) = delete;

  GLuint id() const { return id_; }
  explicit operator bool() const { return id_ != 0; }
  void reset() {
    if (id_) Deleter{}(id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

struct BufferDeleter {
  void operator()(GLuint id) const { glDeleteBuffers(1, &id); }
};
struct TextureDeleter {
  void operator()(GLuint id) const { glDeleteTextures(1, &id); }
};
struct FramebufferDeleter {
  void operator()(GLuint id) const { glDeleteFramebuffers(1, &id); }
};
struct RenderbufferDeleter {
  void operator()(GLuint id) const { glDeleteRenderbuffers(1, &id); }
};
struct VertexArrayDeleter {
  void operator()(GLuint id) const { glDeleteVertexArrays(1, &id); }
};
struct ProgramDeleter {
  void operator()(GLuint id) const { glDeleteProgram(id); }
};
struct QueryDeleter {
  void operator()(GLuint id) const { glDeleteQueries(1, &id); }
};

// A buffer with immutable storage (glNamedBufferStorage).
class Buffer : public Object<BufferDeleter> {
 public:
  Buffer() = default;
  // `bytes` of storage, initialised from `data` when given.
  Buffer(size_t bytes, const void* data, GLbitfield flags = GL_DYNAMIC_STORAGE_BIT)
      : Object(create()), bytes_(bytes) {
    glNamedBufferStorage(id(), GLsizeiptr(bytes > 0 ? bytes : 4), data, flags);
  }
  size_t bytes() const { return bytes_; }
  void bindBase(GLenum target, GLuint index) const { glBindBufferBase(target, index, id()); }
  void upload(const void* data, size_t bytes, size_t offset = 0) const {
    glNamedBufferSubData(id(), GLintptr(offset), GLsizeiptr(bytes), data);
  }
  void download(void* data, size_t bytes, size_t offset = 0) const {
    glGetNamedBufferSubData(id(), GLintptr(offset), GLsizeiptr(bytes), data);
  }

 private:
  static GLuint create() {
    GLuint id = 0;
    glCreateBuffers(1, &id);
    return id;
  }
  size_t bytes_ = 0;
};

inline Object<TextureDeleter> createTexture(GLenum target) {
  GLuint id = 0;
  glCreateTextures(target, 1, &id);
  return Object<TextureDeleter>(id);
}
inline Object<FramebufferDeleter> createFramebuffer() {
  GLuint id = 0;
  glCreateFramebuffers(1, &id);
  return Object<FramebufferDeleter>(id);
}
inline Object<RenderbufferDeleter> createRenderbuffer() {
  GLuint id = 0;
  glCreateRenderbuffers(1, &id);
  return Object<RenderbufferDeleter>(id);
}
inline Object<VertexArrayDeleter> createVertexArray() {
  GLuint id = 0;
  glCreateVertexArrays(1, &id);
  return Object<VertexArrayDeleter>(id);
}
inline Object<QueryDeleter> createQuery(GLenum target) {
  GLuint id = 0;
  glCreateQueries(target, 1, &id);
  return Object<QueryDeleter>(id);
}

using Texture = Object<TextureDeleter>;
using Framebuffer = Object<FramebufferDeleter>;
using Renderbuffer = Object<RenderbufferDeleter>;
using VertexArray = Object<VertexArrayDeleter>;
using Program = Object<ProgramDeleter>;
using Query = Object<QueryDeleter>;

// A fence sync object: signalled when the GPU has finished the commands before it.
class Fence {
 public:
  Fence() = default;
  static Fence insert() {
    Fence f;
    f.sync_ = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    return f;
  }
  ~Fence() {
    if (sync_) glDeleteSync(sync_);
  }
  Fence(Fence&& o) noexcept : sync_(std::exchange(o.sync_, nullptr)) {}
  Fence& operator=(Fence&& o) noexcept {
    if (this != &o) {
      if (sync_) glDeleteSync(sync_);
      sync_ = std::exchange(o.sync_, nullptr);
    }
    return *this;
  }
  Fence(const Fence&) = delete;
  Fence& operator=(const Fence&) = delete;

  // True once signalled; flushes so that the fence is sure to signal eventually.
  bool ready() const {
    if (!sync_) return true;
    GLint status = 0;
    glGetSynciv(sync_, GL_SYNC_STATUS, 1, nullptr, &status);
    if (status == GL_SIGNALED) return true;
    glFlush();
    return false;
  }
  // Blocks until signalled.
  void wait() const {
    if (!sync_) return;
    while (glClientWaitSync(sync_, GL_SYNC_FLUSH_COMMANDS_BIT, 1000000000) == GL_TIMEOUT_EXPIRED) {
    }
  }

 private:
  GLsync sync_ = nullptr;
};

}  // namespace penumbra::gl
