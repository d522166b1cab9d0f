// Images. The same bytes are read back as each output format (.png, .exr, .hdr, .pfm: readImage),
// and as a texture and a data image (io/image_decode.h) under the name "x.tga", so that bytes
// without a signature are tried as TGA. For textures the header is read and planned first; the
// bytes malloc and new hand out while decoding and building the texture, net of frees, must stay
// within the plan's peak_bytes (ASan's allocator hooks count them). Decoding runs with a size
// limit of 256 and a 512 MiB budget, so that a claim of gigabytes is refused from the plan and
// each input takes at most about a second.
#include "fuzz_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/io/image_decode.h"
#include "penumbra/io/image_io.h"
#include "penumbra/scene/texture.h"

#include <sanitizer/allocator_interface.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace {

// What decoding allocates: counted while `g_counting`, from the hooks ASan calls after each
// allocation and before each free (one thread: the decoders start none).
bool g_counting = false;
int64_t g_live = 0, g_peak = 0;

void countMalloc(const volatile void*, size_t size) {
  if (!g_counting) return;
  g_live += int64_t(size);
  g_peak = std::max(g_peak, g_live);
}

void countFree(const volatile void* p) {
  if (!g_counting || p == nullptr) return;
  g_live -= int64_t(__sanitizer_get_allocated_size(const_cast<const void*>(p)));
}

const int g_hooks = __sanitizer_install_malloc_and_free_hooks(countMalloc, countFree);

struct Counting {
  Counting() {
    g_live = g_peak = 0;
    g_counting = true;
  }
  ~Counting() { g_counting = false; }
};

void expectWithinPlan(const char* what, int64_t peak, const penumbra::ImagePlan& plan) {
  if (uint64_t(peak) > plan.peak_bytes) {
    std::fprintf(stderr, "%s allocated %lld bytes at its peak, more than its plan's %llu\n", what,
                 static_cast<long long>(peak), static_cast<unsigned long long>(plan.peak_bytes));
    std::abort();
  }
}

void fuzzTexture(const std::string& name, std::string_view in,
                 const penumbra::ImageLimits& limits) {
  using namespace penumbra;
  const Expected<ImageHeader> header = readImageHeader(name, in);
  int64_t peak = 0;
  {
    Counting counting;
    Expected<TextureTexels> t = decodeTextureImage(name, in, limits);
    fuzz::expectContract(t, name);
    if (t.ok()) {
      // As io/texture_loader.cpp builds it.
      const Texture texture =
          t->sixteen_bit
              ? Texture::fromRgba16(name, t->width, t->height, t->rgba16, true, t->channels)
              : Texture::fromRgba8(name, t->width, t->height, std::move(t->rgba8), true,
                                   t->channels);
      peak = g_peak;
      if (!header.ok()) std::abort();  // decoding reads the same header
      const ImagePlan plan = planImage(*header, limits);
      if (texture.width() != plan.width || texture.height() != plan.height) std::abort();
    }
  }
  if (header.ok() && peak > 0) expectWithinPlan("a texture", peak, planImage(*header, limits));
  {
    Counting counting;
    const Expected<Image> data = decodeDataImage(name, in, limits);
    fuzz::expectContract(data, name);
    if (data.ok()) {
      if (!header.ok()) std::abort();
      expectWithinPlan("a data image", g_peak, planDataImage(*header, limits));
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  (void)g_hooks;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  for (const char* name : {"x.png", "x.exr", "x.hdr", "x.pfm"}) {
    const std::string path = fuzz::writeInput(name, in);
    fuzz::expectContract(readImage(path), path);
  }
  MemoryBudgetScope budget(uint64_t(512) << 20);
  ImageLimits limits;
  limits.max_size = 256;
  limits.max_seconds = 5;
  fuzzTexture("x.tga", in, limits);
  return 0;
}
