#include "viewer/viewer.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/timer.h"
#include "penumbra/gpu/storage.h"
#include "penumbra/interactive/live_session.h"
#include "penumbra/interactive/live_settings.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/scene/media.h"
#include "viewer/orbit_camera.h"
#include "viewer/script.h"

#include <epoxy/gl.h>
// GLFW after epoxy: epoxy provides the GL declarations.
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <fmt/format.h>
#include <imgui.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <deque>
#include <optional>
#include <variant>
#include <vector>

namespace penumbra::viewer {

namespace {

// The light's position, if it has one (directional lights have none).
glm::vec3* lightPosition(Light& light) {
  return std::visit(Overloaded{[](DirectionalLight&) -> glm::vec3* { return nullptr; },
                               [](auto& l) -> glm::vec3* { return &l.position; }},
                    light);
}

const char* lightKind(const Light& light) {
  return std::visit(
      Overloaded{[](const PointLight&) { return "point"; }, [](const SpotLight&) { return "spot"; },
                 [](const DirectionalLight&) { return "directional"; },
                 [](const LuminaireLight&) { return "luminaire"; }},
      light);
}

constexpr int kPanelWidth = 320;  // pixels: the side panel, left of the image

float sceneSize(const Scene& scene) {
  Bounds3 b;
  for (const Mesh& m : scene.meshes) b.extend(Bounds3::of(m.positions));
  return b.empty() ? 1.0f : std::max(glm::length(b.extent()), 1e-3f);
}

// The last frames' times (ms) per pass, for the graph.
struct FrameTimes {
  static constexpr size_t kFrames = 240;
  std::deque<float> solve, view, draw;
  void push(std::deque<float>& d, double ms) {
    d.push_back(float(ms));
    if (d.size() > kFrames) d.pop_front();
  }
};

class Viewer {
 public:
  explicit Viewer(const ViewerOptions& options) : options_(options) {}
  ~Viewer();
  Status open();
  Status run();

 private:
  ViewerOptions options_;
  GLFWwindow* window_ = nullptr;
  bool imgui_ = false;
  GLuint texture_ = 0;
  int texture_w_ = 0, texture_h_ = 0;

  Scene scene_;  // as edited: the session takes it on every change
  std::optional<LiveSession> session_;
  LiveMethod method_ = LiveMethod::kPathTrace;
  OrbitCamera orbit_;
  float scene_size_ = 1.0f;
  std::optional<Script> script_;
  std::string error_;            // shown in the window until the next change
  bool session_failed_ = false;  // stop advancing until something changes
  std::string pending_drop_;
  int selected_light_ = -1, selected_material_ = 0;
  int dragging_light_ = -1;
  bool p_was_down_ = false;
  float drag_depth_ = 0.0f;
  std::string status_line_;
  FrameTimes times_;
  double last_build_ms_ = 0.0;

