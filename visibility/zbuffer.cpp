#include "visibility/zbuffer.h"

#include "scenes/frame.h"
#include "visibility/gl_context.h"
#include "visibility/pixel_pairs.h"

#include <GL/glcorearb.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::visibility {

namespace {

// The GL entry points the backend uses, loaded from the context.
#define RAYBUNDLE_GL_FUNCTIONS(X)                                                                             \
    X(PFNGLGETERRORPROC, GetError)                                                                            \
    X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                                                              \
    X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                                                        \
    X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                                                              \
    X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D)                                                    \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)                                                \
    X(PFNGLDRAWBUFFERSPROC, DrawBuffers)                                                                      \
    X(PFNGLREADBUFFERPROC, ReadBuffer)                                                                        \
    X(PFNGLGENTEXTURESPROC, GenTextures)                                                                      \
    X(PFNGLDELETETEXTURESPROC, DeleteTextures)                                                                \
    X(PFNGLBINDTEXTUREPROC, BindTexture)                                                                      \
    X(PFNGLTEXSTORAGE2DPROC, TexStorage2D)                                                                    \
    X(PFNGLTEXPARAMETERIPROC, TexParameteri)                                                                  \
    X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                                                                  \
    X(PFNGLCREATESHADERPROC, CreateShader)                                                                    \
    X(PFNGLSHADERSOURCEPROC, ShaderSource)                                                                    \
    X(PFNGLCOMPILESHADERPROC, CompileShader)                                                                  \
    X(PFNGLGETSHADERIVPROC, GetShaderiv)                                                                      \
    X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                                                            \
    X(PFNGLDELETESHADERPROC, DeleteShader)                                                                    \
    X(PFNGLCREATEPROGRAMPROC, CreateProgram)                                                                  \
    X(PFNGLATTACHSHADERPROC, AttachShader)                                                                    \
    X(PFNGLLINKPROGRAMPROC, LinkProgram)                                                                      \
    X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                                                                    \
    X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                                                          \
    X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                                                                  \
    X(PFNGLUSEPROGRAMPROC, UseProgram)                                                                        \
    X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                                                        \
    X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                                                            \
    X(PFNGLUNIFORM1IPROC, Uniform1i)                                                                          \
    X(PFNGLGENBUFFERSPROC, GenBuffers)                                                                        \
    X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                                                                  \
    X(PFNGLBINDBUFFERPROC, BindBuffer)                                                                        \
    X(PFNGLBUFFERDATAPROC, BufferData)                                                                        \
    X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                                                              \
    X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                                                        \
    X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                                                              \
    X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)                                              \
    X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)                                                      \
    X(PFNGLVIEWPORTPROC, Viewport)                                                                            \
    X(PFNGLENABLEPROC, Enable)                                                                                \
    X(PFNGLDISABLEPROC, Disable)                                                                              \
    X(PFNGLDEPTHFUNCPROC, DepthFunc)                                                                          \
    X(PFNGLCLEARBUFFERUIVPROC, ClearBufferuiv)                                                                \
    X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv)                                                                  \
    X(PFNGLDRAWARRAYSPROC, DrawArrays)                                                                        \
    X(PFNGLPIXELSTOREIPROC, PixelStorei)                                                                      \
    X(PFNGLREADPIXELSPROC, ReadPixels)                                                                        \
    X(PFNGLFINISHPROC, Finish)                                                                                \
    X(PFNGLGENQUERIESPROC, GenQueries)                                                                        \
    X(PFNGLDELETEQUERIESPROC, DeleteQueries)                                                                  \
    X(PFNGLBEGINQUERYPROC, BeginQuery)                                                                        \
    X(PFNGLENDQUERYPROC, EndQuery)                                                                            \
    X(PFNGLGETQUERYOBJECTUIVPROC, GetQueryObjectuiv)

struct Gl {
#define RAYBUNDLE_GL_DECLARE(type, name) type name = nullptr;
    RAYBUNDLE_GL_FUNCTIONS(RAYBUNDLE_GL_DECLARE)
#undef RAYBUNDLE_GL_DECLARE
    explicit Gl(const GlContext& context) {
#define RAYBUNDLE_GL_LOAD(type, name)                                                             \
    name = reinterpret_cast<type>(context.proc_address("gl" #name));                              \
    if (!name) throw std::runtime_error("zbuffer: the OpenGL context lacks gl" #name);
        RAYBUNDLE_GL_FUNCTIONS(RAYBUNDLE_GL_LOAD)
#undef RAYBUNDLE_GL_LOAD
    }
};

const char* kVertexShader = R"(#version 450 core
layout(location = 0) in vec3 position;
uniform mat4 projection;
invariant gl_Position;  // the same fragment depth in every peeling pass
void main() { gl_Position = projection * vec4(position, 1.0); }
)";

const char* kFragmentShader = R"(#version 450 core
layout(location = 0) out uint id;
layout(binding = 0) uniform sampler2D previous_depth;
uniform int peel;
void main() {
    if (peel != 0 && gl_FragCoord.z <= texelFetch(previous_depth, ivec2(gl_FragCoord.xy), 0).r) discard;
    id = uint(gl_PrimitiveID) + 1u;
}
)";

}  // namespace

