// A program on the installed library: it includes only <penumbra/penumbra.h> and links
// Penumbra::penumbra (CMake) or `pkg-config --libs penumbra`. It renders the Cornell box at 16
// samples per pixel, 32 x 32, prints the image's mean, checks what the physics says about it and
// that bad input comes back as an exception of the input kind; it exits non-zero if any check
// fails. tests/package/consume.sh builds and runs it against an install tree.
#include <penumbra/penumbra.h>

#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

namespace {

// The mean luminance (Rec. 709 weights, W m^-2 sr^-1) of this render as measured when the
// example was written (mean rgb 0.1983 0.1284 0.0367), and the band around it a render must fall
// in: a regression check. The physical bounds are checked on their own.
constexpr double kExpectedMeanLuminance = 0.1366;
constexpr double kTolerance = 0.15;
// The emitted radiance of the box's one light (its "light" material). The light fills a small
// part of the view and every other surface reflects less than it receives (albedo < 1), so the
// image's mean lies between zero and this, channel by channel.
constexpr double kLightEmission[3] = {17.0, 12.0, 4.0};

int failures = 0;

void check(bool ok, const std::string& what) {
  if (!ok) {
    std::fprintf(stderr, "FAILED: %s\n", what.c_str());
    ++failures;
  }
}

void checkRender() {
  const penumbra::api::Scene scene = penumbra::api::Scene::load("cornell");
  const penumbra::api::Result result = penumbra::api::render(
      scene, penumbra::api::Options{{"spp", 16}, {"width", 32}, {"height", 32}, {"quiet", true}});
  check(result.images.size() == 1, "render gives one image");
  if (result.images.empty()) return;
  const penumbra::api::Image& image = result.images.front();
  std::printf("image %d x %d\n", image.width, image.height);
  check(image.width == 32 && image.height == 32, "the image is 32 x 32");
  check(image.rgb.size() == size_t(image.width) * size_t(image.height) * 3,
        "three values per pixel");
  if (image.rgb.empty()) return;

  double sum[3] = {0.0, 0.0, 0.0};
  bool finite = true;
  bool non_negative = true;
  for (size_t i = 0; i < image.rgb.size(); ++i) {
    const float v = image.rgb[i];
    finite = finite && std::isfinite(v);
    non_negative = non_negative && v >= 0.0f;
    sum[i % 3] += v;
  }
  check(finite, "every value is finite");
  check(non_negative, "no value is negative");
  const double pixels = double(image.rgb.size() / 3);
  const double mean[3] = {sum[0] / pixels, sum[1] / pixels, sum[2] / pixels};
  const double luminance = 0.2126 * mean[0] + 0.7152 * mean[1] + 0.0722 * mean[2];
  std::printf("mean rgb %.6f %.6f %.6f, luminance %.6f\n", mean[0], mean[1], mean[2], luminance);
  for (int c = 0; c < 3; ++c) {
    check(mean[c] > 0.0, "the mean of channel " + std::to_string(c) + " is positive");
    check(mean[c] < kLightEmission[c],
          "the mean of channel " + std::to_string(c) + " is below the light's emission");
  }
  check(std::abs(luminance - kExpectedMeanLuminance) <= kTolerance * kExpectedMeanLuminance,
        "the mean luminance " + std::to_string(luminance) + " is within " +
            std::to_string(int(kTolerance * 100)) + "% of " +
            std::to_string(kExpectedMeanLuminance));
}

void checkBadInput() {
  const std::string path = "/nonexistent.obj";
  try {
    penumbra::api::Scene::load(path);
    check(false, "loading " + path + " throws");
  } catch (const penumbra::api::Error& e) {
    std::printf("error as expected: %s\n", e.what());
    check(e.kind() == penumbra::api::ErrorKind::kInput, "a missing file is an input error");
    check(std::string(e.what()).find(path) != std::string::npos, "the message names the file");
  }
}

}  // namespace

int main() {
  try {
    std::printf("penumbra %s\n", penumbra::api::version().c_str());
#ifdef PENUMBRA_EXPECTED_VERSION
    check(penumbra::api::version() == PENUMBRA_EXPECTED_VERSION,
          std::string("the library's version is the package's, ") + PENUMBRA_EXPECTED_VERSION);
#endif
    checkRender();
    checkBadInput();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "FAILED: unexpected exception: %s\n", e.what());
    return 1;
  }
  if (failures > 0) {
    std::fprintf(stderr, "%d check(s) failed\n", failures);
    return 1;
  }
  std::printf("all checks passed\n");
  return 0;
}
