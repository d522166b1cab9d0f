// Cut-outs on the GPU (src/penumbra/raytrace/gpu_cutouts.h): whether a hit on a triangle at
// barycentrics (w1, w2) stops there, as SurfaceTextures::stops decides it on the CPU
// (scene/surface_textures.cpp): alpha = the corner factors interpolated, times each lookup's
// channel sampled on the texture's finest level as sampleTexture does (scene/texture.cpp:
// wrap, then bilinear between texel centres or the nearest texel); kMask stops where
// alpha >= cutoff, kBlend with probability alpha (the caller's uniform number `u`).
//
// Needs CUTOUT_SSBO_FIRST, the first of four shader storage binding points (gpu_cutouts.h
// cutoutDefine). Defines CUTOUTS when on.
#ifdef CUTOUT_SSBO_FIRST
#define CUTOUTS 1

struct GpuCutout {  // 80 bytes
  vec2 st[6];       // lookups 0 and 1, corners 0-2
  vec3 factor;      // alpha factor at the corners
  float cutoff;     // kMask: stops where alpha >= cutoff; negative for kBlend
  uvec2 texture;    // the lookups' textures, 0xffffffff for none
  uvec2 pad;
};

layout(std430, binding = CUTOUT_SSBO_FIRST) readonly buffer CutoutIndex { uint cutout_index[]; };
layout(std430, binding = CUTOUT_SSBO_FIRST + 1) readonly buffer Cutouts { GpuCutout cutouts[]; };
// first, width, height, mode (wrap_s | wrap_t << 2 | nearest << 4)
layout(std430, binding = CUTOUT_SSBO_FIRST + 2) readonly buffer CutoutTextures { uvec4 cutout_textures[]; };
layout(std430, binding = CUTOUT_SSBO_FIRST + 3) readonly buffer CutoutTexels { float cutout_texels[]; };

// scene/texture.cpp reduceCoordinate: 0 repeat, 1 clamp to edge, 2 mirrored repeat.
float cutoutReduce(float s, uint wrap) {
  if (isnan(s) || isinf(s)) return 0.0;
  if (wrap == 1u) return clamp(s, -1.0, 2.0);
  if (wrap == 2u) return s - 2.0 * floor(0.5 * s);
  return s - floor(s);
}

// scene/texture.cpp wrapIndex.
int cutoutWrapIndex(int i, int n, uint wrap) {
  if (wrap == 1u) return clamp(i, 0, n - 1);
  if (wrap == 2u) {
    const int period = 2 * n;
    int m = i % period;
    if (m < 0) m += period;
    return m < n ? m : period - 1 - m;
  }
  int m = i % n;
  return m < 0 ? m + n : m;
}

float cutoutTexel(uvec4 t, int x, int y) {
  return cutout_texels[t.x + uint(y) * t.y + uint(x)];
}

float cutoutSample(uint index, vec2 st) {
  const uvec4 t = cutout_textures[index];
  const uint wrap_s = t.w & 3u, wrap_t = (t.w >> 2) & 3u;
  const int w = int(t.y), h = int(t.z);
  const float s = cutoutReduce(st.x, wrap_s), r = cutoutReduce(st.y, wrap_t);
  if ((t.w & 16u) != 0u) {
    return cutoutTexel(t, cutoutWrapIndex(int(floor(s * float(w))), w, wrap_s),
                       cutoutWrapIndex(int(floor(r * float(h))), h, wrap_t));
  }
  const float x = s * float(w) - 0.5, y = r * float(h) - 0.5;
  const float xf = floor(x), yf = floor(y);
  const int x0 = int(xf), y0 = int(yf);
  const float fx = x - xf, fy = y - yf;
  const int xa = cutoutWrapIndex(x0, w, wrap_s), xb = cutoutWrapIndex(x0 + 1, w, wrap_s);
  const int ya = cutoutWrapIndex(y0, h, wrap_t), yb = cutoutWrapIndex(y0 + 1, h, wrap_t);
  const float top = mix(cutoutTexel(t, xa, ya), cutoutTexel(t, xb, ya), fx);
  const float bottom = mix(cutoutTexel(t, xa, yb), cutoutTexel(t, xb, yb), fx);
  return mix(top, bottom, fy);
}

// Whether triangle `tri` may hold a hole at all.
bool cutoutPossible(uint tri) { return cutout_index[tri] != 0xffffffffu; }

bool cutoutStops(uint tri, vec2 b, float u) {
  const uint c = cutout_index[tri];
  if (c == 0xffffffffu) return true;
  const GpuCutout k = cutouts[c];
  const float w0 = 1.0 - b.x - b.y;
  float a = w0 * k.factor.x + b.x * k.factor.y + b.y * k.factor.z;
  for (int j = 0; j < 2; ++j) {
    if (k.texture[j] == 0xffffffffu) continue;
    a *= cutoutSample(k.texture[j], w0 * k.st[3 * j] + b.x * k.st[3 * j + 1] + b.y * k.st[3 * j + 2]);
  }
  return k.cutoff >= 0.0 ? a >= k.cutoff : u < a;
}

// core/rng.h mixBits32 ("lowbias32").
uint cutoutMix(uint x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

// raytrace/cutout_filter.cpp rayHashUniform: the same number for the same ray and triangle.
float cutoutRayUniform(vec3 org, vec3 dir, uint tri) {
  uint h = cutoutMix(tri + 0x9e3779b9u);
  h = cutoutMix(h ^ floatBitsToUint(org.x));
  h = cutoutMix(h ^ floatBitsToUint(org.y));
  h = cutoutMix(h ^ floatBitsToUint(org.z));
  h = cutoutMix(h ^ floatBitsToUint(dir.x));
  h = cutoutMix(h ^ floatBitsToUint(dir.y));
  h = cutoutMix(h ^ floatBitsToUint(dir.z));
  return float(h >> 8) * (1.0 / 16777216.0);
}

#endif
