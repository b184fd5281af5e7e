#version 300 es
precision highp float;
precision highp int;
precision highp usampler2D;
precision highp isampler2D;
uniform usampler2D u_image;
uniform highp sampler2D u_runs;
uniform isampler2D u_rows;
uniform ivec2 u_origin;    // output pixel of the target's pixel (0, 0)
uniform ivec2 u_rect;      // rect.y, index of its first row in the rows table
uniform vec4 u_limits;     // umax, vmax, uclamp, vclamp
uniform vec4 u_focal;      // fx, fy, cx, cy
uniform vec4 u_distort;    // 1/fx, 1/fy, k1, k2
uniform float u_r2max;
uniform bool u_has_distortion;
uniform float u_scale;
uniform isampler2D u_cubic;  // 257 x 1: Keys' taps per phase, 1/4096 (kernels::cubic_taps)
out vec4 o;
const int W = 4096;
ivec2 at(int i) { return ivec2(i % W, i / W); }
// kernels::gather_cubic1: rows first (rounded to levels), then columns.
ivec4 cubic(int iu, int iv, int pu, int pv, int wq) {
  ivec4 h = texelFetch(u_cubic, ivec2(pu, 0), 0), v = texelFetch(u_cubic, ivec2(pv, 0), 0);
  int w = int(u_limits.x + 0.5), ht = int(u_limits.y + 0.5);
  ivec4 acc = ivec4(0);
  for (int j = 0; j < 4; ++j) {
    int y = clamp(iv - 1 + j, 0, ht - 1);
    ivec4 r = ivec4(texelFetch(u_image, ivec2(clamp(iu - 1, 0, w - 1), y), 0)) * h.x +
              ivec4(texelFetch(u_image, ivec2(clamp(iu, 0, w - 1), y), 0)) * h.y +
              ivec4(texelFetch(u_image, ivec2(clamp(iu + 1, 0, w - 1), y), 0)) * h.z +
              ivec4(texelFetch(u_image, ivec2(clamp(iu + 2, 0, w - 1), y), 0)) * h.w + 2048;
    acc += (r >> 12) * v[j];
  }
  acc = clamp((acc + 2048) >> 12, ivec4(0), ivec4(255));
  return (acc * wq + 8192) >> 14;
}
void main() {
  int xi = int(gl_FragCoord.x) + u_origin.x, yi = int(gl_FragCoord.y) + u_origin.y;
  ivec2 row = texelFetch(u_rows, at(u_rect.y + yi - u_rect.x), 0).xy;
  int run = -1;
  bool bicubic = false;
  for (int k = 0; k < row.y; ++k) {
    vec4 box = texelFetch(u_runs, at(4 * (row.x + k)), 0);
    if (float(xi) >= box.x && float(xi) < box.y) {
      run = row.x + k;
      bicubic = box.w > 0.5;
      break;
    }
  }
  if (run < 0) discard;
  vec4 c0 = texelFetch(u_runs, at(4 * run + 1), 0);
  vec4 c1 = texelFetch(u_runs, at(4 * run + 2), 0);
  vec2 c2 = texelFetch(u_runs, at(4 * run + 3), 0).xy;
  float x = float(xi);
  float X = c0.x * x + c0.y, Y = c0.z * x + c0.w, Z = c1.x * x + c1.y;
  float iz = 1.0 / Z;
  float u = X * iz, v = Y * iz;
  bool ok = Z > 0.0;
  if (u_has_distortion) {
    float xn = (u - u_focal.z) * u_distort.x, yn = (v - u_focal.w) * u_distort.y;
    float r2 = xn * xn + yn * yn;
    float f = 1.0 + r2 * (u_distort.z + u_distort.w * r2);
    ok = ok && r2 <= u_r2max;
    u = u_focal.x * (xn * f) + u_focal.z;
    v = u_focal.y * (yn * f) + u_focal.w;
  }
  float w = (c1.z * x + c1.w) / (c2.x * x + c2.y);
  ok = ok && w > 0.0;
  w = w > 1.0 ? 1.0 : w;
  ok = ok && u >= -0.5 && u <= u_limits.x && v >= -0.5 && v <= u_limits.y;
  if (!ok) {
    o = vec4(0.0);
    return;
  }
  u = min(max(u, 0.0), u_limits.z);
  v = min(max(v, 0.0), u_limits.w);
  int iu = int(u), iv = int(v);
  float fu = u - float(iu), fv = v - float(iv);
  float wq = w * 16384.0;
  if (bicubic) {
    ivec4 c = cubic(iu, iv, int(fu * 256.0 + 0.5), int(fv * 256.0 + 0.5), int(wq + 0.5));
    o = vec4(c) * u_scale;
    return;
  }
  float top = (1.0 - fv) * wq, bot = fv * wq;
  int w00 = int((1.0 - fu) * top + 0.5);
  int w01 = int(fu * top + 0.5);
  int w10 = int((1.0 - fu) * bot + 0.5);
  int w11 = int(fu * bot + 0.5);
  ivec4 acc = ivec4(texelFetch(u_image, ivec2(iu, iv), 0)) * w00 +
              ivec4(texelFetch(u_image, ivec2(iu + 1, iv), 0)) * w01 +
              ivec4(texelFetch(u_image, ivec2(iu, iv + 1), 0)) * w10 +
              ivec4(texelFetch(u_image, ivec2(iu + 1, iv + 1), 0)) * w11 + 8192;
  o = vec4(min(acc >> 14, ivec4(255))) * u_scale;
}