struct ZBufferBackend::Impl {
    std::unique_ptr<GlContext> context;
    std::unique_ptr<Gl> gl;
    int resolution = 0;
    bool jitter = true;
    Vec3 center;
    double radius = 0.0;
    std::vector<Vec3> normals;
    GLuint program = 0, vao = 0, vbo = 0, framebuffer = 0, ids = 0, query = 0;
    GLuint depth[2] = {0, 0};
    GLint projection_location = -1, peel_location = -1;
    GLsizei vertex_count = 0;
    std::vector<std::uint32_t> layer, next_layer;
    std::vector<std::uint64_t> pairs;
    long directions = 0, layers = 0;  // drawn so far: the cost grows with the layers

    GLuint compile(GLenum type, const char* source) {
        const GLuint s = gl->CreateShader(type);
        gl->ShaderSource(s, 1, &source, nullptr);
        gl->CompileShader(s);
        GLint ok = 0;
        gl->GetShaderiv(s, GL_COMPILE_STATUS, &ok);
        if (!ok) {
            char log[2048];
            gl->GetShaderInfoLog(s, sizeof log, nullptr, log);
            throw std::runtime_error(std::string("zbuffer: shader does not compile: ") + log);
        }
        return s;
    }

    void check(const char* where) {
        const GLenum e = gl->GetError();
        if (e != GL_NO_ERROR) throw std::runtime_error(std::string("zbuffer: OpenGL error ") + std::to_string(e) + " in " + where);
    }
};

ZBufferBackend::ZBufferBackend(const scenes::Scene& scene, const BackendOptions& options)
    : impl_(std::make_unique<Impl>()) {
    Impl& s = *impl_;
    s.context = make_gl_context();
    s.gl = std::make_unique<Gl>(*s.context);
    const Gl& gl = *s.gl;
    s.resolution = options.resolution > 0 ? options.resolution : default_resolution(scene);
    s.jitter = options.jitter;
    s.center = scene.bounds_center();
    s.radius = scene.bounds_radius();

    // Triangle soup relative to the scene's centre: primitive i is patch i.
    std::vector<float> vertices;
    for (const auto& p : scene.patch_list()) {
        s.normals.push_back(p.normal);
        for (int k : p.v) {
            const Vec3 d = scene.vertex_positions()[k] - s.center;
            vertices.insert(vertices.end(), {static_cast<float>(d.x()), static_cast<float>(d.y()), static_cast<float>(d.z())});
        }
    }
    s.vertex_count = static_cast<GLsizei>(vertices.size() / 3);

    const GLuint vs = s.compile(GL_VERTEX_SHADER, kVertexShader), fs = s.compile(GL_FRAGMENT_SHADER, kFragmentShader);
    s.program = gl.CreateProgram();
    gl.AttachShader(s.program, vs);
    gl.AttachShader(s.program, fs);
    gl.LinkProgram(s.program);
    gl.DeleteShader(vs);
    gl.DeleteShader(fs);
    GLint linked = 0;
    gl.GetProgramiv(s.program, GL_LINK_STATUS, &linked);
    if (!linked) throw std::runtime_error("zbuffer: shader program does not link");
    s.projection_location = gl.GetUniformLocation(s.program, "projection");
    s.peel_location = gl.GetUniformLocation(s.program, "peel");

    gl.GenVertexArrays(1, &s.vao);
    gl.BindVertexArray(s.vao);
    gl.GenBuffers(1, &s.vbo);
    gl.BindBuffer(GL_ARRAY_BUFFER, s.vbo);
    gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)), vertices.data(),
                  GL_STATIC_DRAW);
    gl.EnableVertexAttribArray(0);
    gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);

    // Framebuffer: patch ids (R32UI) and two depth textures used in turn.
    const GLsizei W = s.resolution + 1;
    gl.GenTextures(1, &s.ids);
    gl.BindTexture(GL_TEXTURE_2D, s.ids);
    gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_R32UI, W, W);
    gl.GenTextures(2, s.depth);
    for (GLuint d : s.depth) {
        gl.BindTexture(GL_TEXTURE_2D, d);
        gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT32F, W, W);
        gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_NONE);
    }
    gl.GenFramebuffers(1, &s.framebuffer);
    gl.BindFramebuffer(GL_FRAMEBUFFER, s.framebuffer);
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, s.ids, 0);
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, s.depth[0], 0);
    const GLenum buffers[] = {GL_COLOR_ATTACHMENT0};
    gl.DrawBuffers(1, buffers);
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw std::runtime_error("zbuffer: the R32UI + 32-bit depth framebuffer is not supported");
    gl.GenQueries(1, &s.query);
    gl.Viewport(0, 0, W, W);
    gl.Enable(GL_DEPTH_TEST);
    gl.DepthFunc(GL_LESS);
    gl.Disable(GL_CULL_FACE);
    gl.UseProgram(s.program);
    s.check("setup");
}

