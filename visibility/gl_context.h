#pragma once
// An off-screen OpenGL 4.5 core context: the one place that knows how it is made.
// gl_context_osmesa.cpp makes it through OSMesa (software, llvmpipe: works headless
// everywhere); gl_context_egl.cpp through EGL on a GPU without a display. CMake picks
// one (RAYBUNDLE_GL_CONTEXT=osmesa|egl).
#include <memory>
#include <string>

namespace raybundle::visibility {

class GlContext {
public:
    virtual ~GlContext() = default;
    // The address of a GL entry point, or nullptr.
    virtual void* proc_address(const char* name) const = 0;
    // Makes the context current on the calling thread.
    virtual void make_current() = 0;
    // "OSMesa: 4.5 (Core Profile) Mesa 22.3.6, llvmpipe ..." and the like.
    virtual std::string describe() const = 0;
};

// Creates the context; throws std::runtime_error with the reason when that fails (no
// OSMesa/EGL at run time, no GL 4.5).
std::unique_ptr<GlContext> make_gl_context();

}  // namespace raybundle::visibility
