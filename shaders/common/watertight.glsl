// The watertight ray-triangle test of Woop, Benthin and Wald (JCGT 2(1), 2013), the GLSL twin of
// src/penumbra/kernels/ray_triangle.h: same operations in the same order; `precise` forbids
// the fused multiply-adds that would break the antisymmetry of shared edges.

struct WatertightRay {
  vec3 org;
  int kx, ky, kz;
  float sx, sy, sz;
};

WatertightRay makeWatertightRay(vec3 org, vec3 dir) {
  WatertightRay r;
  r.org = org;
  vec3 a = abs(dir);
  r.kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
  r.kx = r.kz + 1 == 3 ? 0 : r.kz + 1;
  r.ky = r.kx + 1 == 3 ? 0 : r.kx + 1;
  if (dir[r.kz] < 0.0) {
    int tmp = r.kx;
    r.kx = r.ky;
    r.ky = tmp;
  }
  precise float sz = 1.0 / dir[r.kz];
  r.sz = sz;
  r.sx = dir[r.kx] * sz;
  r.sy = dir[r.ky] * sz;
  return r;
}

// On a hit within [tmin, tmax] writes t and the barycentrics of p1 (u) and p2 (v).
bool intersectTriangle(WatertightRay r, vec3 p0, vec3 p1, vec3 p2, float tmin, float tmax,
                       out float t_out, out float u_out, out float v_out) {
  precise vec3 a = p0 - r.org;
  precise vec3 b = p1 - r.org;
  precise vec3 c = p2 - r.org;
  precise float ax = a[r.kx] - r.sx * a[r.kz];
  precise float ay = a[r.ky] - r.sy * a[r.kz];
  precise float bx = b[r.kx] - r.sx * b[r.kz];
  precise float by = b[r.ky] - r.sy * b[r.kz];
  precise float cx = c[r.kx] - r.sx * c[r.kz];
  precise float cy = c[r.ky] - r.sy * c[r.kz];
  precise float u = cx * by - cy * bx;
  precise float v = ax * cy - ay * cx;
  precise float w = bx * ay - by * ax;
  if (u == 0.0 || v == 0.0 || w == 0.0) {
    u = float(double(cx) * double(by) - double(cy) * double(bx));
    v = float(double(ax) * double(cy) - double(ay) * double(cx));
    w = float(double(bx) * double(ay) - double(by) * double(ax));
  }
  if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
  precise float det = u + v + w;
  if (det == 0.0) return false;
  precise float az = r.sz * a[r.kz];
  precise float bz = r.sz * b[r.kz];
  precise float cz = r.sz * c[r.kz];
  precise float t_scaled = u * az + v * bz + w * cz;
  if (det > 0.0) {
    if (t_scaled < tmin * det || t_scaled > tmax * det) return false;
  } else {
    if (t_scaled > tmin * det || t_scaled < tmax * det) return false;
  }
  precise float inv_det = 1.0 / det;
  precise float t = t_scaled * inv_det;
  if (!(t >= tmin && t <= tmax)) return false;
  t_out = t;
  u_out = v * inv_det;
  v_out = w * inv_det;
  return true;
}