ZBufferBackend::~ZBufferBackend() {
    if (!impl_ || !impl_->gl) return;
    Impl& s = *impl_;
    const Gl& gl = *s.gl;
    // Names are per context: delete in ours, whichever another backend left current.
    try {
        s.context->make_current();
    } catch (...) {
        return;  // destroying the context frees them anyway
    }
    gl.DeleteQueries(1, &s.query);
    gl.DeleteFramebuffers(1, &s.framebuffer);
    gl.DeleteTextures(2, s.depth);
    gl.DeleteTextures(1, &s.ids);
    gl.DeleteBuffers(1, &s.vbo);
    gl.DeleteVertexArrays(1, &s.vao);
    gl.DeleteProgram(s.program);
}

int ZBufferBackend::resolution() const { return impl_->resolution; }

std::string ZBufferBackend::details() const {
    impl_->context->make_current();
    std::string d = impl_->context->describe();
    if (impl_->directions > 0) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "; %.1f depth layers per direction",
                      static_cast<double>(impl_->layers) / static_cast<double>(impl_->directions));
        d += buf;
    }
    return d;
}

void ZBufferBackend::transfer(const Vec3& w, const Eigen::Vector2d& jitter, GeometryMatrix& out) {
    Impl& s = *impl_;
    const Gl& gl = *s.gl;
    s.context->make_current();
    out.direction = w;
    out.entries.clear();
    const int W = s.resolution + 1;
    const double pixel = 2.0 * s.radius / s.resolution;
    const double jx = s.jitter ? jitter.x() : 0.5, jy = s.jitter ? jitter.y() : 0.5;

    // Orthographic projection along w onto the painter's grid: pixel coordinate
    // (u . d + R) / pixel + jitter, mapped to [-1, 1] over W pixels; depth w . d over
    // the bounding sphere.
    Vec3 u, v;
    scenes::orthonormal_basis(w, u, v);
    const double sx = 2.0 / (pixel * W), ox = (2.0 * (s.radius / pixel + jx)) / W - 1.0;
    const double sy = 2.0 / (pixel * W), oy = (2.0 * (s.radius / pixel + jy)) / W - 1.0;
    const double sz = 1.0 / (1.001 * s.radius);
    const float m[16] = {static_cast<float>(sx * u.x()), static_cast<float>(sx * u.y()), static_cast<float>(sx * u.z()), static_cast<float>(ox),
                         static_cast<float>(sy * v.x()), static_cast<float>(sy * v.y()), static_cast<float>(sy * v.z()), static_cast<float>(oy),
                         static_cast<float>(sz * w.x()), static_cast<float>(sz * w.y()), static_cast<float>(sz * w.z()), 0.0f,
                         0.0f, 0.0f, 0.0f, 1.0f};
    gl.UniformMatrix4fv(s.projection_location, 1, GL_TRUE, m);

    const std::size_t cells = static_cast<std::size_t>(W) * W;
    s.layer.assign(cells, 0);
    s.next_layer.resize(cells);
    s.pairs.clear();
    const GLuint zero[4] = {0, 0, 0, 0};
    const GLfloat far[1] = {1.0f};
    gl.PixelStorei(GL_PACK_ALIGNMENT, 4);
    gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
    const std::size_t max_layers = s.normals.size() + 1;
    for (std::size_t k = 0; k < max_layers; ++k) {
        // Layer k into depth[k % 2], testing against layer k - 1 in depth[(k + 1) % 2].
        gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, s.depth[k % 2], 0);
        gl.ActiveTexture(GL_TEXTURE0);
        gl.BindTexture(GL_TEXTURE_2D, s.depth[(k + 1) % 2]);
        gl.Uniform1i(s.peel_location, k > 0 ? 1 : 0);
        gl.ClearBufferuiv(GL_COLOR, 0, zero);
        gl.ClearBufferfv(GL_DEPTH, 0, far);
        gl.BeginQuery(GL_ANY_SAMPLES_PASSED, s.query);
        gl.DrawArrays(GL_TRIANGLES, 0, s.vertex_count);
        gl.EndQuery(GL_ANY_SAMPLES_PASSED);
        gl.Finish();  // OSMesa fills buffers only after glFinish()
        GLuint any = 0;
        gl.GetQueryObjectuiv(s.query, GL_QUERY_RESULT, &any);
        ++s.layers;
        if (!any) break;
        gl.ReadPixels(0, 0, W, W, GL_RED_INTEGER, GL_UNSIGNED_INT, s.next_layer.data());
        // A source in layer k - 1 right before a receiver in layer k.
        if (k > 0)
            for (std::size_t p = 0; p < cells; ++p) {
                const std::uint32_t a = s.layer[p], b = s.next_layer[p];
                if (a == 0 || b == 0) continue;
                if (s.normals[a - 1].dot(w) > 0.0 && s.normals[b - 1].dot(w) < 0.0) s.pairs.push_back(pixel_pair(b - 1, a - 1));
            }
        s.layer.swap(s.next_layer);
    }
    ++s.directions;
    s.check("transfer");
    entries_from_pairs(s.pairs, pixel * pixel, out.entries);
}

}  // namespace raybundle::visibility
