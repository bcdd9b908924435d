// The OpenGL context through OSMesa (software rendering with llvmpipe: works headless
// everywhere). OSMesa is loaded at run time, so that a machine without it gets a clear
// error from this backend instead of a program that does not start, and so that
// nothing links libGL next to it. RAYBUNDLE_OSMESA_LIBRARY names another build of the
// library. OSMesa's buffers are complete only after glFinish().
#include "visibility/gl_context.h"

#include <GL/osmesa.h>

#include <dlfcn.h>

#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace raybundle::visibility {

namespace {

class OsmesaContext final : public GlContext {
public:
    OsmesaContext() {
        const char* configured = std::getenv("RAYBUNDLE_OSMESA_LIBRARY");
        const std::string library = configured && *configured ? configured : "libOSMesa.so.8";
        handle_ = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!handle_) throw std::runtime_error("zbuffer: cannot load OSMesa (" + std::string(dlerror()) + ")");
        create_ = reinterpret_cast<decltype(create_)>(dlsym(handle_, "OSMesaCreateContextAttribs"));
        make_current_ = reinterpret_cast<decltype(make_current_)>(dlsym(handle_, "OSMesaMakeCurrent"));
        destroy_ = reinterpret_cast<decltype(destroy_)>(dlsym(handle_, "OSMesaDestroyContext"));
        get_proc_ = reinterpret_cast<decltype(get_proc_)>(dlsym(handle_, "OSMesaGetProcAddress"));
        if (!create_ || !make_current_ || !destroy_ || !get_proc_) {
            dlclose(handle_);
            throw std::runtime_error("zbuffer: " + library + " lacks the OSMesa context functions");
        }
        const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                               OSMESA_CONTEXT_MAJOR_VERSION, 4, OSMESA_CONTEXT_MINOR_VERSION, 5, 0};
        context_ = create_(attribs, nullptr);
        if (!context_) {
            dlclose(handle_);
            throw std::runtime_error("zbuffer: OSMesa cannot create an OpenGL 4.5 core context");
        }
        try {
            make_current();
        } catch (...) {
            destroy_(context_);
            dlclose(handle_);
            throw;
        }
    }
    // The library stays loaded (each dlopen only counts up): Mesa keeps per-thread
    // dispatch state past OSMesaDestroyContext, which unloading would leave dangling,
    // and LeakSanitizer could no longer name it (tests/sanitizers/lsan.supp).
    ~OsmesaContext() override { destroy_(context_); }

    void* proc_address(const char* name) const override { return reinterpret_cast<void*>(get_proc_(name)); }
    void make_current() override {
        if (!make_current_(context_, buffer_.data(), GL_UNSIGNED_BYTE, 1, 1))
            throw std::runtime_error("zbuffer: cannot make the OSMesa context current");
    }
    void release() override { make_current_(nullptr, nullptr, 0, 0, 0); }  // OSMesa's way to unbind
    std::string describe() const override {
        using GetString = const unsigned char* (*)(unsigned);
        auto get = reinterpret_cast<GetString>(proc_address("glGetString"));
        constexpr unsigned kVersion = 0x1F02, kRenderer = 0x1F01;
        return std::string("OSMesa: ") + reinterpret_cast<const char*>(get(kVersion)) + ", " +
               reinterpret_cast<const char*>(get(kRenderer));
    }

private:
    void* handle_ = nullptr;
    OSMesaContext (*create_)(const int*, OSMesaContext) = nullptr;
    GLboolean (*make_current_)(OSMesaContext, void*, GLenum, GLsizei, GLsizei) = nullptr;
    void (*destroy_)(OSMesaContext) = nullptr;
    OSMESAproc (*get_proc_)(const char*) = nullptr;
    OSMesaContext context_ = nullptr;
    std::vector<unsigned char> buffer_ = std::vector<unsigned char>(4);  // 1 x 1 RGBA, never read
};

}  // namespace

std::unique_ptr<GlContext> make_gl_context() { return std::make_unique<OsmesaContext>(); }

}  // namespace raybundle::visibility
