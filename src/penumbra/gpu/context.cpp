#include "penumbra/gpu/context.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <spdlog/spdlog.h>

#include <fmt/format.h>
#include <cstdlib>
#include <cstring>

namespace penumbra {

namespace {

constexpr EGLint kConfigAttribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                                     EGL_OPENGL_BIT, EGL_NONE};
constexpr EGLint kContextAttribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                      4,
                                      EGL_CONTEXT_MINOR_VERSION,
                                      5,
                                      EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
#ifndef NDEBUG
                                      EGL_CONTEXT_OPENGL_DEBUG,
                                      EGL_TRUE,
#endif
                                      EGL_NONE};

bool hasExtension(const char* list, const char* name) {
  if (!list) return false;
  const size_t n = std::strlen(name);
  for (const char* p = std::strstr(list, name); p; p = std::strstr(p + n, name)) {
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  }
  return false;
}

#ifndef NDEBUG
void GLAPIENTRY debugCallback(GLenum, GLenum type, GLuint, GLenum severity, GLsizei,
                              const GLchar* message, const void*) {
  if (severity == GL_DEBUG_SEVERITY_NOTIFICATION) return;
  if (type == GL_DEBUG_TYPE_ERROR) {
    spdlog::error("OpenGL: {}", message);
  } else {
    spdlog::debug("OpenGL: {}", message);
  }
}
#endif

GlDeviceInfo queryInfo(const std::string& platform) {
  GlDeviceInfo info;
  info.platform = platform;
  auto str = [](GLenum e) {
    const GLubyte* s = glGetString(e);
    return s ? std::string(reinterpret_cast<const char*>(s)) : std::string();
  };
  info.vendor = str(GL_VENDOR);
  info.renderer = str(GL_RENDERER);
  info.version = str(GL_VERSION);
  GLint64 v64 = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &v64);
  info.max_ssbo_bytes = v64;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &info.max_texture_size);
  glGetIntegerv(GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS, &info.max_compute_invocations);
  for (GLuint i = 0; i < 3; ++i) {
    glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_SIZE, i, &info.max_compute_group_size[i]);
    glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, i, &info.max_compute_group_count[i]);
  }
  GLint shared = 0;
  glGetIntegerv(GL_MAX_COMPUTE_SHARED_MEMORY_SIZE, &shared);
  info.max_compute_shared_bytes = shared;
  info.software = info.renderer.find("llvmpipe") != std::string::npos ||
                  info.renderer.find("softpipe") != std::string::npos;
  return info;
}

// Tries to make a 4.5 core context on `display`; on success it is current.
bool makeContext(EGLDisplay display, EGLContext& context, std::string& why) {
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor)) {
    why = fmt::format("eglInitialize failed (0x{:x})", eglGetError());
    return false;
  }
  if (!eglBindAPI(EGL_OPENGL_API)) {
    why = "no desktop OpenGL API";
    eglTerminate(display);
    return false;
  }
  EGLConfig config = nullptr;
  EGLint count = 0;
  eglChooseConfig(display, kConfigAttribs, &config, 1, &count);
  context = eglCreateContext(display, count > 0 ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT,
                             kContextAttribs);
  if (context == EGL_NO_CONTEXT) {
    why = fmt::format("no OpenGL 4.5 core context (0x{:x})", eglGetError());
    eglTerminate(display);
    return false;
  }
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
    why = fmt::format("eglMakeCurrent failed (0x{:x})", eglGetError());
    eglDestroyContext(display, context);
    eglTerminate(display);
    return false;
  }
  return true;
}

struct Candidate {
  std::string name;
  EGLDisplay display;
};

// The displays to try, in order: each EGL device, then Mesa's surfaceless platform.
std::vector<Candidate> candidates(std::vector<std::string>& failures) {
  std::vector<Candidate> out;
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!client) {
    failures.push_back("EGL: no client extensions (is libEGL installed?)");
    return out;
  }
  if (hasExtension(client, "EGL_EXT_platform_device") &&
      hasExtension(client, "EGL_EXT_device_enumeration")) {
    EGLDeviceEXT devices[16];
    EGLint n = 0;
    if (eglQueryDevicesEXT(16, devices, &n)) {
      for (EGLint i = 0; i < n; ++i) {
        EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (d != EGL_NO_DISPLAY) out.push_back({fmt::format("EGL device {}", i), d});
      }
    }
    if (n == 0) failures.push_back("EGL device platform: no devices");
  } else {
    failures.push_back("EGL device platform: not offered");
  }
  if (hasExtension(client, "EGL_MESA_platform_surfaceless")) {
    EGLDisplay d =
        eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (d != EGL_NO_DISPLAY) out.push_back({"EGL surfaceless", d});
  } else {
    failures.push_back("EGL surfaceless platform: not offered");
  }
  return out;
}

}  // namespace

Expected<std::unique_ptr<GlContext>> GlContext::createHeadless() {
  std::vector<std::string> failures;
  for (const Candidate& c : candidates(failures)) {
    EGLContext context = EGL_NO_CONTEXT;
    std::string why;
    if (!makeContext(c.display, context, why)) {
      failures.push_back(c.name + ": " + why);
      continue;
    }
    std::unique_ptr<GlContext> ctx(new GlContext());
    ctx->display_ = c.display;
    ctx->context_ = context;
    ctx->info_ = queryInfo(c.name);
#ifndef NDEBUG
    glEnable(GL_DEBUG_OUTPUT);
    glEnable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
    glDebugMessageCallback(debugCallback, nullptr);
#endif
    return ctx;
  }
  std::string message = "no OpenGL 4.5 context could be made";
  for (const std::string& f : failures) message += "; " + f;
  return runtimeError("", message);
}

GlContext::~GlContext() {
  if (display_) {
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (context_) eglDestroyContext(display_, context_);
    // The display is shared per device by EGL and may back other contexts: not terminated.
  }
}

bool GlContext::makeCurrent() const {
  return eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_) == EGL_TRUE;
}

GlProbe probeGlDevices() {
  GlProbe probe;
  for (const Candidate& c : candidates(probe.failures)) {
    EGLContext context = EGL_NO_CONTEXT;
    std::string why;
    if (!makeContext(c.display, context, why)) {
      probe.failures.push_back(c.name + ": " + why);
      continue;
    }
    probe.devices.push_back(queryInfo(c.name));
    eglMakeCurrent(c.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(c.display, context);
  }
  return probe;
}

bool glRequired() {
  const char* v = std::getenv("PENUMBRA_REQUIRE_GL");
  return v && std::strcmp(v, "0") != 0 && *v != '\0';
}

}  // namespace penumbra
