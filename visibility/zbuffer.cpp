#include "visibility/zbuffer.h"

#include "scenes/frame.h"
#include "visibility/gl_context.h"
#include "visibility/map_grid.h"
#include "visibility/pair_entries.h"
#include "scenes/threads.h"

#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <iterator>
#include <limits>
#include <optional>
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
    X(PFNGLGENTEXTURESPROC, GenTextures)                                                                      \
    X(PFNGLDELETETEXTURESPROC, DeleteTextures)                                                                \
    X(PFNGLBINDTEXTUREPROC, BindTexture)                                                                      \
    X(PFNGLTEXSTORAGE2DPROC, TexStorage2D)                                                                    \
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
    X(PFNGLDRAWELEMENTSPROC, DrawElements)                                                                    \
    X(PFNGLSCISSORPROC, Scissor)                                                                              \
    X(PFNGLDISPATCHCOMPUTEPROC, DispatchCompute)                                                              \
    X(PFNGLMEMORYBARRIERPROC, MemoryBarrier)                                                                  \
    X(PFNGLBINDBUFFERBASEPROC, BindBufferBase)                                                                \
    X(PFNGLBINDBUFFERRANGEPROC, BindBufferRange)                                                              \
    X(PFNGLBUFFERSUBDATAPROC, BufferSubData)                                                                  \
    X(PFNGLUNIFORM1UIPROC, Uniform1ui)                                                                        \
    X(PFNGLUNIFORM1FPROC, Uniform1f)                                                                          \
    X(PFNGLUNIFORM1DPROC, Uniform1d)                                                                          \
    X(PFNGLDISPATCHCOMPUTEINDIRECTPROC, DispatchComputeIndirect)                                              \
    X(PFNGLBUFFERSTORAGEPROC, BufferStorage)                                                                  \
    X(PFNGLGETBUFFERSUBDATAPROC, GetBufferSubData)                                                            \
    X(PFNGLGETINTEGER64VPROC, GetInteger64v)                                                                  \
    X(PFNGLGENQUERIESPROC, GenQueries)                                                                        \
    X(PFNGLDELETEQUERIESPROC, DeleteQueries)                                                                  \
    X(PFNGLQUERYCOUNTERPROC, QueryCounter)                                                                    \
    X(PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v)

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

// Drawing: vertices come in the map's sub-pixel units (exact integers); with a
// power-of-two viewport the transform to window coordinates is exact, so the rasteriser
// sees MapGrid's snapped positions. No depth: the lists are ordered by the pairing pass.
const char* kVertexShader = R"(#version 450 core
layout(location = 0) in vec2 position;  // x, y in 1/256 pixel
uniform float scale;                    // 2 / (256 viewport): a power of two
void main() { gl_Position = vec4(position.x * scale - 1.0, position.y * scale - 1.0, 0.0, 1.0); }
)";

// Every fragment (no depth test) goes into its pixel's list: the k-th to arrive at pixel
// p is layer k there. The order of arrival does not matter: the pairing pass sorts.
// (Layer indices fit 32 bits: reserve_layers() keeps the buffer under 2^32 words.)
const char* kFragmentShader = R"(#version 450 core
layout(std430, binding = 0) writeonly buffer Layers { uint layer_id[]; };
layout(std430, binding = 1) readonly buffer Patches { dvec4 patch_depth[]; };  // t0, tx, ty, kind
layout(std430, binding = 9) coherent buffer Depth { uint depth_count[]; };
uniform uint tiles;     // 8 x 8 tiles per row: pixels are stored tile by tile
uniform uint capacity;  // layers the buffer holds
void main() {
    // An edge-on patch (kind 0) blocks nothing: the global z-buffer does not draw it.
    if (patch_depth[gl_PrimitiveID].w == 0.0lf) return;
    uvec2 q = uvec2(gl_FragCoord.xy);
    uint p = ((q.y >> 3) * tiles + (q.x >> 3)) * 64u + (q.y & 7u) * 8u + (q.x & 7u);
    uint k = atomicAdd(depth_count[p], 1u);
    if (k < capacity) layer_id[k * tiles * tiles * 64u + p] = uint(gl_PrimitiveID);
}
)";

// The counters the passes share on the GPU (binding 5); what comes back to the CPU is
// in the read-back buffer (binding 7).
#define RAYBUNDLE_ZBUFFER_BUFFERS                                                                          \
    "layout(std430, binding = 2) coherent buffer KeyR { uint key_r[]; };\n"                                 \
    "layout(std430, binding = 3) coherent buffer KeyS { uint key_s[]; };\n"                                 \
    "layout(std430, binding = 4) coherent buffer SlotCount { uint slot_count[]; };\n"                       \
    "layout(std430, binding = 5) coherent buffer Counters { uint used_count; uint overflow; uint max_layers; " \
    "uint compact_count; };\n"                                                                              \
    "layout(std430, binding = 6) coherent buffer Used { uint used[]; };\n"

// Per pixel: its surfaces in exact order (as GlobalZBufferBackend::transfer and
// pixel_pairs.h's order_ties and pairs_along), each (receiver, source) pair counted.
// Neighbouring pixels mostly give the same pairs, so a 16 x 16 tile first counts its
// pairs in a table in shared memory and then adds each distinct pair's count once to
// the global open-addressing table, whose slot holds key_r = receiver + 1 and key_s =
// source + 1. A slot is claimed word by word: key_r first, then key_s by the first
// thread with the same receiver to get there; a thread that finds either word taken by
// another value probes on. Every claimed global slot is listed once in `used`.
constexpr int kMaxLayers = 64;
// Directions per submission of transfer_many(): one wait for the GPU for all of them.
constexpr int kBatch = 16;
constexpr std::uint32_t kMaxTable = 1u << 28;  // slots: 4 words each on the GPU, 3 to read back
const char* kPairShader = "#version 450 core\n" RAYBUNDLE_ZBUFFER_BUFFERS R"(
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) readonly buffer Layers { uint layer_id[]; };
layout(std430, binding = 1) readonly buffer Patches { dvec4 patch_depth[]; };  // t0, tx, ty, kind
layout(std430, binding = 9) buffer Depth { uint depth_count[]; };
uniform uint width;
uniform uint tiles;   // 8 x 8 tiles per row, as the draw stores pixels
uniform uint layers;  // layers the buffer holds
uniform uint mask;     // global table size - 1 (a power of two)
uniform uint patches;  // the sky's receiver index is patches, its source patches + 1
uniform int sky;
uniform double tie;
const int kMaxLayers = 64;
const uint kLocal = 1024u;  // the tile's table (a power of two)
shared uint local_r[kLocal];
shared uint local_s[kLocal];
shared uint local_c[kLocal];
shared uint tile_layers;

