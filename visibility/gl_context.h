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
    // Leaves the calling thread with no context current (this one was).
    virtual void release() = 0;
    // "OSMesa: 4.5 (Core Profile) Mesa 22.3.6, llvmpipe ..." and the like.
    virtual std::string describe() const = 0;
};

// The context current on the calling thread for the guard's life, then none: the
// threads that use it are the process's workers, which live on and run other work
// (scenes/threads.h). Left current there, EGL would refuse to make it current on
// another thread, and OSMesa would flush it there after it is destroyed. Guards do not
// nest: the inner one's end leaves no context current (so no GL call after it).
class CurrentContext {
public:
    explicit CurrentContext(GlContext& context) : context_(context) { context_.make_current(); }
    ~CurrentContext() { context_.release(); }
    CurrentContext(const CurrentContext&) = delete;
    CurrentContext& operator=(const CurrentContext&) = delete;

private:
    GlContext& context_;
};

// Creates the context; throws std::runtime_error with the reason when that fails (no
// OSMesa/EGL at run time, no GL 4.5).
std::unique_ptr<GlContext> make_gl_context();

}  // namespace raybundle::visibility
