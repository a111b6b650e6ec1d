// The renderer's GLSL program (docs/algorithms.md#rendering). The layout constants come from
// gpu_rig.hpp, #defined in front of the sources, so the shaders and the C++ packing cannot
// disagree.
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
layout(location = UV_ATTRIBUTE) in vec2 a_uv;
layout(location = TANGENT_ATTRIBUTE) in vec4 a_tan;
layout(location = SKIN_ATTRIBUTE) in vec4 a_groups;  // palette entries (BodySkin)
layout(location = SKIN_WEIGHT_ATTRIBUTE) in vec4 a_weights;
uniform mat4 u_mvp;
uniform mat4 u_palette[PALETTE_SIZE];  // the body pose's joint motions
out vec3 v_pos;
out vec3 v_nrm;
out vec2 v_uv;
out vec4 v_tan;
void main() {
  // a_pos and a_nrm are the blended mesh (renderer.cpp blends the shapes on the CPU).
  // INFLUENCES: the most palette entries any vertex of the rig uses (llvmpipe pays for each
  // indexed matrix on every vertex).
#if INFLUENCES == 1
  mat4 m = u_palette[int(a_groups.x)];
#else
  mat4 m = a_weights.x * u_palette[int(a_groups.x)] + a_weights.y * u_palette[int(a_groups.y)];
#if INFLUENCES > 2
  m += a_weights.z * u_palette[int(a_groups.z)];
#endif
#if INFLUENCES > 3
  m += a_weights.w * u_palette[int(a_groups.w)];
#endif
#endif
  vec4 world = m * vec4(a_pos, 1.0);
  v_pos = world.xyz;
  v_nrm = mat3(m) * a_nrm;
  v_tan = vec4(mat3(m) * a_tan.xyz, a_tan.w);
  v_uv = a_uv;
  gl_Position = u_mvp * world;
}
)";

// Metallic-roughness PBR (GGX, Smith-Schlick, Schlick Fresnel) under a studio rig: a key, a fill
// and a rim light and a sky/ground ambient; textures in slot order (BASE_COLOR_SLOT, ...), each
// with its UV transform (UV_TRANSFORM: else the identity); alpha MASK discards, BLEND keeps the
// alpha.
const char* kFragmentShader = R"(
in vec3 v_pos;
in vec3 v_nrm;
in vec2 v_uv;
in vec4 v_tan;
uniform vec4 u_base_color;  // linear
uniform vec3 u_emissive;
uniform vec2 u_metallic_roughness;
uniform float u_normal_scale;
uniform float u_occlusion_strength;
uniform bool u_blend;  // alpha BLEND: keep the alpha; otherwise opaque
uniform float u_alpha_cutoff;
uniform bool u_unlit;  // KHR_materials_unlit
uniform bool u_toon;   // MToon (rig::Toon)
uniform vec3 u_shade, u_rim;
uniform vec4 u_toon_params;  // shading shift, toony, rim fresnel power, rim lift
uniform mat3 u_uv[SLOT_COUNT];
uniform sampler2D u_textures[SLOT_COUNT];
uniform vec3 u_eye;
out vec4 frag;
const float PI = 3.14159265;
// The sRGB curve; FAST_SRGB: 1.055 c^(1/2.4) - 0.055 fitted by three square roots (Ian Taylor's
// approximation, within 0.25 of an 8-bit level; llvmpipe's pow is a log2 and an exp2 polynomial).
vec3 to_srgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
#if FAST_SRGB
  vec3 s1 = sqrt(c), s2 = sqrt(s1), s3 = sqrt(s2);
  vec3 curve = 0.662002687 * s1 + 0.684122060 * s2 - 0.323583601 * s3 - 0.0225411470 * c;
#else
  vec3 curve = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
#endif
  return mix(12.92 * c, curve, step(0.0031308, c));
}
// Whether the material fills texture `slot` (TEXTURES is a constant of this program variant).
#define HAS_TEXTURE(slot) (((TEXTURES >> slot) & 1) != 0)
// `var` = the slot's texel, or `fallback` without a texture. A macro, not a function: sampler
// arrays take constant indices only. The constant condition leaves only one side in the program.
#define SAMPLE(var, slot, fallback) \
  vec4 var = fallback;              \
  if (HAS_TEXTURE(slot)) var = texture(u_textures[slot], UV(slot))