uint hash(uint r, uint s) {
    uint h = (r * 0x9E3779B1u) ^ ((s + 0x7F4A7C15u) * 0x85EBCA77u);
    h ^= h >> 16;
    h *= 0x7FEB352Du;
    return h ^ (h >> 15);
}

void add_global(uint r, uint s, uint c) {
    uint slot = hash(r, s) & mask;
    for (uint probe = 0u; probe < 256u; ++probe) {  // a crowded table: grown and run again
        uint kr = atomicCompSwap(key_r[slot], 0u, r + 1u);
        if (kr == 0u || kr == r + 1u) {
            uint ks = atomicCompSwap(key_s[slot], 0u, s + 1u);
            if (ks == 0u) {
                uint j = atomicAdd(used_count, 1u);
                if (j <= mask) used[j] = slot;
            }
            if (ks == 0u || ks == s + 1u) {
                atomicAdd(slot_count[slot], c);
                return;
            }
        }
        slot = (slot + 1u) & mask;
    }
    atomicOr(overflow, 1u);
}

void add(uint r, uint s) {
    uint slot = hash(r, s) & (kLocal - 1u);
    for (uint probe = 0u; probe < 64u; ++probe) {
        uint kr = atomicCompSwap(local_r[slot], 0u, r + 1u);
        if (kr == 0u || kr == r + 1u) {
            uint ks = atomicCompSwap(local_s[slot], 0u, s + 1u);
            if (ks == 0u || ks == s + 1u) {
                atomicAdd(local_c[slot], 1u);
                return;
            }
        }
        slot = (slot + 1u) & (kLocal - 1u);
    }
    add_global(r, s, 1u);  // the tile's table is crowded: straight to the global one
}

// order_ties' order within a run of equal depths: receivers first; sources by
// ascending index, receivers by descending index.
bool tie_before(uint a, bool sa, uint b, bool sb) {
    if (sa != sb) return sb;
    return sa ? a < b : a > b;
}

void main() {
    uint t = gl_LocalInvocationIndex;
    for (uint i = t; i < kLocal; i += 256u) {
        local_r[i] = 0u;
        local_s[i] = 0u;
        local_c[i] = 0u;
    }
    if (t == 0u) tile_layers = 0u;
    memoryBarrierShared();
    barrier();

    uint cells = tiles * tiles * 64u;
    uvec2 q = gl_GlobalInvocationID.xy;
    if (q.x < width && q.y < width) {
        uint p = ((q.y >> 3) * tiles + (q.x >> 3)) * 64u + (q.y & 7u) * 8u + (q.x & 7u);
        double x = double(q.x), y = double(q.y);
        uint id[kMaxLayers];
        double depth[kMaxLayers];
        bool source[kMaxLayers];
        int m = 0;
        uint count = depth_count[p];
        depth_count[p] = 0u;  // ready for the next direction
        atomicMax(tile_layers, count);
        // Insertion by exact depth (receivers first at equal depths), as the global z-buffer.
        for (uint k = 0u; k < min(count, layers); ++k) {
            uint f = layer_id[k * cells + p];
            dvec4 c = patch_depth[f];
            if (c.w == 0.0lf) continue;  // edge-on: no projected area, blocks nothing
            precise double d = c.x + c.y * x + c.z * y;
            bool s = c.w > 0.0lf;
            int j = m;
            while (j > 0 && (d < depth[j - 1] || (d == depth[j - 1] && !s && source[j - 1]))) {
                id[j] = id[j - 1];
                depth[j] = depth[j - 1];
                source[j] = source[j - 1];
                --j;
            }
            id[j] = f;
            depth[j] = d;
            source[j] = s;
            ++m;
        }
        // Runs of depths within `tie` of the previous one, ordered as every backend orders ties.
        for (int a = 0; a < m;) {
            int b = a + 1;
            while (b < m && depth[b] - depth[b - 1] <= tie) ++b;
            for (int i = a + 1; i < b; ++i) {
                uint fi = id[i];
                double di = depth[i];
                bool si = source[i];
                int j = i;
                while (j > a && tie_before(fi, si, id[j - 1], source[j - 1])) {
                    id[j] = id[j - 1];
                    depth[j] = depth[j - 1];
                    source[j] = source[j - 1];
                    --j;
                }
                id[j] = fi;
                depth[j] = di;
                source[j] = si;
            }
            a = b;
        }
        for (int i = 0; i + 1 < m; ++i)
            if (source[i] && !source[i + 1]) add(id[i + 1], id[i]);
        if (sky != 0 && m > 0) {
            if (!source[0]) add(id[0], patches);
            if (source[m - 1]) add(patches + 1u, id[m - 1]);
        }
    }
    memoryBarrierShared();
    barrier();
    for (uint i = t; i < kLocal; i += 256u)
        if (local_c[i] != 0u) add_global(local_r[i] - 1u, local_s[i] - 1u, local_c[i]);
    if (t == 0u) atomicMax(max_layers, tile_layers);
}
)";

