// std430 buffer layouts shared with src/penumbra/raytrace/gpu_layout.h (sizes checked there).

struct BvhNode {  // 32 bytes: the canonical binary node (accel/bvh.h) as is
  vec3 lo;
  uint index;  // inner: children index and index + 1; leaf: first triangle
  vec3 hi;
  uint count;  // 0 for an inner node
};

struct GpuTriangle {  // 48 bytes, in leaf order
  vec3 p0;
  int id;  // index in the input
  vec3 p1;
  float pad1;
  vec3 p2;
  float pad2;
};

struct GpuRay {  // 32 bytes
  vec3 org;
  float tmin;
  vec3 dir;
  float tmax;
};

struct GpuHit {  // 16 bytes
  int triangle;
  float t, u, v;
};
