#version 300 es
// Fragment shader's lookup: the run of pixel (x, y), then coord1 and
// gather1 (lf::kernels) on it. The rectangle drawn is the fragment's rect;
// a pixel of it that no run holds is discarded (left 0 or unblended).
// u_scale: 1/255 into an 8-bit target (a fragment), 1 into the float
// accumulation (a whole view).
uniform vec4 u_quad;   // x0, y0, x1, y1 in output pixels
uniform vec4 u_frame;  // origin x, origin y, width, height of the target in output pixels
void main() {
  float px = (gl_VertexID & 1) == 0 ? u_quad.x : u_quad.z;
  float py = (gl_VertexID & 2) == 0 ? u_quad.y : u_quad.w;
  vec2 p = (vec2(px, py) - u_frame.xy) / u_frame.zw;
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