// One thread: the counters into the read-back buffer, the compaction's group counts,
// and the counters reset for the next direction.
const char* kArgsShader = "#version 450 core\n" RAYBUNDLE_ZBUFFER_BUFFERS R"(
layout(local_size_x = 1) in;
layout(std430, binding = 7) writeonly buffer Readback { uint back_count; uint back_overflow; uint back_layers; uint back_pad; };
layout(std430, binding = 8) writeonly buffer Args { uint groups_x; uint groups_y; uint groups_z; };
void main() {
    uint m = used_count;
    compact_count = m;
    back_count = m;
    back_overflow = overflow;
    back_layers = max_layers;
    used_count = 0u;
    overflow = 0u;
    max_layers = 0u;
    uint groups = (m + 63u) / 64u, across = min(groups, 65535u);
    groups_x = across;
    groups_y = across == 0u ? 0u : (groups + across - 1u) / across;
    groups_z = 1u;
}
)";

// The used slots' (receiver, source, count) into the read-back buffer, each slot
// cleared behind.
const char* kCompactShader = "#version 450 core\n" RAYBUNDLE_ZBUFFER_BUFFERS R"(
layout(local_size_x = 64) in;
layout(std430, binding = 7) writeonly buffer Readback { uint back_header[4]; uint entry[]; };
void main() {
    uint j = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u + gl_GlobalInvocationID.x;
    if (j >= compact_count) return;
    uint slot = used[j];
    entry[3u * j] = key_r[slot] - 1u;
    entry[3u * j + 1u] = key_s[slot] - 1u;
    entry[3u * j + 2u] = slot_count[slot];
    key_r[slot] = 0u;
    key_s[slot] = 0u;
    slot_count[slot] = 0u;
}
)";

#undef RAYBUNDLE_ZBUFFER_BUFFERS

std::uint32_t next_power_of_two(std::uint32_t x) {
    std::uint32_t p = 1;
    while (p < x) p <<= 1;
    return p;
}

}  // namespace

struct ZBufferBackend::Impl {
    std::unique_ptr<GlContext> context;
    std::unique_ptr<Gl> gl;
    MapGrid grid;
    bool sky = false;
    std::vector<Vec3> normals;
    std::vector<double> plane;  // n . (first vertex)
    GLuint draw_program = 0, pair_program = 0, args_program = 0, compact_program = 0;
    GLuint vao = 0, vertex_buffer = 0, index_buffer = 0, framebuffer = 0, target = 0;
    GLuint layer_buffer = 0, depth_count = 0, patch_buffer = 0, key_r = 0, key_s = 0, slot_count = 0, counters = 0,
           used = 0, readback = 0, args = 0;
    std::vector<std::uint32_t> entry_words;  // from the read-back buffer: 3 words per entry
    // Batches (transfer_many): per direction of a submission a slot of vertices, of
    // depth records and of the read-back buffer, each at an offset the GPU can bind.
    GLuint batch_vertices = 0, batch_records = 0, batch_readback = 0;
    int batch_slots = 0;                     // directions one submission holds
    std::uint32_t batch_table = 0;           // the table size its read-back slots are for
    GLintptr vertex_slot = 0, record_slot = 0, back_slot = 0;  // bytes per slot
    std::vector<float> stage_vertices;       // the batch's vertices and records, slot by slot
    std::vector<double> stage_records;
    std::vector<MapGrid> grids;              // one per thread of the CPU's preparation
    struct Scratch {
        PairCountScratch sort;
        std::vector<std::uint32_t> words;
    };
    std::vector<Scratch> scratch;            // one per direction of a submission
    GLint draw_capacity = -1;
    GLint pair_width = -1, pair_layers = -1, pair_mask = -1, pair_patches = -1, pair_sky = -1, pair_tie = -1;
    GLsizei index_count = 0;
    int layer_capacity = 0;         // surfaces per pixel the layer buffer holds
    std::uint32_t table_size = 0;   // slots of the hash table (a power of two)
    std::vector<float> vertices;    // x, y per vertex, per direction
    std::vector<double> records;    // t0, tx, ty, kind per patch, per direction
    PairCountScratch sort;          // transfer()'s sorting
    long directions = 0, layers = 0;  // surfaces at each direction's deepest pixel, summed
    // RAYBUNDLE_ZBUFFER_PROFILE=1: seconds spent per stage, CPU and GPU (timestamps), printed
    // to stderr when the backend goes.
    bool profile = false;
    GLuint stamps[4] = {0, 0, 0, 0};
    double cpu_prepare = 0, cpu_submit = 0, cpu_wait = 0, cpu_finish = 0, gpu_draw = 0, gpu_pair = 0, gpu_compact = 0;
    long batches = 0;  // submissions of transfer_many()
    long timed = 0;    // directions with GPU timestamps (those run alone)

    Impl(const scenes::Scene& scene, const BackendOptions& options)
        : grid(scene, patch_arrays(scene), options.resolution > 0 ? options.resolution : default_resolution(scene),
               options.jitter),
          sky(options.sky) {}

    GLuint compile(GLenum type, const char* source) {
        const GLuint s = gl->CreateShader(type);
        gl->ShaderSource(s, 1, &source, nullptr);
        gl->CompileShader(s);
        GLint ok = 0;
        gl->GetShaderiv(s, GL_COMPILE_STATUS, &ok);
        if (!ok) {
            char log[2048];
            gl->GetShaderInfoLog(s, sizeof log, nullptr, log);
            gl->DeleteShader(s);
            throw std::runtime_error(std::string("zbuffer: shader does not compile: ") + log);
        }
        return s;
    }

    GLuint link(std::initializer_list<GLuint> shaders) {
        const GLuint program = gl->CreateProgram();
        for (GLuint s : shaders) gl->AttachShader(program, s);
        gl->LinkProgram(program);
        for (GLuint s : shaders) gl->DeleteShader(s);
        GLint linked = 0;
        gl->GetProgramiv(program, GL_LINK_STATUS, &linked);
        if (!linked) {
            char log[2048];
            gl->GetProgramInfoLog(program, sizeof log, nullptr, log);
            gl->DeleteProgram(program);
            throw std::runtime_error(std::string("zbuffer: shader program does not link: ") + log);
        }
        return program;
    }

    GLuint buffer(GLsizeiptr bytes, const void* data, GLenum usage) {
        GLuint b = 0;
        gl->GenBuffers(1, &b);
        gl->BindBuffer(GL_SHADER_STORAGE_BUFFER, b);
        gl->BufferData(GL_SHADER_STORAGE_BUFFER, bytes, data, usage);
        return b;
    }

