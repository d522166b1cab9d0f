// std430 buffer layouts of the GPU Jacobi solver, shared with src/penumbra/radiosity/jacobi_gl.h
// (sizes and offsets checked there). The work-decomposition constants (BLOCK_COLUMNS, LANES,
// WARPS, ROWS_PER_WARP, UPDATE_GROUP, REDUCE_GROUP) come from there too, as #defines.

struct GpuRgb {  // 16 bytes: B per element, and the product's partial sums
  vec3 rgb;
  float pad;
};

struct GpuJacobiElement {  // 32 bytes
  vec3 reflectance;        // rho_i per channel
  float self_form_factor;  // F_ii as stored: diag(M)_ii = 1 - rho_i F_ii
  vec3 emission;           // E_i
  float pad;
};
