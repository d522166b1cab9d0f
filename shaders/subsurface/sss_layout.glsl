// std430 buffer layouts of the subsurface passes, shared with src/penumbra/subsurface/sss_gl.h
// (sizes and offsets checked there).

struct GpuSssElement {  // 64 bytes
  vec3 position;
  float eta;  // 0: opaque, no pass 1
  vec3 normal;  // geometric
  float lift;   // shadow rays start this far off the surface along the normal
  vec3 shading_normal;
  float pad0;
  vec3 static_irradiance;  // transmitted, from emissive surfaces and the environment
  float pad1;
};

struct GpuSssNode {  // 32 bytes
  vec3 position;
  float area;
  uint child_first;  // children: children[child_first .. child_first + child_count)
  uint child_count;
  uint pad0, pad1;
};

struct GpuMat3 {  // 48 bytes: three columns, w unused (SssTree::moment_inverse, the gradients)
  vec4 column[3];
};

struct GpuSssLink {  // 32 bytes
  vec3 factor;  // F, RGB
  uint node;
  vec3 offset;  // where in the node its throughput falls, from the node's position
  float pad;
};
