// The OpenGL context through EGL, for a GPU without a display: a device display when
// the EGL_EXT_platform_device extension is there (headless NVIDIA, Mesa), else the
// default display, with a 1 x 1 pbuffer that is never read (all rendering goes to
// framebuffer objects). Select with -DRAYBUNDLE_GL_CONTEXT=egl.
#include "visibility/gl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <stdexcept>
#include <string>

namespace raybundle::visibility {

namespace {

class EglContext final : public GlContext {
public:
    EglContext() {
        try {
            create();
        } catch (...) {
            free_all();
            throw;
        }
    }
    ~EglContext() override { free_all(); }

    void create() {
        auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
        auto platform_display =
            reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
        if (query_devices && platform_display) {
            EGLDeviceEXT devices[16];
            EGLint count = 0;
            if (query_devices(16, devices, &count))
                for (EGLint k = 0; k < count && display_ == EGL_NO_DISPLAY; ++k) {
                    EGLDisplay d = platform_display(EGL_PLATFORM_DEVICE_EXT, devices[k], nullptr);
                    if (d != EGL_NO_DISPLAY && eglInitialize(d, nullptr, nullptr)) display_ = d;
                }
        }
        if (display_ == EGL_NO_DISPLAY) {
            display_ = eglGetDisplay(EGL_DEFAULT_DISPLAY);
            if (display_ == EGL_NO_DISPLAY || !eglInitialize(display_, nullptr, nullptr))
                throw std::runtime_error("zbuffer: no EGL display (no GPU driver?)");
        }
        if (!eglBindAPI(EGL_OPENGL_API)) throw std::runtime_error("zbuffer: EGL has no desktop OpenGL");
        const EGLint config_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                         EGL_NONE};
        EGLConfig config;
        EGLint configs = 0;
        if (!eglChooseConfig(display_, config_attribs, &config, 1, &configs) || configs < 1)
            throw std::runtime_error("zbuffer: no EGL configuration for OpenGL with a pbuffer");
        const EGLint surface_attribs[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
        surface_ = eglCreatePbufferSurface(display_, config, surface_attribs);
        if (surface_ == EGL_NO_SURFACE) throw std::runtime_error("zbuffer: EGL cannot create a pbuffer surface");
        const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                          EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                          EGL_NONE};
        context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, context_attribs);
        if (context_ == EGL_NO_CONTEXT) throw std::runtime_error("zbuffer: EGL cannot create an OpenGL 4.5 core context");
        make_current();
    }
    // Frees what this context made. The display is shared by every context on the
    // device and eglInitialize is not reference-counted: it is never terminated.
    void free_all() {
        if (display_ == EGL_NO_DISPLAY) return;
        eglBindAPI(EGL_OPENGL_API);
        if (eglGetCurrentContext() == context_) eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
        if (surface_ != EGL_NO_SURFACE) eglDestroySurface(display_, surface_);
        context_ = EGL_NO_CONTEXT;
        surface_ = EGL_NO_SURFACE;
    }

    void* proc_address(const char* name) const override { return reinterpret_cast<void*>(eglGetProcAddress(name)); }
    void make_current() override {
        if (!eglBindAPI(EGL_OPENGL_API) || !eglMakeCurrent(display_, surface_, surface_, context_))
            throw std::runtime_error("zbuffer: cannot make the EGL context current");
    }
    // The API is per thread (ES where a thread has not chosen), and eglMakeCurrent binds
    // and releases the context of the thread's API: each thread that uses ours says so.
    void release() override {
        eglBindAPI(EGL_OPENGL_API);
        eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    std::string describe() const override {
        using GetString = const unsigned char* (*)(unsigned);
        auto get = reinterpret_cast<GetString>(proc_address("glGetString"));
        constexpr unsigned kVersion = 0x1F02, kRenderer = 0x1F01;
        return std::string("EGL: ") + reinterpret_cast<const char*>(get(kVersion)) + ", " +
               reinterpret_cast<const char*>(get(kRenderer));
    }

private:
    EGLDisplay display_ = EGL_NO_DISPLAY;
    EGLSurface surface_ = EGL_NO_SURFACE;
    EGLContext context_ = EGL_NO_CONTEXT;
};

}  // namespace

std::unique_ptr<GlContext> make_gl_context() { return std::make_unique<EglContext>(); }

}  // namespace raybundle::visibility
