// The renderer's GLSL program. The layout constants come from gpu_rig.hpp, #defined in front of
// the sources, so the shaders and the C++ packing cannot disagree.
#include "shaders.hpp"

#include <sstream>
#include <string>

#include "facecast/core/error.hpp"
#include "gpu_rig.hpp"

namespace facecast::render::detail {
namespace {

// The sources after their first lines: compile() puts #version and the layout #defines in front.
const char* kVertexShader = R"(
layout(location = POSITION_ATTRIBUTE) in vec3 a_pos;
layout(location = NORMAL_ATTRIBUTE) in vec3 a_nrm;
layout(location = MORPH_ATTRIBUTE) in ivec2 a_morph;  // first entry, entry count
uniform sampler2D u_deltas;  // TEXELS_PER_ENTRY texels per entry: (dpos, shape), (dnrm, 0)
uniform float u_weights[MAX_SHAPES];
uniform mat4 u_mvp;
uniform mat4 u_model;  // head pose (a rotation about the neck)
out vec3 v_pos;
out vec3 v_nrm;
void main() {
  vec3 p = a_pos;
  vec3 n = a_nrm;
  for (int i = 0; i < a_morph.y; ++i) {
    int e = (a_morph.x + i) * TEXELS_PER_ENTRY;
    ivec2 at = ivec2(e % DELTA_WIDTH, e / DELTA_WIDTH);
    vec4 d = texelFetch(u_deltas, at, 0);
    float w = u_weights[int(d.w)];
    if (w != 0.0) {
      p += w * d.xyz;
      n += w * texelFetch(u_deltas, at + ivec2(1, 0), 0).xyz;
    }
  }
  vec4 world = u_model * vec4(p, 1.0);
  v_pos = world.xyz;
  v_nrm = mat3(u_model) * n;
  gl_Position = u_mvp * world;
}
)";

const char* kFragmentShader = R"(
in vec3 v_pos;
in vec3 v_nrm;
uniform vec3 u_color;  // linear
uniform vec3 u_eye;
out vec4 frag;
vec3 to_srgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
void main() {
  vec3 n = normalize(v_nrm);
  vec3 v = normalize(u_eye - v_pos);
  if (dot(n, v) < 0.0) n = -n;  // two-sided: open sheets and inner surfaces
  vec3 key = normalize(vec3(-0.45, 0.55, 0.75));
  vec3 fill = normalize(vec3(0.6, 0.1, 0.8));
  vec3 rim = normalize(vec3(0.0, 0.4, -1.0));
  float wrap = 0.25;  // soft wrap lighting, kinder to skin
  float kd = max((dot(n, key) + wrap) / (1.0 + wrap), 0.0);
  float fd = max(dot(n, fill), 0.0);
  float rd = pow(max(dot(n, rim), 0.0), 2.0);
  vec3 h = normalize(key + v);
  float spec = pow(max(dot(n, h), 0.0), 40.0) * 0.12;
  float hemi = 0.5 + 0.5 * n.y;
  vec3 c = u_color * (0.22 + 0.1 * hemi + 0.78 * kd + 0.25 * fd + 0.2 * rd) + vec3(spec);
  frag = vec4(to_srgb(c), 1.0);
}
)";

std::string prelude() {
  std::ostringstream s;
  s << "#version 330 core\n"
    << "#define MAX_SHAPES " << kMaxShapes << "\n"
    << "#define DELTA_WIDTH " << kDeltaWidth << "\n"
    << "#define TEXELS_PER_ENTRY " << kTexelsPerEntry << "\n"
    << "#define POSITION_ATTRIBUTE " << kPositionAttribute << "\n"
    << "#define NORMAL_ATTRIBUTE " << kNormalAttribute << "\n"
    << "#define MORPH_ATTRIBUTE " << kMorphAttribute << "\n";
  return s.str();
}

GLuint compile(GLenum type, const char* body, const char* what) {
  const std::string source = prelude() + body;
  const char* text = source.c_str();
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &text, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    for (char& c : log) c = c == '\n' ? ' ' : c;
    throw Error(std::string("glCompileShader (") + what + ") failed: " + log, ErrorCode::kInternal);
  }
  return s;
}

}  // namespace

void check_gl(const char* call) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR) {
    std::ostringstream s;
    s << call << " failed: GL error 0x" << std::hex << e;
    throw Error(s.str(), ErrorCode::kInternal);
  }
}

GLuint link_program() {
  const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader, "vertex");
  const GLuint fs = compile(GL_FRAGMENT_SHADER, kFragmentShader, "fragment");
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) throw Error("glLinkProgram failed", ErrorCode::kInternal);
  return program;
}

}  // namespace facecast::render::detail