  Status loadScene(const std::string& path, bool keep_camera);
  LiveSettings liveSettings() const;
  void startSession();
  void handleInput();
  void uploadImage();
  void drawPanels();
  // The side panel's sections (drawPanels).
  void drawSessionControls();
  void drawExposure();
  void drawMethodOptions();
  void drawLights();
  bool editLight(Light& light);
  void drawMaterials();
  bool editSubsurface(Material& m);
  void drawFrameTimes();
  void drawLightMarkers();
  Status capture(const std::string& path);
  Status writeStats(const nlohmann::json& frames) const;
  Camera currentCamera() const { return orbit_.camera(); }
  // Where the image goes: the window right of the side panel (the whole window without it).
  struct Rect {
    int x0 = 0, width = 1, height = 1;
  };
  Rect imageRect() const {
    int w = options_.width, h = options_.height;
    if (window_) glfwGetFramebufferSize(window_, &w, &h);
    const int panel = options_.hide_ui ? 0 : std::min(kPanelWidth, w / 2);
    return Rect{panel, std::max(w - panel, 1), std::max(h, 1)};
  }
  void drawError(const Rect& r);
  void lightsChanged() {
    if (session_) session_->setLights(scene_.lights);
    session_failed_ = false;
  }
  void materialsChanged() {
    if (session_) session_->setMaterials(scene_.materials);
    session_failed_ = false;
  }
};

Viewer::~Viewer() {
  // The session's GPU objects go while the window's context is current.
  session_.reset();
  if (texture_) glDeleteTextures(1, &texture_);
  if (imgui_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  if (window_) glfwDestroyWindow(window_);
  glfwTerminate();
}

Status Viewer::loadScene(const std::string& path, bool keep_camera) {
  Expected<Scene> scene = penumbra::loadScene(path);
  if (!scene) return scene.error();
  scene_ = std::move(*scene);
  scene_size_ = sceneSize(scene_);
  if (!keep_camera) orbit_.set(scene_.camera ? *scene_.camera : defaultCamera(scene_));
  selected_light_ = scene_.lights.empty() ? -1 : 0;
  selected_material_ = 0;
  if (window_) glfwSetWindowTitle(window_, fmt::format("Penumbra: {}", scene_.source).c_str());
  return {};
}

// The session's settings from the options, the image's size and the device: `gpu` as asked;
// `auto` the GPU twins when the window's OpenGL is hardware, as `render --device auto` chooses.
LiveSettings Viewer::liveSettings() const {
  LiveSettings s;
  const Rect r = imageRect();
  s.width = r.width;
  s.height = r.height;
  s.spp = options_.spp;
  s.seed = options_.seed;
  s.elements = options_.elements;
  s.iterations = options_.iterations;
  s.lpv = options_.lpv;
  s.gpu = options_.device == "gpu" || (options_.device == "auto" && liveMethodHasGpu(method_) &&
                                       window_ && !gl::softwareRenderer());
  return s;
}

// A new session of the current method on the scene as it is (after a drop, a method change).
void Viewer::startSession() {
  session_.reset();
  session_failed_ = false;
  Expected<LiveSession> session =
      LiveSession::create(scene_, method_, liveSettings(), currentCamera());
  if (!session) {
    error_ = session.error().describe();
    session_failed_ = true;
    return;
  }
  session_.emplace(std::move(*session));
  error_.clear();
}

Status Viewer::open() {
  const std::optional<LiveMethod> method = parseLiveMethod(options_.method);
  if (!method) {
    return inputError(
        "", "--method",
        fmt::format("'{}': use pathtrace, matrix, progressive, stochastic, sss or lpv",
                    options_.method));
  }
  method_ = *method;
  if (!options_.script.empty()) {
    Expected<Script> script = readScript(options_.script);
    if (!script) return script.error();
    script_ = std::move(*script);
  }
  PENUMBRA_TRY(loadScene(options_.scene, false));
  if (script_ && !script_->light_path.empty() &&
      (script_->light >= int(scene_.lights.size()) ||
       !lightPosition(scene_.lights[size_t(script_->light)]))) {
    return inputError(
        options_.script, "light",
        fmt::format("the scene has no light {} with a position to move", script_->light));
  }
  if (!options_.screenshot.empty() && extensionOf(options_.screenshot) != ".png") {
    return inputError(options_.screenshot, "", "a screenshot is a .png file");
  }
  // Where the capture goes is checked before the window runs, not found after its frames.
  if (!options_.screenshot.empty()) {
    PENUMBRA_TRY(checkOutputPath(options_.sequence ? sequenceFrameName(options_.screenshot, 0)
                                                   : options_.screenshot));
  }
  if (!options_.stats.empty()) PENUMBRA_TRY(checkOutputPath(options_.stats));
  // Checked before the window opens: a method the scene cannot take is a usage error.
  {
    Expected<LiveSession> check =
        LiveSession::create(scene_, method_, liveSettings(), currentCamera());
    if (!check) return check.error();
  }

  glfwSetErrorCallback([](int, const char* message) { fmt::print(stderr, "glfw: {}\n", message); });
  if (!glfwInit()) {
    return runtimeError("", "cannot open a window: no display (set DISPLAY, or run under Xvfb)");
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_RESIZABLE, options_.screenshot.empty() ? GLFW_TRUE : GLFW_FALSE);
  window_ = glfwCreateWindow(options_.width, options_.height,
                             fmt::format("Penumbra: {}", scene_.source).c_str(), nullptr, nullptr);
  if (!window_) return runtimeError("", "cannot open an OpenGL 4.5 core window");
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(options_.screenshot.empty() ? 1 : 0);
  glfwSetWindowUserPointer(window_, this);
  glfwSetDropCallback(window_, [](GLFWwindow* w, int count, const char** paths) {
    if (count > 0) static_cast<Viewer*>(glfwGetWindowUserPointer(w))->pending_drop_ = paths[0];
  });

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini next to the user's files
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window_, true);
  ImGui_ImplOpenGL3_Init("#version 450");
  imgui_ = true;
  glGenTextures(1, &texture_);
  glBindTexture(GL_TEXTURE_2D, texture_);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  startSession();
  return {};
}

void Viewer::uploadImage() {
  const Image& image = session_->image();
  const std::vector<uint8_t> bytes = displayBytes(image, options_.tonemap);
  glBindTexture(GL_TEXTURE_2D, texture_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (image.width != texture_w_ || image.height != texture_h_) {
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, image.width, image.height, 0, GL_RGB, GL_UNSIGNED_BYTE,
                 bytes.data());
    texture_w_ = image.width;
    texture_h_ = image.height;
  } else {
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, image.width, image.height, GL_RGB, GL_UNSIGNED_BYTE,
                    bytes.data());
  }
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
}

void Viewer::handleInput() {
  ImGuiIO& io = ImGui::GetIO();
  const Rect r = imageRect();
  const int w = r.width, h = r.height;
  const Camera before = currentCamera();
  const glm::vec2 delta(io.MouseDelta.x, io.MouseDelta.y);
  const glm::vec2 mouse(io.MousePos.x - float(r.x0), io.MousePos.y);
  if (!io.WantCaptureMouse) {
    const CameraRays rays(before, w, h);
    if (ImGui::IsMouseClicked(ImGuiMouseButton_Left)) {
      // A light's marker under the mouse: drag the light.
      dragging_light_ = -1;
      for (size_t k = 0; k < scene_.lights.size(); ++k) {
        glm::vec3* p = lightPosition(scene_.lights[k]);
        float depth = 0.0f;
        const std::optional<glm::vec2> at = p ? rays.project(*p, &depth) : std::nullopt;
        if (at && glm::length(*at - mouse) < 10.0f) {
          dragging_light_ = int(k);
          selected_light_ = int(k);
          drag_depth_ = depth;
        }
      }
    }
    if (ImGui::IsMouseDown(ImGuiMouseButton_Left) && dragging_light_ >= 0) {
      if (delta != glm::vec2(0.0f)) {
        *lightPosition(scene_.lights[size_t(dragging_light_)]) =
            rays.unproject(mouse.x, mouse.y, drag_depth_);
        lightsChanged();
      }
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Left) && !io.KeyShift) {
      orbit_.orbit(delta, float(h));
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Middle) ||
               (ImGui::IsMouseDown(ImGuiMouseButton_Left) && io.KeyShift)) {
      orbit_.pan(delta, float(h));
    } else if (ImGui::IsMouseDown(ImGuiMouseButton_Right)) {
      orbit_.look(delta, float(h));
    }
    if (!ImGui::IsMouseDown(ImGuiMouseButton_Left)) dragging_light_ = -1;
    if (io.MouseWheel != 0.0f) orbit_.dolly(io.MouseWheel);
  }
  const bool p_down = glfwGetKey(window_, GLFW_KEY_P) == GLFW_PRESS;
  const bool p_pressed = p_down && !p_was_down_;
  p_was_down_ = p_down;
  if (!io.WantCaptureKeyboard) {
    auto down = [&](int key) { return glfwGetKey(window_, key) == GLFW_PRESS ? 1.0f : 0.0f; };
    const glm::vec3 move(down(GLFW_KEY_D) - down(GLFW_KEY_A), down(GLFW_KEY_E) - down(GLFW_KEY_Q),
                         down(GLFW_KEY_W) - down(GLFW_KEY_S));
    // Half the scene's size per second.
    if (move != glm::vec3(0.0f)) orbit_.fly(move, 0.5f * scene_size_ * io.DeltaTime);
    if (p_pressed) {
      const std::string path = fmt::format("penumbra_{}.png", int(glfwGetTime() * 1000.0));
      const Status s = capture(path);
      status_line_ = s.ok() ? "wrote " + path : s.error().describe();
    }
  }
  if (session_) {
    session_->setCamera(currentCamera());
    session_->setSize(w, h);
  }
}

