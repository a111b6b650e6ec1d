#pragma once
// Private: OpenGL 3.3 core entry points, GL error checks and the renderer's shader program.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

namespace facecast::render::detail {

/// Throws Error(kInternal) "<call> failed: GL error 0x..." when glGetError reports one.
void check_gl(const char* call);

/// What one variant of the avatar's program compiles in: llvmpipe runs the program per material
/// variant, and a branch on a uniform still costs its masked code, so what a material does not use
/// is left out.
struct ProgramVariant {
  unsigned textures = 0;  // bit `slot` set for each texture slot the material fills
  // Discard below the alpha cutoff (alpha MASK). Only then: a shader that may discard cannot test
  // depth before shading.
  bool alpha_mask = false;
  // Some filled slot has a UV transform other than the identity. Without one the slots sample at
  // the interpolated UV itself, which llvmpipe samples about 7 % faster (a textured frame).
  bool uv_transform = false;
  int occlusion_source = 0;  // where the material's occlusion is read (an OcclusionSource)
  bool fast_srgb = false;    // RenderOptions::fast_srgb
  int influences = 1;        // the most body palette entries a vertex blends (BodySkin, 1-4)
  int palette_size = 2;  // the rig's palette entries (BodySkin::group_joint, at most kPaletteSize)
  bool operator==(const ProgramVariant&) const = default;
};

/// Compiles and links the avatar's program on the current context: the head pose on the blended
/// mesh in the vertex shader, metallic-roughness shading of the material's textures and sRGB output
/// in the fragment shader. The GPU layout constants of gpu_rig.hpp are #defined at the top of the
/// sources. Throws Error(kInternal) with the log.
GLuint link_program(const ProgramVariant& variant);
/// The background image's program: a screen-covering triangle (drawn with no vertex buffer).
GLuint link_background_program();

}  // namespace facecast::render::detail