    // A hash table of `size` empty slots, its list of used slots, and a read-back
    // buffer (4 counters, then 3 words per entry) with room for as many entries.
    void make_table(std::uint32_t size) {
        const GLuint old[] = {key_r, key_s, slot_count, used, readback};
        gl->DeleteBuffers(5, old);
        table_size = size;
        const std::vector<std::uint32_t> zeros(size, 0);
        const GLsizeiptr bytes = static_cast<GLsizeiptr>(size) * 4;
        key_r = buffer(bytes, zeros.data(), GL_DYNAMIC_COPY);
        key_s = buffer(bytes, zeros.data(), GL_DYNAMIC_COPY);
        slot_count = buffer(bytes, zeros.data(), GL_DYNAMIC_COPY);
        used = buffer(bytes, nullptr, GL_DYNAMIC_COPY);
        readback = buffer(16 + 3 * bytes, nullptr, GL_DYNAMIC_COPY);
    }

    // Room for `n` surfaces per pixel in the layer buffer.
    // Room for at least `needed` surfaces per pixel in the layer buffer, `wanted` where
    // one buffer can hold them (GL_MAX_SHADER_STORAGE_BLOCK_SIZE: 128 MiB on llvmpipe,
    // eight 2049-pixel layers' worth).
    void reserve_layers(int needed, int wanted) {
        if (needed <= layer_capacity) return;
        GLint64 max_block = 0;
        gl->GetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_block);
        const std::size_t fit = std::min<std::size_t>(static_cast<std::size_t>(max_block) / (4 * cells()),
                                                       ((std::size_t{1} << 32) - 1) / cells());
        const int n = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(std::max(needed, wanted)), fit));
        if (n < needed)
            throw std::runtime_error("zbuffer: " + std::to_string(needed) + " surfaces over a pixel of a " +
                                     std::to_string(grid.width()) + "-pixel map need " +
                                     std::to_string(4 * static_cast<std::size_t>(needed) * cells()) +
                                     " bytes in one buffer (the GPU takes " + std::to_string(max_block) +
                                     "); use a smaller resolution or exact-painter");
        gl->DeleteBuffers(1, &layer_buffer);
        layer_buffer = 0;
        layer_buffer = buffer(static_cast<GLsizeiptr>(4 * static_cast<std::size_t>(n) * cells()), nullptr, GL_DYNAMIC_COPY);
        layer_capacity = n;
    }


    // Pixels in the buffers: 8 x 8 tiles (neighbouring fragments, neighbouring words).
    GLuint tiles() const { return static_cast<GLuint>((grid.width() + 7) / 8); }
    std::size_t cells() const { return static_cast<std::size_t>(tiles()) * tiles() * 64; }

    // Where one direction's data lie on the GPU: its vertices, its patches' depth
    // records and its part of a read-back buffer (4 counters, then 3 words per entry).
    struct Slot {
        GLuint vertices;
        GLintptr vertex_offset;
        GLuint records;
        GLintptr record_offset;
        GLsizeiptr record_bytes;
        GLuint back;
        GLintptr back_offset;
        GLsizeiptr back_bytes;
    };
    Slot single_slot() const {
        return {vertex_buffer, 0, patch_buffer, 0, static_cast<GLsizeiptr>(std::max<std::size_t>(records.size(), 4) * sizeof(double)),
                readback, 0, static_cast<GLsizeiptr>(16 + 12 * static_cast<std::size_t>(table_size))};
    }

    // Every fragment of every patch into its pixel's list.
    void draw(const Slot& slot, bool stamp) {
        if (stamp) gl->QueryCounter(stamps[0], GL_TIMESTAMP);
        gl->UseProgram(draw_program);
        gl->BindBuffer(GL_ARRAY_BUFFER, slot.vertices);
        gl->VertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, reinterpret_cast<const void*>(slot.vertex_offset));
        gl->BindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, layer_buffer);
        gl->BindBufferRange(GL_SHADER_STORAGE_BUFFER, 1, slot.records, slot.record_offset, slot.record_bytes);
        gl->BindBufferBase(GL_SHADER_STORAGE_BUFFER, 9, depth_count);
        gl->Uniform1ui(draw_capacity, static_cast<GLuint>(layer_capacity));
        gl->DrawElements(GL_TRIANGLES, index_count, GL_UNSIGNED_INT, nullptr);
    }

    struct Back {
        std::uint32_t count, overflow, layers;
    };

    // The drawn surfaces paired and counted, compacted into the slot's read-back part,
    // the lists and the table cleared, all on the GPU (no wait).
    void submit_pair(const Slot& slot, bool stamp) {
        const GLsizei W = grid.width();
        gl->MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        const GLuint bound[] = {layer_buffer, 0, key_r, key_s, slot_count, counters, used, 0, args, depth_count};
        for (GLuint b = 0; b < 10; ++b)
            if (b != 1 && b != 7) gl->BindBufferBase(GL_SHADER_STORAGE_BUFFER, b, bound[b]);
        gl->BindBufferRange(GL_SHADER_STORAGE_BUFFER, 1, slot.records, slot.record_offset, slot.record_bytes);
        gl->BindBufferRange(GL_SHADER_STORAGE_BUFFER, 7, slot.back, slot.back_offset, slot.back_bytes);
        gl->UseProgram(pair_program);
        gl->Uniform1ui(pair_layers, static_cast<GLuint>(layer_capacity));
        gl->Uniform1ui(pair_mask, table_size - 1);
        const GLuint groups = static_cast<GLuint>((W + 15) / 16);
        if (stamp) gl->QueryCounter(stamps[1], GL_TIMESTAMP);
        gl->DispatchCompute(groups, groups, 1);
        gl->MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        if (stamp) gl->QueryCounter(stamps[2], GL_TIMESTAMP);
        gl->UseProgram(args_program);
        gl->DispatchCompute(1, 1, 1);
        gl->MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_COMMAND_BARRIER_BIT);
        gl->UseProgram(compact_program);
        gl->BindBuffer(GL_DISPATCH_INDIRECT_BUFFER, args);
        gl->DispatchComputeIndirect(0);
        gl->MemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
        if (stamp) gl->QueryCounter(stamps[3], GL_TIMESTAMP);
    }

    // The slot's counters and, where the direction is complete, its entries (the first
    // read of a submission waits for the GPU).
    Back read(const Slot& slot, std::vector<std::uint32_t>& words) {
        std::uint32_t header[4];
        gl->BindBuffer(GL_SHADER_STORAGE_BUFFER, slot.back);
        gl->GetBufferSubData(GL_SHADER_STORAGE_BUFFER, slot.back_offset, sizeof header, header);
        words.resize(3 * static_cast<std::size_t>(header[0]));
        if (header[0] > 0 && header[1] == 0 && header[2] <= static_cast<std::uint32_t>(layer_capacity))
            gl->GetBufferSubData(GL_SHADER_STORAGE_BUFFER, slot.back_offset + 16, static_cast<GLsizeiptr>(words.size() * 4),
                                 words.data());
        return {header[0], header[1], header[2]};
    }

    // One direction, alone: one draw and one wait for the GPU.
    Back pair() {
        const Slot slot = single_slot();
        draw(slot, profile);
        submit_pair(slot, profile);
        const auto submitted = std::chrono::steady_clock::now();
        const Back back = read(slot, entry_words);  // waits for the GPU
        if (profile) {
            cpu_wait += std::chrono::duration<double>(std::chrono::steady_clock::now() - submitted).count();
            GLuint64 t[4];
            for (int k = 0; k < 4; ++k) gl->GetQueryObjectui64v(stamps[k], GL_QUERY_RESULT, &t[k]);
            gpu_draw += 1e-9 * static_cast<double>(t[1] - t[0]);
            gpu_pair += 1e-9 * static_cast<double>(t[2] - t[1]);
            gpu_compact += 1e-9 * static_cast<double>(t[3] - t[2]);
            ++timed;
        }
        return back;
    }

    // A direction the GPU did not finish (more surfaces over a pixel than the layer
    // buffer holds, or a crowded table): the buffers grown, or an error past their
    // limits. Returns whether it must run again.
    bool grow(const Back& back) {
        const bool deeper = static_cast<int>(back.layers) > layer_capacity;
        if (back.layers > static_cast<std::uint32_t>(kMaxLayers))
            throw std::runtime_error("zbuffer: " + std::to_string(back.layers) + " surfaces over one pixel (at most " +
                                     std::to_string(kMaxLayers) + "); use exact-painter");
        if (deeper) reserve_layers(static_cast<int>(back.layers), std::min(kMaxLayers, static_cast<int>(back.layers) + 2));
        if (back.overflow != 0) {
            if (table_size >= kMaxTable)
                throw std::runtime_error("zbuffer: the pairs of one direction overflow a table of " +
                                         std::to_string(kMaxTable) + " slots; use exact-painter");
            make_table(std::min(8 * table_size, kMaxTable));
        }
        return deeper || back.overflow != 0;
    }

    // Direction w's vertices (x, y per vertex) and depth records (t0, tx, ty, kind per
    // patch) through `g`, projected for w and jitter.
    void prepare(MapGrid& g, const Vec3& w, const Eigen::Vector2d& jitter, float* xy, double* record) const {
        g.project(w, jitter);
        const auto& X = g.projected_x();
        const auto& Y = g.projected_y();
        for (std::size_t k = 0; k < X.size(); ++k) {
            xy[2 * k] = static_cast<float>(X[k]);
            xy[2 * k + 1] = static_cast<float>(Y[k]);
        }
        // Each patch's depth at pixel (x, y): t0 + tx x + ty y, as the global z-buffer's.
        const Vec3 origin = g.pixel_point(0, 0);
        const Vec3 du = g.pixel_point(1, 0) - origin, dv = g.pixel_point(0, 1) - origin;
        for (std::size_t i = 0; i < normals.size(); ++i) {
            const double nw = normals[i].dot(w);
            double* r = &record[4 * i];
            if (nw == 0.0) {
                r[0] = r[1] = r[2] = r[3] = 0.0;
                continue;
            }
            r[0] = (plane[i] - normals[i].dot(origin)) / nw;
            r[1] = -normals[i].dot(du) / nw;
            r[2] = -normals[i].dot(dv) / nw;
            r[3] = nw > 0.0 ? 1.0 : -1.0;
        }
    }

    // Directions one submission takes: kBatch, fewer where their slots would pass
    // 256 MiB (a large scene's read-back parts are 12 bytes per slot of its table).
    int batch_capacity() const {
        const std::size_t bytes = 64 + 12 * static_cast<std::size_t>(table_size) + records.size() * sizeof(double) +
                                  vertices.size() * sizeof(float);
        return static_cast<int>(std::clamp<std::size_t>((std::size_t{256} << 20) / bytes, 1, kBatch));
    }

    // Slots for `slots` directions at once, their read-back parts sized for the table.
    void reserve_batch(int slots) {
        if (slots <= batch_slots && batch_table == table_size) return;
        if (batch_table == table_size) slots = std::max(slots, batch_slots);
        GLint64 align = 0;
        gl->GetInteger64v(GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, &align);
        const auto round_up = [a = std::max<GLint64>(align, 16)](std::size_t bytes) {
            return static_cast<GLintptr>((bytes + static_cast<std::size_t>(a) - 1) / static_cast<std::size_t>(a) *
                                         static_cast<std::size_t>(a));
        };
        vertex_slot = round_up(std::max<std::size_t>(vertices.size(), 2) * sizeof(float));
        record_slot = round_up(std::max<std::size_t>(records.size(), 4) * sizeof(double));
        back_slot = round_up(16 + 12 * static_cast<std::size_t>(table_size));
        const GLuint old[] = {batch_vertices, batch_records, batch_readback};
        gl->DeleteBuffers(3, old);
        auto storage = [&](GLenum kind, GLintptr bytes) {
            GLuint b = 0;
            gl->GenBuffers(1, &b);
            gl->BindBuffer(kind, b);
            gl->BufferStorage(kind, bytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
            return b;
        };
        batch_vertices = storage(GL_ARRAY_BUFFER, vertex_slot * slots);
        batch_records = storage(GL_SHADER_STORAGE_BUFFER, record_slot * slots);
        batch_readback = buffer(back_slot * slots, nullptr, GL_DYNAMIC_COPY);
        batch_slots = slots;
        batch_table = table_size;
        stage_vertices.resize(static_cast<std::size_t>(vertex_slot) / sizeof(float) * static_cast<std::size_t>(slots));
        stage_records.resize(static_cast<std::size_t>(record_slot) / sizeof(double) * static_cast<std::size_t>(slots));
    }

    Slot batch_slot(int k) const {
        return {batch_vertices, vertex_slot * k, batch_records, record_slot * k,
                static_cast<GLsizeiptr>(std::max<std::size_t>(records.size(), 4) * sizeof(double)),
                batch_readback, back_slot * k, static_cast<GLsizeiptr>(16 + 12 * static_cast<std::size_t>(table_size))};
    }

    void check(const char* where) {
        const GLenum e = gl->GetError();
        if (e != GL_NO_ERROR) throw std::runtime_error(std::string("zbuffer: OpenGL error ") + std::to_string(e) + " in " + where);
    }
};

