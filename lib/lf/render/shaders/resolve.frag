#version 300 es
// lf::Compositor::resolve(): colour = min(sum * (255 / weight) + 0.5, 255),
// truncated; alpha 255 where any weight arrived; all 0 where none did.
precision highp float;
uniform highp sampler2D u_sum;
out vec4 o;
void main() {
  vec4 s = texelFetch(u_sum, ivec2(gl_FragCoord.xy), 0);
  if (s.a == 0.0) {
    o = vec4(0.0);
    return;
  }
  vec3 c = floor(min(s.rgb * (255.0 / s.a) + 0.5, vec3(255.0)));
  o = vec4(c / 255.0, 1.0);
}
