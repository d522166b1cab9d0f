// std430 buffer layouts of the GPU progressive radiosity solver, shared with
// src/penumbra/radiosity/progressive_gl.h (sizes and offsets checked there with static_assert).

struct GpuProgressiveElement {  // 80 bytes: one kInside atlas texel (ProgressiveRadiosity order)
  vec3 position;                // the CPU's element point: centroid of its exact coverage (m)
  float area;                   // the CPU's exact-coverage area (m^2)
  vec3 reflectance;             // rho per channel
  uint texel;                   // atlas texel index y * width + x
  vec3 normal;                  // unit, its faces' (the side it is on): culling
  uint piece_count;             // its pieces: polygons[8 * piece_first ..], 8 corners each
  vec2 barycentric;             // (w1, w2) of `position` on `triangle`
  uint triangle;                // the scene triangle whose face holds its texel's centre
  uint piece_first;
  vec3 shading_normal;          // unit: the receiver's cosine (a normal map's, else `normal`)
  uint pad;
};

struct GpuProgressiveTriangle {  // 48 bytes: a scene triangle as an occluder
  vec3 p0;
  int front_chart;  // the charts of its front and back faces, -1 for none
  vec3 p1;
  uint tessellation;  // the depth pass's sub-triangle grid: k x k sub-triangles
  vec3 p2;
  int back_chart;
};

struct GpuShooter {     // 8 bytes: a shooter's elements
  uint element_first;   // [element_first, + element_count)
  uint element_count;
};

struct GpuShooterPoint {  // 8 bytes: a cluster of a shooter, a contiguous range of elements
  uint member_first;      // its elements [member_first, + member_count)
  uint member_count;
};

// One shooter point of a batch (std140, 128 bytes), in the uniform block the depth and receiver
// passes share: the points of a batch are the same for every fragment, so they are read as
// uniforms rather than from storage buffers.
struct GpuBatchPoint {
  dvec4 position;   // xyz (m, double: the near-pair test in the CPU's precision), w = area (m^2)
  vec4 position_f;  // xyz as float (the hemisphere's origin), w = area
  vec4 residual;    // area-weighted mean dB of its elements (W m^-2)
  uvec4 members;    // x: first element, y: count, z: its index among the shooter's points
  vec4 eye;         // xyz: where its visibility is taken from, off position_f (cut-outs)
  uvec4 pieces;     // x: its first polygon in point_polygons, y: their count (0: discs only)
  vec4 pad;         // the std140 array stride (a multiple of 32)
};

// MAX_BATCH_POINTS, the points of a batch, is defined by the host (radiosity/hemisphere_gl.h:
// batchPointDefines) for the passes that read the batch.

struct GpuSelection {  // 16 bytes: the winner of the shooter selection
  double power;        // its residual power, luminance (W); 0 when nothing is left
  uint shooter;        // 0xffffffff when nothing is left
  uint pad;
};

struct GpuResolveSums {  // 96 bytes: one work group's share of an iteration's energy (W)
  dvec4 arrived;         // sum incident * area
  dvec4 absorbed;        // sum (1 - rho) incident * area
  dvec4 reflected;       // sum rho incident * area (joins the unshot power)
};
