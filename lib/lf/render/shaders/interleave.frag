#version 300 es
// lf::interleave_quilt() (lf/render/lenticular.h), the same expressions in the
// same order; output row y is gl_FragCoord.y (read back top row first).
precision highp float;
precision highp int;
uniform highp sampler2D u_quilt;
uniform vec4 u_k;        // pitch, tilt, subp, center
uniform ivec4 u_screen;  // width, height, flip x, inverted views
uniform ivec4 u_layout;  // views, cols, rows, BGR sub-pixels
out vec4 o;
int view_of(float u, float v, int c) {
  float a = (u + float(c) * u_k.z + v * u_k.y) * u_k.x - u_k.w;
  a = a - floor(a);
  if (u_screen.w != 0) a = 1.0 - a;
  return clamp(int(floor(a * float(u_layout.x))), 0, u_layout.x - 1);
}
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  ivec2 size = textureSize(u_quilt, 0);
  int tw = size.x / u_layout.y, th = size.y / u_layout.z;
  float u = (float(p.x) + 0.5) / float(u_screen.x);
  if (u_screen.z != 0) u = 1.0 - u;
  float v = 1.0 - (float(p.y) + 0.5) / float(u_screen.y);
  int ty = min(th - 1, int(floor((1.0 - v) * float(th))));
  int tx = min(tw - 1, int(floor(u * float(tw))));
  vec4 rgb;
  for (int ch = 0; ch < 3; ++ch) {
    int view = view_of(u, v, u_layout.w != 0 ? 2 - ch : ch);
    int col = view - (view / u_layout.y) * u_layout.y, row = view / u_layout.y;
    ivec2 t = ivec2(col * tw + tx, (u_layout.z - 1 - row) * th + ty);
    rgb[ch] = texelFetch(u_quilt, t, 0)[ch];
  }
  o = vec4(rgb.rgb, 1.0);
}