ZBufferBackend::ZBufferBackend(const scenes::Scene& scene, const BackendOptions& options)
    : impl_(std::make_unique<Impl>(scene, options)) {
    Impl& s = *impl_;
    s.context = make_gl_context();
    const CurrentContext current(*s.context);
    s.gl = std::make_unique<Gl>(*s.context);
    const Gl& gl = *s.gl;

    std::vector<std::uint32_t> indices;
    for (const auto& p : scene.patch_list()) {
        s.normals.push_back(p.normal);
        s.plane.push_back(p.normal.dot(scene.vertex_positions()[p.v[0]]));
        for (int k : p.v) indices.push_back(static_cast<std::uint32_t>(k));
    }
    if (s.normals.size() + 2 >= std::numeric_limits<std::uint32_t>::max())
        throw std::runtime_error("zbuffer: too many patches for 32-bit ids");
    s.index_count = static_cast<GLsizei>(indices.size());

    s.draw_program = s.link({s.compile(GL_VERTEX_SHADER, kVertexShader), s.compile(GL_FRAGMENT_SHADER, kFragmentShader)});
    s.pair_program = s.link({s.compile(GL_COMPUTE_SHADER, kPairShader)});
    s.args_program = s.link({s.compile(GL_COMPUTE_SHADER, kArgsShader)});
    s.compact_program = s.link({s.compile(GL_COMPUTE_SHADER, kCompactShader)});
    s.draw_capacity = gl.GetUniformLocation(s.draw_program, "capacity");
    s.pair_width = gl.GetUniformLocation(s.pair_program, "width");
    s.pair_layers = gl.GetUniformLocation(s.pair_program, "layers");
    s.pair_mask = gl.GetUniformLocation(s.pair_program, "mask");
    s.pair_patches = gl.GetUniformLocation(s.pair_program, "patches");
    s.pair_sky = gl.GetUniformLocation(s.pair_program, "sky");
    s.pair_tie = gl.GetUniformLocation(s.pair_program, "tie");

    // Vertices (rewritten per direction) and the patches' triangles: primitive i is patch i.
    s.vertices.resize(2 * scene.vertex_positions().size());
    gl.GenVertexArrays(1, &s.vao);
    gl.BindVertexArray(s.vao);
    gl.GenBuffers(1, &s.vertex_buffer);
    gl.BindBuffer(GL_ARRAY_BUFFER, s.vertex_buffer);
    gl.BufferStorage(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(std::max<std::size_t>(s.vertices.size(), 2) * sizeof(float)),
                     nullptr, GL_DYNAMIC_STORAGE_BIT);
    gl.EnableVertexAttribArray(0);
    gl.VertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
    gl.GenBuffers(1, &s.index_buffer);
    gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, s.index_buffer);
    gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size() * sizeof(std::uint32_t)),
                  indices.data(), GL_STATIC_DRAW);

    // A framebuffer of the map's size that the fragments do not write (they append to
    // their pixel's list); no depth test: every fragment counts.
    const GLsizei W = s.grid.width();
    gl.GenTextures(1, &s.target);
    gl.BindTexture(GL_TEXTURE_2D, s.target);
    gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_R8, W, W);
    gl.GenFramebuffers(1, &s.framebuffer);
    gl.BindFramebuffer(GL_FRAMEBUFFER, s.framebuffer);
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, s.target, 0);
    const GLenum none[] = {GL_NONE};
    gl.DrawBuffers(1, none);
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw std::runtime_error("zbuffer: the map's framebuffer is not complete");

    // A viewport of a power of two pixels (at least the map) makes the transform of the
    // sub-pixel positions exact; the scissor keeps the map.
    const GLsizei viewport = static_cast<GLsizei>(next_power_of_two(static_cast<std::uint32_t>(W)));
    gl.Viewport(0, 0, viewport, viewport);
    gl.Enable(GL_SCISSOR_TEST);
    gl.Scissor(0, 0, W, W);
    gl.Disable(GL_DEPTH_TEST);
    gl.Disable(GL_CULL_FACE);
    gl.UseProgram(s.draw_program);
    gl.Uniform1f(gl.GetUniformLocation(s.draw_program, "scale"), static_cast<float>(2.0 / (kSubpixel * viewport)));
    gl.Uniform1ui(gl.GetUniformLocation(s.draw_program, "tiles"), s.tiles());
    gl.UseProgram(s.pair_program);
    gl.Uniform1ui(s.pair_width, static_cast<GLuint>(W));
    gl.Uniform1ui(gl.GetUniformLocation(s.pair_program, "tiles"), s.tiles());
    gl.Uniform1ui(s.pair_patches, static_cast<GLuint>(s.normals.size()));
    gl.Uniform1i(s.pair_sky, s.sky ? 1 : 0);
    gl.Uniform1d(s.pair_tie, 1e-9 * s.grid.radius());

    // Buffers of the passes: per-patch depth coefficients (rewritten per direction, in
    // the GPU's memory), each pixel's surface count, the counters, the compaction's
    // group counts, the layers (grown as needed) and the hash table (grown when it
    // overflows or is more than half full).
    s.records.resize(4 * s.normals.size());
    gl.GenBuffers(1, &s.patch_buffer);
    gl.BindBuffer(GL_SHADER_STORAGE_BUFFER, s.patch_buffer);
    gl.BufferStorage(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(std::max<std::size_t>(s.records.size(), 4) * sizeof(double)),
                     nullptr, GL_DYNAMIC_STORAGE_BIT);
    const std::vector<std::uint32_t> no_surfaces(s.cells(), 0);
    s.depth_count = s.buffer(static_cast<GLsizeiptr>(no_surfaces.size() * 4), no_surfaces.data(), GL_DYNAMIC_COPY);
    const std::uint32_t zeros[4] = {0, 0, 0, 0};
    s.counters = s.buffer(sizeof zeros, zeros, GL_DYNAMIC_COPY);
    s.args = s.buffer(3 * sizeof(std::uint32_t), zeros, GL_DYNAMIC_COPY);
    s.reserve_layers(1, 8);
    s.make_table(next_power_of_two(static_cast<std::uint32_t>(std::clamp<std::size_t>(4 * s.normals.size(), 4096, 1u << 22))));
    const char* profile = std::getenv("RAYBUNDLE_ZBUFFER_PROFILE");
    s.profile = profile && *profile && std::string(profile) != "0";
    if (s.profile) gl.GenQueries(4, s.stamps);
    s.check("setup");
}

