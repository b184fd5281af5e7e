#version 300 es
// Compositing a received fragment: u_spans holds, per row of its rect,
// (index of the row's first pixel in u_pixels, span begin x, span end x);
// u_pixels the fragments' pixels, one after another; a span's fourth
// value is its fragment's weight shift (a partial sum's pixels are added
// times 2^shift). Sums as lf::Compositor (whole numbers: exact in the
// float target).
precision highp float;
precision highp int;
precision highp usampler2D;
precision highp isampler2D;
uniform usampler2D u_pixels;
uniform isampler2D u_spans;
uniform ivec2 u_rect;  // rect.y, index of its first row in u_spans
out vec4 o;
const int W = 4096;
ivec2 at(int i) { return ivec2(i % W, i / W); }
void main() {
  int xi = int(gl_FragCoord.x), yi = int(gl_FragCoord.y);
  ivec4 row = texelFetch(u_spans, at(u_rect.y + yi - u_rect.x), 0);
  if (xi < row.y || xi >= row.z) discard;
  o = vec4(texelFetch(u_pixels, at(row.x + xi - row.y), 0) << uint(row.w));
}