#if UV_TRANSFORM
#define UV(slot) (u_uv[slot] * vec3(v_uv, 1.0)).xy
#else
#define UV(slot) v_uv
#endif
// One light's diffuse and specular: GGX distribution, Smith-Schlick visibility (its n.v factor
// `gv` shared by the lights), Schlick Fresnel; the n.v n.l of the visibility cancels the
// microfacet denominator's 4 n.v n.l, which leaves one division.
vec3 light(vec3 n, vec3 v, vec3 l, float radiance, vec3 albedo, vec3 f0, float a2, float k,
           float gv) {
  float nl = max(dot(n, l), 0.0);
  vec3 h = normalize(l + v);
  float nh = max(dot(n, h), 0.0), m = 1.0 - max(dot(v, h), 0.0), m2 = m * m;
  float q = nh * nh * (a2 - 1.0) + 1.0;
  vec3 f = f0 + (1.0 - f0) * (m2 * m2 * m);
  float spec = a2 / (4.0 * PI * q * q * gv * (nl * (1.0 - k) + k));
  return ((1.0 - f) * albedo * (1.0 / PI) + spec * f) * (radiance * nl);
}
// MToon, approximately: the shade and lit colours split by the toon ramp of the key light's n.l
// (toon avatars are lit by one light; the fill and back lights of the PBR path would only add
// shade colour), then the parametric rim.
vec3 toon(vec3 n, vec3 v, vec3 lit) {
  float lo = -1.0 + u_toon_params.y, hi = 1.0 - u_toon_params.y;
  float s = clamp((dot(n, normalize(vec3(-0.45, 0.55, 0.75))) + u_toon_params.x - lo) /
                  max(hi - lo, 1e-4), 0.0, 1.0);
  return mix(u_shade, lit, s) +
         u_rim * pow(clamp(1.0 - dot(n, v) + u_toon_params.w, 0.0, 1.0), u_toon_params.z);
}
void main() {
  SAMPLE(base_texel, BASE_COLOR_SLOT, vec4(1.0));
  vec4 base = u_base_color * base_texel;
#if ALPHA_MASK
  if (base.a < u_alpha_cutoff) discard;
#endif
  if (u_unlit) {
    frag = vec4(to_srgb(base.rgb), u_blend ? base.a : 1.0);
    return;
  }
  SAMPLE(mr, METALLIC_ROUGHNESS_SLOT, vec4(1.0));
  float metal = clamp(u_metallic_roughness.x * mr.b, 0.0, 1.0);
  float rough = clamp(u_metallic_roughness.y * mr.g, 0.04, 1.0);
  vec3 v = normalize(u_eye - v_pos);
  vec3 n = normalize(v_nrm);
  float side = dot(n, v) < 0.0 ? -1.0 : 1.0;  // two-sided: open sheets and inner surfaces
  n *= side;
  SAMPLE(normal_texel, NORMAL_SLOT, vec4(0.5, 0.5, 1.0, 1.0));
  if (HAS_TEXTURE(NORMAL_SLOT)) {
    vec3 t = normalize(v_tan.xyz - n * dot(n, v_tan.xyz));
    vec3 b = cross(n, t) * v_tan.w * side;
    vec3 tn = normal_texel.xyz * 2.0 - 1.0;
    tn.xy *= u_normal_scale;
    n = normalize(mat3(t, b, n) * tn);
  }
  // The occlusion where gpu_rig.cpp put it (OCCLUSION_SOURCE: an OcclusionSource).
#if OCCLUSION_SOURCE == 1
  float occlusion = mr.r;
#elif OCCLUSION_SOURCE == 2
  float occlusion = normal_texel.a;
#elif OCCLUSION_SOURCE == 3
  float occlusion = base_texel.a;
#else
  SAMPLE(occlusion_texel, OCCLUSION_SLOT, vec4(1.0));
  float occlusion = occlusion_texel.r;
#endif
  float ao = 1.0 + u_occlusion_strength * (occlusion - 1.0);
  vec3 albedo = base.rgb * (1.0 - metal);
  vec3 f0 = mix(vec3(0.04), base.rgb, metal);
  float a = max(rough * rough, 1e-3), a2 = a * a;
  float k = (rough + 1.0) * (rough + 1.0) / 8.0;
  float gv = max(dot(n, v), 1e-4) * (1.0 - k) + k;
  if (u_toon) {
    frag = vec4(to_srgb(toon(n, v, base.rgb)), u_blend ? base.a : 1.0);
    return;
  }
  vec3 c = light(n, v, normalize(vec3(-0.45, 0.55, 0.75)), 2.6, albedo, f0, a2, k, gv)
         + light(n, v, normalize(vec3(0.6, 0.1, 0.8)), 0.8, albedo, f0, a2, k, gv)
         + light(n, v, normalize(vec3(0.0, 0.4, -1.0)), 1.2, albedo, f0, a2, k, gv);
  vec3 ambient = mix(vec3(0.20, 0.19, 0.18), vec3(0.34, 0.36, 0.40), 0.5 + 0.5 * n.y);
  c += ao * ambient * (albedo + f0 * 0.5);
  SAMPLE(emissive, EMISSIVE_SLOT, vec4(1.0));
  c += u_emissive * emissive.rgb;
  frag = vec4(to_srgb(c), u_blend ? base.a : 1.0);
}
)";