void Viewer::drawLightMarkers() {
  const Rect r = imageRect();
  const CameraRays rays(currentCamera(), r.width, r.height);
  ImDrawList* draw = ImGui::GetForegroundDrawList();
  for (size_t k = 0; k < scene_.lights.size(); ++k) {
    glm::vec3* p = lightPosition(scene_.lights[k]);
    const std::optional<glm::vec2> at = p ? rays.project(*p) : std::nullopt;
    if (!at) continue;
    const ImU32 colour =
        int(k) == selected_light_ ? IM_COL32(255, 210, 60, 255) : IM_COL32(255, 255, 255, 200);
    const ImVec2 centre(at->x + float(r.x0), at->y);
    draw->AddCircle(centre, 8.0f, colour, 16, 2.0f);
    draw->AddCircleFilled(centre, 3.0f, colour);
  }
}

void Viewer::drawPanels() {
  const Rect r = imageRect();
  ImGui::SetNextWindowPos(ImVec2(0, 0));
  ImGui::SetNextWindowSize(ImVec2(float(r.x0), float(r.height)));
  ImGui::Begin("Penumbra", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  drawSessionControls();
  if (ImGui::CollapsingHeader("method options")) drawMethodOptions();
  if (ImGui::CollapsingHeader("exposure", ImGuiTreeNodeFlags_DefaultOpen)) drawExposure();
  if (ImGui::CollapsingHeader("lights", ImGuiTreeNodeFlags_DefaultOpen)) drawLights();
  if (ImGui::CollapsingHeader("materials")) drawMaterials();
  if (ImGui::CollapsingHeader("frame times (ms)", ImGuiTreeNodeFlags_DefaultOpen)) {
    drawFrameTimes();
  }
  ImGui::End();
  if (!error_.empty()) drawError(r);
}

// The scene's name, the method, restart and screenshot, and the session's status.
void Viewer::drawSessionControls() {
  ImGui::TextUnformatted(scene_.source.c_str());
  int method = int(method_);
  std::array<const char*, 6> names{};
  for (LiveMethod m : kLiveMethods) names[size_t(m)] = liveMethodName(m).data();
  if (ImGui::Combo("method", &method, names.data(), int(names.size()))) {
    method_ = LiveMethod(method);
    startSession();
  }
  if (session_) ImGui::TextWrapped("%s", session_->status().c_str());
  if (ImGui::Button("restart")) startSession();
  ImGui::SameLine();
  if (ImGui::Button("screenshot (P)")) {
    const std::string path = fmt::format("penumbra_{}.png", int(glfwGetTime() * 1000.0));
    const Status s = capture(path);
    status_line_ = s.ok() ? "wrote " + path : s.error().describe();
  }
  if (!status_line_.empty()) ImGui::TextWrapped("%s", status_line_.c_str());
}

// The live method's options, from their descriptions (interactive/live_settings.h): each one's
// value (the method's default until set), its range and help; a value is checked as `render`
// checks it, and a change restarts the session.
void Viewer::drawMethodOptions() {
  LiveSettings settings = liveSettings();
  bool changed = false;
  for (const OptionSpec* spec : liveOptionSpecs(method_)) {
    const OptionValue current = liveOptionValue(settings, method_, *spec);
    const std::string label =
        spec->unit.empty() ? spec->name : fmt::format("{} ({})", spec->name, spec->unit);
    ImGui::PushID(spec->name.c_str());
    OptionValue edited = current;
    bool edit = false;
    if (const int64_t* i = std::get_if<int64_t>(&current)) {
      int64_t v = *i;
      edit = ImGui::InputScalar(label.c_str(), ImGuiDataType_S64, &v, nullptr, nullptr, nullptr,
                                ImGuiInputTextFlags_EnterReturnsTrue);
      edited = v;
    } else if (const uint64_t* u = std::get_if<uint64_t>(&current)) {
      uint64_t v = *u;
      edit = ImGui::InputScalar(label.c_str(), ImGuiDataType_U64, &v, nullptr, nullptr, nullptr,
                                ImGuiInputTextFlags_EnterReturnsTrue);
      edited = v;
    }
    if (ImGui::IsItemHovered()) {
      const std::optional<OptionRange> range = spec->rangeFor(std::string(liveMethodName(method_)));
      ImGui::SetTooltip("%s%s", spec->help.c_str(),
                        range ? fmt::format(" {}", range->describe()).c_str() : "");
    }
    ImGui::PopID();
    if (!edit || edited == current) continue;
    const Status s = setLiveOption(settings, method_, *spec, edited);
    if (!s) {
      status_line_ = s.error().describe();
      continue;
    }
    changed = true;
  }
  if (!changed) return;
  options_.spp = settings.spp;
  options_.seed = settings.seed;
  options_.elements = settings.elements;
  options_.iterations = settings.iterations;
  options_.lpv = settings.lpv;
  status_line_.clear();
  startSession();
}

void Viewer::drawExposure() {
  int op = options_.tonemap.op == ToneMapOperator::kReinhard ? 0 : 1;
  const char* ops[] = {"Reinhard (automatic key)", "exposure"};
  bool changed = ImGui::Combo("operator", &op, ops, 2);
  options_.tonemap.op = op == 0 ? ToneMapOperator::kReinhard : ToneMapOperator::kExposure;
  changed |= ImGui::SliderFloat("stops", &options_.tonemap.exposure_stops, -10.0f, 10.0f);
  if (changed && session_) uploadImage();
}

// The list of lights, adding a point light, and the selected light's editor.
void Viewer::drawLights() {
  if (scene_.lights.empty()) ImGui::TextUnformatted("(emitting surfaces only)");
  for (size_t k = 0; k < scene_.lights.size(); ++k) {
    const std::string label = fmt::format("{} {}", lightKind(scene_.lights[k]), k);
    if (ImGui::Selectable(label.c_str(), selected_light_ == int(k))) selected_light_ = int(k);
  }
  if (ImGui::Button("add point light")) {
    const Camera c = currentCamera();
    scene_.lights.push_back(PointLight{c.look_at + 0.25f * scene_size_ * c.up, glm::vec3(1.0f)});
    selected_light_ = int(scene_.lights.size() - 1);
    lightsChanged();
  }
  if (selected_light_ >= 0 && selected_light_ < int(scene_.lights.size())) {
    if (editLight(scene_.lights[size_t(selected_light_)])) lightsChanged();
  }
}

// The light's position (or direction) and power; true when changed.
bool Viewer::editLight(Light& light) {
  bool changed = false;
  const float step = 0.005f * scene_size_;
  std::visit(
      Overloaded{
          [&](PointLight& p) {
            changed |= ImGui::DragFloat3("position", &p.position.x, step);
            changed |= ImGui::ColorEdit3("intensity W/sr", &p.intensity.x,
                                         ImGuiColorEditFlags_HDR | ImGuiColorEditFlags_Float);
          },
          [&](SpotLight& p) {
            changed |= ImGui::DragFloat3("position", &p.position.x, step);
            changed |= ImGui::ColorEdit3("intensity W/sr", &p.intensity.x,
                                         ImGuiColorEditFlags_HDR | ImGuiColorEditFlags_Float);
          },
          [&](DirectionalLight& d) {
            if (ImGui::DragFloat3("direction", &d.direction.x, 0.01f) &&
                glm::length(d.direction) > 1e-6f) {
              d.direction = glm::normalize(d.direction);
              changed = true;
            }
            changed |= ImGui::ColorEdit3("irradiance W/m2", &d.irradiance.x,
                                         ImGuiColorEditFlags_HDR | ImGuiColorEditFlags_Float);
          },
          [&](LuminaireLight& p) {
            changed |= ImGui::DragFloat3("position", &p.position.x, step);
            changed |= ImGui::ColorEdit3("scale", &p.scale.x,
                                         ImGuiColorEditFlags_HDR | ImGuiColorEditFlags_Float);
          }},
      light);
  return changed;
}

// The list of materials and the selected material's editor.
void Viewer::drawMaterials() {
  for (size_t k = 0; k < scene_.materials.size(); ++k) {
    const std::string label =
        scene_.materials[k].name.empty() ? fmt::format("material {}", k) : scene_.materials[k].name;
    if (ImGui::Selectable(fmt::format("{}##{}", label, k).c_str(), selected_material_ == int(k))) {
      selected_material_ = int(k);
    }
  }
  if (selected_material_ < int(scene_.materials.size())) {
    Material& m = scene_.materials[size_t(selected_material_)];
    bool changed = ImGui::ColorEdit3("reflectance", &m.reflectance.x, ImGuiColorEditFlags_Float);
    changed |= ImGui::ColorEdit3("emission", &m.emission.x,
                                 ImGuiColorEditFlags_HDR | ImGuiColorEditFlags_Float);
    changed |= ImGui::Checkbox("two-sided", &m.two_sided);
    changed |= editSubsurface(m);
    if (changed) materialsChanged();
  }
}

// The material's medium: opaque, a preset, or its coefficients edited; true when changed.
bool Viewer::editSubsurface(Material& m) {
  bool changed = false;
  const std::span<const char* const> presets = subsurfacePresetNames();
  int preset = -1;
  if (m.subsurface) {
    for (size_t p = 0; p < presets.size(); ++p) {
      if (m.subsurface->preset == presets[p]) preset = int(p);
    }
  }
  const char* shown = m.subsurface ? (preset >= 0 ? presets[size_t(preset)] : "custom") : "opaque";
  if (ImGui::BeginCombo("subsurface", shown)) {
    if (ImGui::Selectable("opaque", !m.subsurface)) {
      m.subsurface.reset();
      changed = true;
    }
    for (size_t p = 0; p < presets.size(); ++p) {
      if (ImGui::Selectable(presets[p], preset == int(p))) {
        m.subsurface = subsurfacePreset(presets[p]);
        changed = true;
      }
    }
    ImGui::EndCombo();
  }
  if (m.subsurface) {
    // Shown per millimetre, as the scene format and Jensen et al.'s table give them.
    glm::vec3 s = glm::vec3(m.subsurface->sigma_s_prime * 1e-3);
    glm::vec3 a = glm::vec3(m.subsurface->sigma_a * 1e-3);
    float eta = float(m.subsurface->eta);
    bool medium = ImGui::DragFloat3("sigma_s' /mm", &s.x, 0.01f, 1e-4f, 1e3f);
    medium |= ImGui::DragFloat3("sigma_a /mm", &a.x, 0.0005f, 0.0f, 1e3f);
    medium |= ImGui::DragFloat("eta", &eta, 0.005f, 1.0f, 3.0f);
    if (medium) {
      m.subsurface->sigma_s_prime = glm::max(glm::dvec3(s) * 1e3, glm::dvec3(1e-1));
      m.subsurface->sigma_a = glm::max(glm::dvec3(a) * 1e3, glm::dvec3(0.0));
      m.subsurface->eta = std::clamp(double(eta), 1.0, 3.0);
      m.subsurface->preset.clear();
      changed = true;
    }
  }
  return changed;
}

void Viewer::drawFrameTimes() {
  auto plot = [](const char* label, const std::deque<float>& d) {
    const std::vector<float> v(d.begin(), d.end());
    const float last = v.empty() ? 0.0f : v.back();
    ImGui::PlotLines(fmt::format("{} {:.1f}", label, last).c_str(), v.data(), int(v.size()), 0,
                     nullptr, 0.0f, FLT_MAX, ImVec2(0, 36));
  };
  plot("solve", times_.solve);
  plot("view", times_.view);
  plot("draw", times_.draw);
  if (last_build_ms_ > 0.0) ImGui::Text("last build %.0f ms", last_build_ms_);
  ImGui::Text("%.1f frames per second", ImGui::GetIO().Framerate);
}

// The last error, in a window of its own beside the panel, until dismissed.
void Viewer::drawError(const Rect& r) {
  ImGui::SetNextWindowPos(ImVec2(float(r.x0 + 10), 10), ImGuiCond_FirstUseEver);
  ImGui::Begin("error");
  ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.45f, 0.4f, 1.0f));
  ImGui::TextWrapped("%s", error_.c_str());
  ImGui::PopStyleColor();
  if (ImGui::Button("dismiss")) error_.clear();
  ImGui::End();
}