ZBufferBackend::~ZBufferBackend() {
    if (!impl_ || !impl_->gl) return;
    Impl& s = *impl_;
    const Gl& gl = *s.gl;
    // Names are per context: delete in ours (and leave this thread with none current).
    std::optional<CurrentContext> current;
    try {
        current.emplace(*s.context);
    } catch (...) {
        return;  // destroying the context frees them anyway
    }
    if (s.profile && s.directions > 0) {
        const double d = 1e3 / static_cast<double>(s.directions), g = 1e3 / static_cast<double>(std::max(1L, s.timed));
        std::fprintf(stderr,
                     "zbuffer profile, ms per direction over %ld (%ld submissions of several): CPU prepare %.3f, "
                     "submit %.3f, wait %.3f, finish %.3f (wall, all threads together); GPU over the %ld run alone: "
                     "draw %.3f, pair %.3f, compact %.3f; %.2f surfaces at the deepest pixel\n",
                     s.directions, s.batches, s.cpu_prepare * d, s.cpu_submit * d, s.cpu_wait * d, s.cpu_finish * d,
                     s.timed, s.gpu_draw * g, s.gpu_pair * g, s.gpu_compact * g,
                     static_cast<double>(s.layers) / static_cast<double>(s.directions));
    }
    if (s.profile) gl.DeleteQueries(4, s.stamps);
    gl.DeleteFramebuffers(1, &s.framebuffer);
    gl.DeleteTextures(1, &s.target);
    const GLuint buffers[] = {s.vertex_buffer, s.index_buffer, s.layer_buffer, s.depth_count, s.patch_buffer,
                              s.key_r,         s.key_s,        s.slot_count,   s.counters,    s.used,
                              s.readback,      s.args,         s.batch_vertices, s.batch_records, s.batch_readback};
    gl.DeleteBuffers(static_cast<GLsizei>(std::size(buffers)), buffers);
    gl.DeleteVertexArrays(1, &s.vao);
    for (GLuint p : {s.draw_program, s.pair_program, s.args_program, s.compact_program})
        gl.DeleteProgram(p);
}