// The background image: one triangle covering the screen, the image scaled to cover it.
const char* kBackgroundVertexShader = R"(
uniform vec2 u_scale;  // of the image's UV range, keeping its aspect ratio
out vec2 v_uv;
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  v_uv = 0.5 + (vec2(p.x, 1.0 - p.y) - 0.5) * u_scale;
  gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);
}
)";

const char* kBackgroundFragmentShader = R"(
in vec2 v_uv;
uniform sampler2D u_image;
out vec4 frag;
void main() { frag = vec4(texture(u_image, v_uv).rgb, 1.0); }
)";

std::string prelude() {
  std::ostringstream s;
  s << "#version 330 core\n"
    << "#define POSITION_ATTRIBUTE " << kPositionAttribute << "\n"
    << "#define NORMAL_ATTRIBUTE " << kNormalAttribute << "\n"
    << "#define UV_ATTRIBUTE " << kUvAttribute << "\n"
    << "#define TANGENT_ATTRIBUTE " << kTangentAttribute << "\n"
    << "#define SKIN_ATTRIBUTE " << kSkinAttribute << "\n"
    << "#define SKIN_WEIGHT_ATTRIBUTE " << kSkinWeightAttribute << "\n"
    << "#define SLOT_COUNT " << kSlotCount << "\n"
    << "#define BASE_COLOR_SLOT " << kBaseColorSlot << "\n"
    << "#define METALLIC_ROUGHNESS_SLOT " << kMetallicRoughnessSlot << "\n"
    << "#define NORMAL_SLOT " << kNormalSlot << "\n"
    << "#define OCCLUSION_SLOT " << kOcclusionSlot << "\n"
    << "#define EMISSIVE_SLOT " << kEmissiveSlot << "\n";
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

namespace {

GLuint link(const char* vertex, const char* fragment, const char* what) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertex, what);
  const GLuint fs = compile(GL_FRAGMENT_SHADER, fragment, what);
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) throw Error(std::string("glLinkProgram (") + what + ") failed", ErrorCode::kInternal);
  return program;
}

}  // namespace

GLuint link_program(const ProgramVariant& v) {
  std::ostringstream fragment;
  fragment << "#define ALPHA_MASK " << v.alpha_mask << "\n#define TEXTURES " << v.textures
           << "\n#define UV_TRANSFORM " << v.uv_transform << "\n#define OCCLUSION_SOURCE "
           << v.occlusion_source << "\n#define FAST_SRGB " << v.fast_srgb << "\n"
           << kFragmentShader;
  const std::string vertex = "#define INFLUENCES " + std::to_string(v.influences) +
                             "\n#define PALETTE_SIZE " + std::to_string(v.palette_size) + "\n" +
                             kVertexShader;
  return link(vertex.c_str(), fragment.str().c_str(), "avatar");
}

GLuint link_background_program() {
  return link(kBackgroundVertexShader, kBackgroundFragmentShader, "background");
}

}  // namespace facecast::render::detail