Status Viewer::capture(const std::string& path) {
  int w = 1, h = 1;
  glfwGetFramebufferSize(window_, &w, &h);
  std::vector<uint8_t> rgb(size_t(w) * size_t(h) * 3), row(size_t(w) * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  // OpenGL's rows go bottom up.
  for (int y = 0; y < h / 2; ++y) {
    uint8_t* a = rgb.data() + size_t(y) * row.size();
    uint8_t* b = rgb.data() + size_t(h - 1 - y) * row.size();
    std::copy(a, a + row.size(), row.begin());
    std::copy(b, b + row.size(), a);
    std::copy(row.begin(), row.end(), b);
  }
  return writePng8(path, w, h, rgb);
}

Status Viewer::run() {
  const bool capturing = !options_.screenshot.empty();
  const int frames = capturing ? std::max(options_.frames, 1) : 0;
  // Dear ImGui lays a new window out in its first frame and shows it from the second: a capture
  // with the panels draws two more frames of the last state.
  const int last = frames - 1 + (options_.hide_ui ? 0 : 2);
  nlohmann::json frame_stats = nlohmann::json::array();
  for (int loop = 0; !glfwWindowShouldClose(window_); ++loop) {
    const Timer frame_timer;
    LiveStep work;
    const int frame = std::min(loop, std::max(frames - 1, 0));
    glfwPollEvents();
    if (!pending_drop_.empty()) {
      const std::string path = std::exchange(pending_drop_, std::string());
      const Status s = loadScene(path, false);
      if (s.ok()) {
        startSession();
      } else {
        error_ = s.error().describe();
      }
    }
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    if (!capturing) handleInput();
    if (capturing && script_ && loop == script_->drop_frame) pending_drop_ = script_->drop_file;
    if (capturing && script_) {
      // (A dropped scene may have no such light.)
      const std::optional<glm::vec3> p = script_->lightAt(frame, frames);
      glm::vec3* moved = p && script_->light < int(scene_.lights.size())
                             ? lightPosition(scene_.lights[size_t(script_->light)])
                             : nullptr;
      if (moved) {
        *moved = *p;
        lightsChanged();
      }
      if (const std::optional<CameraKey> c = script_->cameraAt(frame, frames)) {
        Camera cam = currentCamera();
        cam.position = c->position;
        cam.look_at = c->look_at;
        orbit_.set(cam);
        if (session_) session_->setCamera(currentCamera());
      }
    }
    if (session_ && !session_failed_ && !session_->done()) {
      // A capture finishes each frame's work (unless --live); the window works within its
      // budget.
      Expected<LiveStep> step =
          session_->advance(capturing && !options_.live ? 0.0 : options_.budget);
      if (!step) {
        error_ = step.error().describe();
        session_failed_ = true;
        if (capturing) return step.error();
      } else {
        times_.push(times_.solve, 1e3 * step->solve_seconds);
        times_.push(times_.view, 1e3 * step->view_seconds);
        if (step->build_seconds > 0.0) last_build_ms_ = 1e3 * step->build_seconds;
        if (step->image_changed) uploadImage();
        work = *step;
      }
    }
    const Timer draw_timer;
    int w = 1, h = 1;
    glfwGetFramebufferSize(window_, &w, &h);
    const Rect image = imageRect();
    ImGui::GetBackgroundDrawList()->AddImage(
        reinterpret_cast<ImTextureID>(static_cast<intptr_t>(texture_)),
        ImVec2(float(image.x0), 0.0f), ImVec2(float(image.x0 + image.width), float(image.height)));
    if (!options_.hide_ui) {
      drawPanels();
      drawLightMarkers();
    }
    ImGui::Render();
    glViewport(0, 0, w, h);
    glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    times_.push(times_.draw, 1e3 * draw_timer.seconds());
    if (capturing && options_.sequence && loop < frames) {
      PENUMBRA_TRY(capture(sequenceFrameName(options_.screenshot, frame)));
    }
    if (capturing && loop == last) {
      if (!options_.sequence) PENUMBRA_TRY(capture(options_.screenshot));
      if (!options_.stats.empty()) PENUMBRA_TRY(writeStats(frame_stats));
      return {};
    }
    glfwSwapBuffers(window_);
    frame_stats.push_back({{"build_ms", 1e3 * work.build_seconds},
                           {"solve_ms", 1e3 * work.solve_seconds},
                           {"view_ms", 1e3 * work.view_seconds},
                           {"draw_ms", times_.draw.back()},
                           {"frame_ms", 1e3 * frame_timer.seconds()}});
  }
  return {};
}

Status Viewer::writeStats(const nlohmann::json& frames) const {
  double sum = 0.0;
  for (const nlohmann::json& f : frames) sum += f["frame_ms"].get<double>();
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  nlohmann::json j = {
      {"method", liveMethodName(method_)},
      {"scene", scene_.source},
      {"renderer", renderer ? renderer : ""},
      {"live", options_.live},
      {"device", session_ && session_->settings().gpu ? "gpu" : "cpu"},
      {"budget_ms", 1e3 * options_.budget},
      {"width", options_.width},
      {"height", options_.height},
      {"status", session_ ? session_->status() : std::string()},
      {"error", error_},
      {"frames", frames},
      {"frames_per_second", frames.empty() ? 0.0 : 1e3 * double(frames.size()) / sum}};
  return writeStatsFile(options_.stats, j);
}

}  // namespace

Status runViewer(const ViewerOptions& options) {
  Viewer viewer(options);
  PENUMBRA_TRY(viewer.open());
  return viewer.run();
}

}  // namespace penumbra::viewer