int ZBufferBackend::resolution() const { return impl_->grid.resolution(); }

std::string ZBufferBackend::details() const {
    const CurrentContext current(*impl_->context);
    std::string d = impl_->context->describe();
    if (impl_->directions > 0) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "; %.1f surfaces at a direction's deepest pixel",
                      static_cast<double>(impl_->layers) / static_cast<double>(impl_->directions));
        d += buf;
    }
    return d;
}

void ZBufferBackend::transfer(const Vec3& w, const Eigen::Vector2d& jitter, GeometryMatrix& out) {
    Impl& s = *impl_;
    const Gl& gl = *s.gl;
    const CurrentContext current(*s.context);
    out.direction = w;
    out.entries.clear();
    const auto start = std::chrono::steady_clock::now();
    s.prepare(s.grid, w, jitter, s.vertices.data(), s.records.data());
    gl.BindBuffer(GL_ARRAY_BUFFER, s.vertex_buffer);
    gl.BufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(s.vertices.size() * sizeof(float)), s.vertices.data());
    gl.BindBuffer(GL_SHADER_STORAGE_BUFFER, s.patch_buffer);
    gl.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(s.records.size() * sizeof(double)),
                     s.records.data());

    // One draw and one wait for the GPU; again only when a pixel had more surfaces than
    // the layer buffer holds, or the table overflowed (both are then grown).
    const auto prepared = std::chrono::steady_clock::now();
    const double wait_before = s.cpu_wait;
    Impl::Back back{};
    do back = s.pair();
    while (s.grow(back));
    s.layers += back.layers;
    ++s.directions;
    s.check("transfer");
    const auto paired = std::chrono::steady_clock::now();

    // A table more than half full is grown for the next direction.
    if (back.count > s.table_size / 2 && s.table_size < kMaxTable) s.make_table(std::min(4 * s.table_size, kMaxTable));
    entries_from_counts(s.entry_words.data(), back.count, s.grid.pixel_area(), s.sort, out.entries);
    if (s.profile) {
        const auto seconds = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
        s.cpu_prepare += seconds(start, prepared);
        s.cpu_submit += seconds(prepared, paired) - (s.cpu_wait - wait_before);
        s.cpu_finish += seconds(paired, std::chrono::steady_clock::now());
    }
}

