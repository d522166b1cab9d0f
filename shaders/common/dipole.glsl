// THE GLSL TWIN of src/penumbra/kernels/dipole.h (fresnelReflectance, fresnelTransmittance,
// DipoleChannel::reflectance): the same operations in the same order, in single precision;
// change both together (Dipole.GlslTwinAgreesWithCpp checks that they agree).
#ifndef PENUMBRA_DIPOLE_GLSL
#define PENUMBRA_DIPOLE_GLSL

// Unpolarised Fresnel reflectance from index n_i into n_t at cos_i; 1 beyond the critical angle.
float fresnelReflectance(float n_i, float n_t, float cos_i) {
  cos_i = clamp(cos_i, 0.0, 1.0);
  float sin_t = n_i / n_t * sqrt(max(0.0, 1.0 - cos_i * cos_i));
  if (sin_t >= 1.0) return 1.0;
  float cos_t = sqrt(max(0.0, 1.0 - sin_t * sin_t));
  float rs = (n_i * cos_i - n_t * cos_t) / (n_i * cos_i + n_t * cos_t);
  float rp = (n_t * cos_i - n_i * cos_t) / (n_t * cos_i + n_i * cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

// F_t(eta, cos theta): the share entering a medium of relative index eta from outside.
float fresnelTransmittance(float eta, float cos_theta) {
  return 1.0 - fresnelReflectance(1.0, eta, cos_theta);
}

// R_d(r) of one channel (Jensen et al. 2001, eq. 4); c = (alpha', sigma_tr, z_r, z_v).
float dipoleReflectance(vec4 c, float r) {
  float r2 = r * r;
  float d_r = sqrt(r2 + c.z * c.z), d_v = sqrt(r2 + c.w * c.w);
  float real = c.z * (c.y * d_r + 1.0) * exp(-c.y * d_r) / (d_r * d_r * d_r);
  float virt = c.w * (c.y * d_v + 1.0) * exp(-c.y * d_v) / (d_v * d_v * d_v);
  return c.x / (4.0 * 3.14159265358979) * (real + virt);
}

#endif
