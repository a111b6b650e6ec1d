#pragma once
// Private: OpenGL 3.3 core entry points, GL error checks and the renderer's shader program.
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

namespace facecast::render::detail {

/// Throws Error(kInternal) "<call> failed: GL error 0x..." when glGetError reports one.
void check_gl(const char* call);

/// Compiles and links the program on the current context: the head pose on the blended mesh in
/// the vertex shader, metallic-roughness shading of the material's textures and sRGB output in
/// the fragment shader, which discards below the alpha cutoff when `alpha_mask` (only then: a
/// shader that may discard cannot test depth before shading). `textures` has bit `slot` set for
/// each texture slot the material fills: the others cost nothing (llvmpipe runs the program per
/// material variant; a branch on a uniform still costs its masked code). The GPU layout constants
/// of gpu_rig.hpp are #defined at the top of the sources. `occlusion_source`: where the material's
/// occlusion is read (an OcclusionSource). Throws Error(kInternal) with the log.
GLuint link_program(bool alpha_mask, unsigned textures, int occlusion_source);
/// The background image's program: a screen-covering triangle (drawn with no vertex buffer).
GLuint link_background_program();

}  // namespace facecast::render::detail