int ZBufferBackend::batch_directions() const { return kBatch; }

void ZBufferBackend::transfer_many(const std::vector<Vec3>& directions, const std::vector<Eigen::Vector2d>& jitters,
                                   std::vector<GeometryMatrix>& out, int threads, const std::function<void()>& alongside) {
    Impl& s = *impl_;
    const Gl& gl = *s.gl;
    const std::size_t n = directions.size();
    out.resize(n);
    bool along = static_cast<bool>(alongside);
    for (std::size_t b0 = 0, step = 0; b0 < n; b0 += step) {
        const CurrentContext current(*s.context);
        step = std::min<std::size_t>(static_cast<std::size_t>(s.batch_capacity()), n - b0);
        const int K = static_cast<int>(step);
        if (K == 1) {  // no slots for one direction: the buffers of transfer()
            if (along) alongside();
            along = false;
            transfer(directions[b0], jitters[b0], out[b0]);
            continue;
        }
        s.reserve_batch(K);
        // Each preparing thread holds a copy of the map's grid (its projected vertices, two
        // doubles each; the scene's arrays are shared): at most 256 MiB of them.
        const std::size_t grid_bytes = 64 + s.vertices.size() * 8;
        const int T = std::max(1, std::min({threads, K, static_cast<int>(std::max<std::size_t>(1, (std::size_t{256} << 20) / grid_bytes))}));
        if (static_cast<int>(s.grids.size()) < T) s.grids.resize(static_cast<std::size_t>(T), s.grid);
        if (static_cast<int>(s.scratch.size()) < K) s.scratch.resize(static_cast<std::size_t>(K));
        const auto start = std::chrono::steady_clock::now();

        // The CPU's part first, on the threads: every direction's vertices and records,
        // then one upload of each.
        const std::size_t vertex_floats = static_cast<std::size_t>(s.vertex_slot) / sizeof(float);
        const std::size_t record_doubles = static_cast<std::size_t>(s.record_slot) / sizeof(double);
        parallel_chunks(K, T, [&](int k0, int k1, int t) {
            for (int k = k0; k < k1; ++k)
                s.prepare(s.grids[static_cast<std::size_t>(t)], directions[b0 + k], jitters[b0 + k],
                          &s.stage_vertices[vertex_floats * k], &s.stage_records[record_doubles * k]);
        });
        gl.BindBuffer(GL_ARRAY_BUFFER, s.batch_vertices);
        gl.BufferSubData(GL_ARRAY_BUFFER, 0, s.vertex_slot * K, s.stage_vertices.data());
        gl.BindBuffer(GL_SHADER_STORAGE_BUFFER, s.batch_records);
        gl.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, s.record_slot * K, s.stage_records.data());

        // Every direction drawn, paired and compacted into its slot, one after another on
        // the GPU (each pass leaves the lists and the table clean for the next); the
        // solver's work meanwhile; then the slots read back (the first read waits).
        const auto prepared = std::chrono::steady_clock::now();
        const auto capacity = static_cast<std::uint32_t>(s.layer_capacity);  // as submitted
        for (int k = 0; k < K; ++k) {
            const Impl::Slot slot = s.batch_slot(k);
            s.draw(slot, false);
            s.submit_pair(slot, false);
        }
        s.check("transfer_many");
        const auto submitted = std::chrono::steady_clock::now();
        if (along) {
            alongside();
            along = false;
        }
        const auto waiting = std::chrono::steady_clock::now();
        std::vector<Impl::Back> backs(static_cast<std::size_t>(K));
        for (int k = 0; k < K; ++k)
            backs[static_cast<std::size_t>(k)] = s.read(s.batch_slot(k), s.scratch[static_cast<std::size_t>(k)].words);
        const auto read = std::chrono::steady_clock::now();
        // A direction the GPU could not finish with the buffers as submitted runs again
        // alone, with them grown (rare after the first directions; an earlier one of the
        // batch may have grown them already).
        std::uint32_t most = 0;
        for (int k = 0; k < K; ++k) {
            Impl::Back& back = backs[static_cast<std::size_t>(k)];
            if (back.overflow != 0 || back.layers > capacity) {
                s.grow(back);
                s.prepare(s.grid, directions[b0 + k], jitters[b0 + k], s.vertices.data(), s.records.data());
                gl.BindBuffer(GL_ARRAY_BUFFER, s.vertex_buffer);
                gl.BufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(s.vertices.size() * sizeof(float)),
                                 s.vertices.data());
                gl.BindBuffer(GL_SHADER_STORAGE_BUFFER, s.patch_buffer);
                gl.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(s.records.size() * sizeof(double)),
                                 s.records.data());
                do back = s.pair();
                while (s.grow(back));
                s.scratch[static_cast<std::size_t>(k)].words.swap(s.entry_words);
            }
            s.layers += back.layers;
            ++s.directions;
            most = std::max(most, back.count);
        }
        s.check("transfer_many");
        // A table more than half full is grown for the next submission.
        if (most > s.table_size / 2 && s.table_size < kMaxTable) s.make_table(std::min(4 * s.table_size, kMaxTable));
        // The entries sorted and stored on the threads.
        parallel_chunks(K, T, [&](int k0, int k1) {
            for (int k = k0; k < k1; ++k) {
                auto& x = s.scratch[static_cast<std::size_t>(k)];
                GeometryMatrix& m = out[b0 + static_cast<std::size_t>(k)];
                m.direction = directions[b0 + k];
                entries_from_counts(x.words.data(), backs[static_cast<std::size_t>(k)].count, s.grid.pixel_area(), x.sort,
                                    m.entries);
            }
        });
        if (s.profile) {
            const auto seconds = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
            s.cpu_prepare += seconds(start, prepared);
            s.cpu_submit += seconds(prepared, submitted);
            s.cpu_wait += seconds(waiting, read);
            s.cpu_finish += seconds(read, std::chrono::steady_clock::now());
            ++s.batches;
        }
    }
    if (along) alongside();  // an empty batch
}

}  // namespace raybundle::visibility
