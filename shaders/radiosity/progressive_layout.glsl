// std430 buffer layouts of the GPU progressive radiosity solver, shared with
// src/penumbra/radiosity/progressive_gl.h (sizes and offsets checked there with static_assert).

struct GpuProgressiveElement {  // 48 bytes: one kInside atlas texel (ProgressiveRadiosity order)
  vec3 position;                // the CPU's element point: centroid of its exact coverage (m)
  float area;                   // the CPU's exact-coverage area (m^2)
  vec3 reflectance;             // rho per channel
  uint texel;                   // atlas texel index y * width + x
  vec2 barycentric;             // (w1, w2) of `position` on its triangle
  uint triangle;                // flattenScene order
  uint polygon;                 // its clipped texel polygon in polygons[8 * polygon ..], or
                                // 0xffffffff for a whole texel square (around `position`)
};

struct GpuProgressiveTriangle {  // 112 bytes
  vec3 p0;
  float area;  // m^2
  vec3 p1;
  int leg;  // chart leg (texels)
  vec3 p2;
  uint right;  // the corner at the chart's right angle
  vec3 normal;  // unit front normal, zero for degenerate triangles
  uint tessellation;  // the depth pass's sub-triangle grid: k x k sub-triangles
  vec2 uv[3];         // lightmap UVs of the corners (atlas.uvs[3 t + k])
  uint element_first;
  uint element_count;
  ivec2 corner;  // the chart: texel of lattice point (0, 0), and the legs' directions
  ivec2 axis;
};

struct GpuShooterPoint {  // 8 bytes: a shooter element or 2^level x 2^level block
  uint member_first;      // its elements: members[member_first .. + member_count)
  uint member_count;
};

// One shooter point of a batch (std140, 96 bytes), in the uniform block the depth and receiver
// passes share: the points of a batch are the same for every fragment, so they are read as
// uniforms rather than from storage buffers.
struct GpuBatchPoint {
  dvec4 position;   // xyz (m, double: the near-pair test in the CPU's precision), w = area (m^2)
  vec4 position_f;  // xyz as float (the hemisphere's origin), w = area
  vec4 residual;    // area-weighted mean dB of its elements (W m^-2)
  uvec4 members;    // x: first in members[], y: count
};

#define MAX_BATCH_POINTS 16

struct GpuSelection {  // 16 bytes: the winner of the shooter selection
  double power;        // its residual power, luminance (W); 0 when nothing is left
  uint triangle;       // 0xffffffff when nothing is left
  uint pad;
};

struct GpuResolveSums {  // 96 bytes: one work group's share of an iteration's energy (W)
  dvec4 arrived;         // sum incident * area
  dvec4 absorbed;        // sum (1 - rho) incident * area
  dvec4 reflected;       // sum rho incident * area (joins the unshot power)
};
