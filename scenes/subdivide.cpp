#include "scenes/subdivide.h"

#include "scenes/buffer.h"
#include "scenes/errors.h"
#include "scenes/machine.h"
#include "scenes/threads.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <iomanip>
#include <sstream>

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

namespace raybundle::scenes {
namespace {

// The corner normals of the face on one side of an edge a-b before its split: at a,
// at b, at the opposite vertex w, and the new vertex's (the normalised blend of a's and
// b's at the split; a zero blend, possible only with file normals, leaves it to
// finalize()).
struct Side {
    TriMesh::VertexHandle a, b, w;
    std::array<double, 3> at_a, at_b, at_w, mid;
    bool valid = false;
};

// h runs from a to b inside the face; the new vertex lies at a + t (b - a).
Side side_of(const TriMesh& mesh, OpenMesh::HPropHandleT<std::array<double, 3>> normal, TriMesh::HalfedgeHandle h,
             double t) {
    Side s;
    if (!mesh.face_handle(h).is_valid()) return s;
    const auto next = mesh.next_halfedge_handle(h), prev = mesh.prev_halfedge_handle(h);
    s.a = mesh.from_vertex_handle(h);
    s.b = mesh.to_vertex_handle(h);
    s.w = mesh.to_vertex_handle(next);
    s.at_a = mesh.property(normal, prev);
    s.at_b = mesh.property(normal, h);
    s.at_w = mesh.property(normal, next);
    const Vec3 sum = (1.0 - t) * to_eigen(s.at_a) + t * to_eigen(s.at_b);
    s.mid = to_array(sum.norm() > 0.0 ? Vec3(sum.normalized()) : Vec3::Zero());
    s.valid = true;
    return s;
}

}  // namespace

TriMesh::VertexHandle split_edge(Scene& scene, TriMesh::HalfedgeHandle h, double t) {
    TriMesh& mesh = scene.mesh;
    const auto normal = scene.corner_normal_handle;
    const auto at = (1.0 - t) * mesh.point(mesh.from_vertex_handle(h)) + t * mesh.point(mesh.to_vertex_handle(h));
    const Side sides[2] = {side_of(mesh, normal, h, t), side_of(mesh, normal, mesh.opposite_halfedge_handle(h), 1.0 - t)};
    const auto ends = std::make_pair(mesh.from_vertex_handle(h), mesh.to_vertex_handle(h));
    const auto m = mesh.split_copy(mesh.edge_handle(h), at);
    // Every face around the new vertex m is part of an old face: of the one on side s
    // when it holds m -> s.b or s.a -> m (s.a -> s.b was its halfedge). The edges from
    // m to the opposite vertices are new: no contact edges (split_copy copied the split
    // edge's mark to them).
    for (auto out : mesh.voh_range(m)) {
        const auto to = mesh.to_vertex_handle(out);
        if (to != ends.first && to != ends.second) mesh.property(scene.contact_edge_handle, mesh.edge_handle(out)) = false;
        if (!mesh.face_handle(out).is_valid()) continue;
        const auto next = mesh.next_halfedge_handle(out), in = mesh.next_halfedge_handle(next);
        const auto x = mesh.to_vertex_handle(out), y = mesh.to_vertex_handle(next);
        for (const Side& s : sides)
            if (s.valid && (x == s.b || y == s.a)) {
                auto corner = [&s](TriMesh::VertexHandle v) { return v == s.a ? s.at_a : v == s.b ? s.at_b : s.at_w; };
                mesh.property(normal, out) = corner(x);
                mesh.property(normal, next) = corner(y);
                mesh.property(normal, in) = s.mid;
            }
    }
    return m;
}

namespace {

// The mesh while subdivide() refines it: connectivity, points, corner normals and
// contact marks in plain arrays. An edge is split exactly as split_edge() splits it
// through OpenMesh's TriConnectivity::split_copy (the same new handles in the same
// order, the same next, prev and outgoing halfedges, the same normals and marks), minus
// OpenMesh's per-element bookkeeping (each new edge and face grew every property array
// of the mesh by one), and a pass's splits run on the threads: see split_all(). The
// result is written back into the mesh once, on the threads. Halfedge h's opposite is
// h ^ 1, its edge h / 2; -1 is no element.
class SplitMesh {
public:
    SplitMesh(const Scene& scene, int threads);

    std::size_t edges() const { return contact.size(); }
    std::size_t faces() const { return face_half.size(); }
    int sides(int e) const { return (he[2 * e].face >= 0 ? 1 : 0) + (he[2 * e + 1].face >= 0 ? 1 : 0); }
    double sqr_length(int e) const { return (point[he[2 * e].to] - point[he[2 * e + 1].to]).sqrnorm(); }
    // Splits the edges at their midpoints, the mesh becoming what split_edge(scene,
    // halfedge 0, 0.5) on each in this order makes; no edge twice.
    void split_all(const std::vector<int>& order, int threads);
    void reserve(std::size_t vertices, std::size_t edges, std::size_t faces);
    void write_back(Scene& scene, int threads) const;

private:
    // Where a split puts what it makes: its vertex, its first new edge and its first new
    // face (OpenMesh's order: the edge to the split edge's tail, then the ones to the
    // opposite corners on halfedge 0's side and on halfedge 1's; the faces likewise).
    struct Slots {
        int vertex, edge, face;
    };
    // A vertex whose outgoing halfedge a split changes (applied after the pass: other
    // threads read that vertex's).
    struct Moved {
        int vertex = -1, halfedge = -1;
    };
    struct Side {  // as side_of() in split_edge(): the face on one side of the edge
        int a = -1, b = -1, w = -1;
        std::array<double, 3> at_a{}, at_b{}, at_w{}, mid{};
        bool valid = false;
    };
    Side side_of(int h, double t) const;
    int new_edge(int from, int into, Slots& at);  // returns the halfedge from -> into
    void set_next(int h, int n) { he[h].next = n, he[n].prev = h; }
    Moved split(int e, Slots at);
    Moved split_midpoint(int e, Slots at);

    struct Half {
        int to, next, prev, face;
        std::array<double, 3> normal;  // the corner normal at its head
    };
    // Grown by each pass and written by its splits on the threads (which take the new
    // memory's page faults): reserved at once for the refined mesh, where possible.
    Buffer<Half> he;                             // per halfedge: one record (a split reads its fields together)
    Buffer<int> out;                             // per vertex: an outgoing halfedge
    Buffer<int> face_half;                       // per face: one of its halfedges
    Buffer<OpenMesh::Vec3d> point;               // per vertex
    Buffer<char> contact;                        // per edge
    Buffer<int> edge_from, face_from;            // per edge, face: the mesh's element whose other properties it copies
    std::size_t mesh_edges = 0, mesh_faces = 0;  // the mesh's counts before the refinement
};

SplitMesh::SplitMesh(const Scene& scene, int threads) {
    const TriMesh& mesh = scene.mesh;
    const std::size_t nh = mesh.n_halfedges(), nv = mesh.n_vertices(), nf = mesh.n_faces();
    mesh_edges = mesh.n_edges(), mesh_faces = nf;
    he.resize(nh);
    out.resize(nv), point.resize(nv), face_half.resize(nf), face_from.resize(nf);
    contact.resize(mesh_edges), edge_from.resize(mesh_edges);
    parallel_chunks(static_cast<int>(nh), threads, [&](int h0, int h1) {
        for (int i = h0; i < h1; ++i) {
            const TriMesh::HalfedgeHandle h(i);
            he[i] = {mesh.to_vertex_handle(h).idx(), mesh.next_halfedge_handle(h).idx(),
                     mesh.prev_halfedge_handle(h).idx(), mesh.face_handle(h).idx(),
                     mesh.property(scene.corner_normal_handle, h)};
        }
    });
    for (std::size_t v = 0; v < nv; ++v) {
        const TriMesh::VertexHandle vh(static_cast<int>(v));
        out[v] = mesh.halfedge_handle(vh).idx();
        point[v] = mesh.point(vh);
    }
    for (std::size_t f = 0; f < nf; ++f) {
        face_half[f] = mesh.halfedge_handle(TriMesh::FaceHandle(static_cast<int>(f))).idx();
        face_from[f] = static_cast<int>(f);
    }
    for (std::size_t e = 0; e < mesh_edges; ++e) {
        contact[e] = mesh.property(scene.contact_edge_handle, TriMesh::EdgeHandle(static_cast<int>(e))) ? 1 : 0;
        edge_from[e] = static_cast<int>(e);
    }
}

void SplitMesh::reserve(std::size_t vertices, std::size_t edges, std::size_t faces) {
    he.reserve(2 * edges), contact.reserve(edges), edge_from.reserve(edges);
    out.reserve(vertices), point.reserve(vertices), face_half.reserve(faces), face_from.reserve(faces);
}

int SplitMesh::new_edge(int from, int into, Slots& at) {
    const int e = at.edge++;
    he[2 * e] = {into, -1, -1, -1, {0.0, 0.0, 0.0}};
    he[2 * e + 1] = {from, -1, -1, -1, {0.0, 0.0, 0.0}};
    contact[e] = 0;
    return 2 * e;
}

// TriConnectivity::split(EdgeHandle, VertexHandle), step for step.
SplitMesh::Moved SplitMesh::split(int e, Slots at) {
    const int v = at.vertex;
    const int h0 = 2 * e, o0 = 2 * e + 1;
    const int v2 = he[o0].to;
    const int e1 = new_edge(v, v2, at), t1 = e1 ^ 1;
    const int f0 = he[h0].face, f3 = he[o0].face;
    out[v] = h0;
    he[o0].to = v;
    if (f0 >= 0) {
        const int h1 = he[h0].next, h2 = he[h1].next;
        const int v1 = he[h1].to;
        const int e0 = new_edge(v, v1, at), t0 = e0 ^ 1;
        const int f1 = at.face++;
        face_half[f0] = h0, face_half[f1] = h2;
        he[h1].face = f0, he[t0].face = f0, he[h0].face = f0;
        he[h2].face = f1, he[t1].face = f1, he[e0].face = f1;
        set_next(h0, h1), set_next(h1, t0), set_next(t0, h0);
        set_next(e0, h2), set_next(h2, t1), set_next(t1, e0);
        face_from[f1] = face_from[f0];  // split_copy: the new face copies the old one
    } else {
        set_next(he[h0].prev, t1), set_next(t1, h0);
    }
    if (f3 >= 0) {
        const int o1 = he[o0].next, o2 = he[o1].next;
        const int v3 = he[o1].to;
        const int e2 = new_edge(v, v3, at), t2 = e2 ^ 1;
        const int f2 = at.face++;
        face_half[f2] = o1, face_half[f3] = o0;
        he[o1].face = f2, he[t2].face = f2, he[e1].face = f2;
        he[o2].face = f3, he[o0].face = f3, he[e2].face = f3;
        set_next(e1, o1), set_next(o1, t2), set_next(t2, e1);
        set_next(o0, e2), set_next(e2, o2), set_next(o2, o0);
        face_from[f2] = face_from[f3];
    } else {
        set_next(e1, he[o0].next), set_next(o0, e1);
        out[v] = e1;
    }
    return out[v2] == h0 ? Moved{v2, t1} : Moved{};
}

SplitMesh::Side SplitMesh::side_of(int h, double t) const {
    Side s;
    if (he[h].face < 0) return s;
    s.a = he[h ^ 1].to, s.b = he[h].to, s.w = he[he[h].next].to;
    s.at_a = he[he[h].prev].normal, s.at_b = he[h].normal, s.at_w = he[he[h].next].normal;
    const Vec3 sum = (1.0 - t) * to_eigen(s.at_a) + t * to_eigen(s.at_b);
    s.mid = to_array(sum.norm() > 0.0 ? Vec3(sum.normalized()) : Vec3::Zero());
    s.valid = true;
    return s;
}

SplitMesh::Moved SplitMesh::split_midpoint(int e, Slots at) {
    const double t = 0.5;
    const int h = 2 * e, m = at.vertex;
    const OpenMesh::Vec3d middle = (1.0 - t) * point[he[h ^ 1].to] + t * point[he[h].to];
    const Side sides[2] = {side_of(h, t), side_of(h ^ 1, 1.0 - t)};
    // split_copy: a new vertex, the split, and the split edge's properties on every edge
    // at the new vertex (the halves and the edges to the opposite corners).
    point[m] = middle;
    const int first = at.edge;
    const Moved moved = split(e, at);
    const int last = first + 1 + (sides[0].valid ? 1 : 0) + (sides[1].valid ? 1 : 0);
    for (int k = first; k < last; ++k) edge_from[k] = edge_from[e];
    // As split_edge(): the edges to the opposite corners are no contact edges (the split
    // edge's other half, made first, keeps the mark), and each face at m takes its corner
    // normals from the side it is part of.
    contact[first] = contact[e];
    for (const int o : {h, 2 * first, 2 * first + 2, 2 * first + 4}) {
        if (o >= 2 * last || he[o].face < 0) continue;
        const int n = he[o].next, in = he[n].next;
        const int x = he[o].to, y = he[n].to;
        for (const Side& s : sides)
            if (s.valid && (x == s.b || y == s.a)) {
                auto corner = [&s](int v) { return v == s.a ? s.at_a : v == s.b ? s.at_b : s.at_w; };
                he[o].normal = corner(x);
                he[n].normal = corner(y);
                he[in].normal = s.mid;
            }
    }
    return moved;
}

// One split changes the halfedges of the two faces on its edge (and of their pieces
// made before it in the pass), the links of a boundary halfedge with its neighbours on
// the boundary, its own new elements, and one outgoing halfedge (returned, applied at
// the end). So the splits fall into groups that share a face or a boundary link; a
// group's splits run in the pass's order on one thread, and the groups side by side.
// Every new element's index is fixed before (by the pass's order, as one split after
// another numbers them), so the mesh is the same for any number of threads. A fine
// refinement's last passes have many groups (docs/benchmarks.md counts them).
void SplitMesh::split_all(const std::vector<int>& order, int threads) {
    const std::size_t k = order.size();
    const int old_edges = static_cast<int>(contact.size()), old_faces = static_cast<int>(face_half.size());
    std::vector<Slots> slots(k);
    Slots next_free{static_cast<int>(point.size()), old_edges, old_faces};
    for (std::size_t i = 0; i < k; ++i) {
        const int e = order[i];
        const int sides = this->sides(e);
        slots[i] = next_free;
        next_free.vertex += 1, next_free.edge += 1 + sides, next_free.face += sides;
    }
    point.resize(static_cast<std::size_t>(next_free.vertex)), out.resize(point.size());
    he.resize(2 * static_cast<std::size_t>(next_free.edge));
    contact.resize(static_cast<std::size_t>(next_free.edge)), edge_from.resize(contact.size());
    face_half.resize(static_cast<std::size_t>(next_free.face)), face_from.resize(face_half.size());

    // The groups: union-find over the splits, joined through the faces at the pass's
    // start and through boundary neighbours that are split too.
    std::vector<int> group(k), split_of(static_cast<std::size_t>(old_edges), -1), owner(static_cast<std::size_t>(old_faces), -1);
    for (std::size_t i = 0; i < k; ++i) group[i] = static_cast<int>(i), split_of[order[i]] = static_cast<int>(i);
    auto find = [&](int x) {
        while (group[x] != x) x = group[x] = group[group[x]];
        return x;
    };
    auto unite = [&](int a, int b) {
        a = find(a), b = find(b);
        if (a != b) group[std::max(a, b)] = std::min(a, b);
    };
    for (std::size_t i = 0; i < k; ++i)
        for (const int h : {2 * order[i], 2 * order[i] + 1}) {
            const int f = he[h].face;
            if (f >= 0) {
                int& o = owner[static_cast<std::size_t>(f)];
                if (o < 0) o = static_cast<int>(i);
                else unite(static_cast<int>(i), o);
            } else {
                for (const int neighbour : {he[h].prev, he[h].next})
                    if (const int j = split_of[static_cast<std::size_t>(neighbour / 2)]; j >= 0) unite(static_cast<int>(i), j);
            }
        }
    // Each group's splits in order (a group is named by its first split), the largest
    // groups dealt out first.
    std::vector<int> start(k + 1, 0), members(k);
    for (std::size_t i = 0; i < k; ++i) group[i] = find(static_cast<int>(i));  // roots precede their members
    for (std::size_t i = 0; i < k; ++i) ++start[static_cast<std::size_t>(group[i]) + 1];
    std::vector<int> groups;
    for (std::size_t i = 0; i < k; ++i)
        if (start[i + 1] > 0) groups.push_back(static_cast<int>(i));
    for (std::size_t i = 0; i < k; ++i) start[i + 1] += start[i];
    {
        std::vector<int> fill(start.begin(), start.end() - 1);
        for (std::size_t i = 0; i < k; ++i) members[static_cast<std::size_t>(fill[static_cast<std::size_t>(group[i])]++)] = static_cast<int>(i);
    }
    std::stable_sort(groups.begin(), groups.end(), [&](int a, int b) { return start[a + 1] - start[a] > start[b + 1] - start[b]; });
    std::vector<Moved> moved(k);
    // Chunks of consecutive groups of about k / (16 threads) splits each (the many small
    // groups of the last passes write neighbouring slots: one thread to a page), the
    // largest groups first, each a chunk of its own where it is that large. Chunks of a
    // fixed count of groups put a pass's few large groups (one per wall) in one chunk,
    // on one thread: at 121,324 patches, a pass of 12,000 splits in 263 groups ran on one
    // thread while the other waited. A pass of a few thousand splits is quicker on one
    // thread.
    const int T = k >= 4096 ? threads : 1;
    const std::size_t per_chunk = std::max<std::size_t>(1, k / (16 * static_cast<std::size_t>(std::max(1, T))));
    std::vector<int> chunk_start(1, 0);  // into groups
    for (std::size_t g = 0, size = 0; g < groups.size(); ++g) {
        size += static_cast<std::size_t>(start[groups[g] + 1] - start[groups[g]]);
        if (size >= per_chunk || g + 1 == groups.size()) chunk_start.push_back(static_cast<int>(g + 1)), size = 0;
    }
    const int chunks = static_cast<int>(chunk_start.size()) - 1;
    parallel_chunks(chunks, T, [&](int c0, int c1) {
        for (int g = chunk_start[c0]; g < chunk_start[c1]; ++g)
            for (int m = start[groups[g]]; m < start[groups[g] + 1]; ++m) {
                const auto i = static_cast<std::size_t>(members[static_cast<std::size_t>(m)]);
                moved[i] = split_midpoint(order[i], slots[i]);
            }
    }, std::max(1, chunks));  // one chunk at a time
    for (const Moved& m : moved)
        if (m.vertex >= 0) out[static_cast<std::size_t>(m.vertex)] = m.halfedge;
}

void SplitMesh::write_back(Scene& scene, int threads) const {
    TriMesh& mesh = scene.mesh;
    const std::size_t nv = point.size(), ne = contact.size(), nf = face_half.size(), old_v = mesh.n_vertices();
    // OpenMesh writes every element it adds, array by array: the property arrays grown
    // on the threads (largest first, one thread each), then the kernel's own. With room
    // to spare for the contact cuts that follow: a split past the capacity would copy
    // every array of the mesh, on one thread (4 ms at 121k patches).
    auto room = [](std::size_t n) { return n + n / 8 + 1024; };
    struct Grown {
        OpenMesh::BaseProperty* property;
        std::size_t size, capacity;  // as the kernel's reserve() and resize() below
    };
    std::vector<Grown> grow;
    for (auto it = mesh.vprops_begin(); it != mesh.vprops_end(); ++it)
        if (*it) grow.push_back({*it, nv, room(nv)});
    for (auto it = mesh.hprops_begin(); it != mesh.hprops_end(); ++it)
        if (*it) grow.push_back({*it, 2 * ne, 2 * room(ne)});
    for (auto it = mesh.eprops_begin(); it != mesh.eprops_end(); ++it)
        if (*it) grow.push_back({*it, ne, room(ne)});
    for (auto it = mesh.fprops_begin(); it != mesh.fprops_end(); ++it)
        if (*it) grow.push_back({*it, nf, room(nf)});
    std::stable_sort(grow.begin(), grow.end(), [](const Grown& a, const Grown& b) {
        return a.property->size_of(a.size) > b.property->size_of(b.size);
    });
    parallel_chunks(static_cast<int>(grow.size()), threads, [&](int k0, int k1) {
        for (int k = k0; k < k1; ++k) {
            const Grown& g = grow[static_cast<std::size_t>(k)];
            g.property->reserve(g.capacity);
            g.property->resize(g.size);
        }
    }, std::max<int>(1, static_cast<int>(grow.size())));  // one property a chunk
    mesh.reserve(room(nv), room(ne), room(nf));
    mesh.resize(nv, ne, nf);
    parallel_chunks(static_cast<int>(he.size()), threads, [&](int h0, int h1) {
        for (int i = h0; i < h1; ++i) {
            const TriMesh::HalfedgeHandle h(i);
            mesh.set_vertex_handle(h, TriMesh::VertexHandle(he[i].to));
            mesh.set_next_halfedge_handle(h, TriMesh::HalfedgeHandle(he[i].next));  // and next's prev
            mesh.set_face_handle(h, TriMesh::FaceHandle(he[i].face));
            mesh.property(scene.corner_normal_handle, h) = he[i].normal;
        }
    });
    parallel_chunks(static_cast<int>(nv), threads, [&](int v0, int v1) {
        for (int v = v0; v < v1; ++v) {
            const TriMesh::VertexHandle vh(v);
            mesh.set_halfedge_handle(vh, TriMesh::HalfedgeHandle(out[static_cast<std::size_t>(v)]));
            if (static_cast<std::size_t>(v) >= old_v) mesh.set_point(vh, point[static_cast<std::size_t>(v)]);
        }
    });
    parallel_chunks(static_cast<int>(nf), threads, [&](int f0, int f1) {
        for (int f = f0; f < f1; ++f)
            mesh.set_halfedge_handle(TriMesh::FaceHandle(f), TriMesh::HalfedgeHandle(face_half[static_cast<std::size_t>(f)]));
    });
    // The new edges' and faces' other properties (status, materials, objects, any a
    // loader added) copied from the elements they came from, each property by one thread
    // (the contact marks are bits: one writer).
    std::vector<OpenMesh::BaseProperty*> edge_props, face_props;
    for (auto it = mesh.eprops_begin(); it != mesh.eprops_end(); ++it)
        if (*it && *it != &mesh.property(scene.contact_edge_handle)) edge_props.push_back(*it);
    for (auto it = mesh.fprops_begin(); it != mesh.fprops_end(); ++it)
        if (*it) face_props.push_back(*it);
    const int tasks = static_cast<int>(edge_props.size() + face_props.size()) + 1;
    parallel_chunks(tasks, threads, [&](int k0, int k1) {
        for (int k = k0; k < k1; ++k) {
            if (k < static_cast<int>(edge_props.size())) {
                for (std::size_t e = mesh_edges; e < ne; ++e)
                    edge_props[static_cast<std::size_t>(k)]->copy(static_cast<std::size_t>(edge_from[e]), e);
            } else if (k < tasks - 1) {
                for (std::size_t f = mesh_faces; f < nf; ++f)
                    face_props[static_cast<std::size_t>(k) - edge_props.size()]->copy(
                        static_cast<std::size_t>(face_from[f]), f);
            } else {
                auto& marks = mesh.property(scene.contact_edge_handle);  // bits: one writer
                for (std::size_t e = 0; e < ne; ++e) marks[e] = contact[e] != 0;
            }
        }
    }, 1);
}

}  // namespace

PatchLimit::PatchLimit(std::size_t count)
    : std::runtime_error("refinement would make " + std::to_string(count) + " patches or more"), patches(count) {}

std::size_t subdivide(Scene& scene, double max_edge, int threads, Finish finish, double max_patches) {
    const double limit2 = max_edge * max_edge;
    SplitMesh mesh(scene, threads);
    // Room for the refined mesh at once: reserved, not touched, so a count too high costs
    // address space only, and one too low lets the arrays grow (a copy on one thread).
    // Refinement leaves pieces of max_edge^2 / 6 on average (121,324 of a Cornell box of
    // 1.9e6 mm^2 at 10 mm), few below max_edge^2 / 12, and a sliver cut along its length.
    double faces = 0.0;
    for (const auto& p : scene.patch_list()) {
        const auto& pos = scene.vertex_positions();
        double longest = 0.0;
        for (int k = 0; k < 3; ++k) longest = std::max(longest, (pos[p.v[k]] - pos[p.v[(k + 1) % 3]]).norm());
        faces += std::max({1.0, p.area / (limit2 / 12.0), 2.0 * longest / max_edge});
    }
    faces = std::min(faces, max_patches);  // never more: the passes stop there
    const auto f = static_cast<std::size_t>(faces);
    mesh.reserve(scene.mesh.n_vertices() + f / 2 + 64, scene.mesh.n_edges() + 3 * f / 2 + 64, f + 64);
    std::size_t splits = 0;
    std::vector<std::pair<double, int>> long_edges;
    std::vector<int> order;
    std::vector<std::vector<std::pair<double, int>>> found(static_cast<std::size_t>(std::max(1, threads)));
    for (;;) {
        // The edges longer than the limit, in edge order (bands on the threads, joined in order).
        const std::size_t n = mesh.edges();
        run_threads(static_cast<int>(found.size()), [&](int t) {
            auto& mine = found[static_cast<std::size_t>(t)];
            mine.clear();
            const std::size_t e1 = n * static_cast<std::size_t>(t + 1) / found.size();
            for (std::size_t e = n * static_cast<std::size_t>(t) / found.size(); e < e1; ++e) {
                const double len2 = mesh.sqr_length(static_cast<int>(e));
                if (len2 > limit2) mine.emplace_back(len2, static_cast<int>(e));
            }
        });
        long_edges.clear();
        for (const auto& mine : found) long_edges.insert(long_edges.end(), mine.begin(), mine.end());
        if (long_edges.empty()) break;
        // Longest first (splitting the longest edge of a triangle is what keeps shapes
        // bounded), equal lengths in edge order.
        parallel_sort(long_edges, threads, [](const auto& a, const auto& b) {
            return a.first > b.first || (a.first == b.first && a.second < b.second);
        });
        // Each listed edge is split: only its own split moves its ends.
        order.resize(long_edges.size());
        for (std::size_t i = 0; i < long_edges.size(); ++i) order[i] = long_edges[i].second;
        // Each split makes a face on each side of its edge.
        std::size_t faces_after = mesh.faces();
        for (const int e : order) faces_after += mesh.sides(e);
        if (static_cast<double>(faces_after) > max_patches) throw PatchLimit(faces_after);
        mesh.split_all(order, threads);
        splits += order.size();
    }
    if (splits > 0) mesh.write_back(scene, threads);
    if (finish == Finish::finalize) scene.finalize(threads);
    return splits;
}

namespace {

// The longest edge of face f, and its squared length.
std::pair<TriMesh::EdgeHandle, double> longest_edge(const TriMesh& mesh, TriMesh::FaceHandle f) {
    std::pair<TriMesh::EdgeHandle, double> best{TriMesh::EdgeHandle(), -1.0};
    for (auto e : mesh.fe_range(f)) {
        const double len2 = mesh.calc_edge_sqr_length(e);
        // Ties broken by index, so that two triangles agree on which is the longest.
        if (len2 > best.second || (len2 == best.second && e.idx() < best.first.idx())) best = {e, len2};
    }
    return best;
}

// One LEPP bisection of face f: its longest edge is split once it is the longest edge of
// the triangle across it too (or on the boundary); until then that triangle is bisected
// first. Along the path the longest edges grow, so it ends; `depth` bounds it anyway.
std::size_t bisect(Scene& scene, TriMesh::FaceHandle f, int depth = 0) {
    TriMesh& mesh = scene.mesh;
    std::size_t splits = 0;
    for (;;) {
        const auto [e, len2] = longest_edge(mesh, f);
        auto h = mesh.halfedge_handle(e, 0);
        if (mesh.face_handle(h) != f) h = mesh.halfedge_handle(e, 1);
        const auto g = mesh.opposite_face_handle(h);
        // Past 64 levels (never seen: along the path the longest edges grow) the edge is
        // split all the same, which gives up the angle bound for that cut.
        if (!g.is_valid() || longest_edge(mesh, g).first == e || depth > 64) {
            split_edge(scene, h, 0.5);
            return splits + 1;
        }
        splits += bisect(scene, g, depth + 1);  // g's cut edges rank above e: look again
    }
}

}  // namespace

std::size_t refine_patches(Scene& scene, const std::vector<double>& max_edge, std::vector<std::uint32_t>* origin,
                           int threads) {
    TriMesh& mesh = scene.mesh;
    if (max_edge.size() != mesh.n_faces())
        throw std::invalid_argument("refine_patches: " + std::to_string(max_edge.size()) + " sizes for " +
                                    std::to_string(mesh.n_faces()) + " patches");
    // Per face, the size its pieces must reach and the patch it came from: face
    // properties, which every split copies to the new faces.
    for (std::size_t i = 0; i < max_edge.size(); ++i)
        if (!(max_edge[i] * max_edge[i] > 0.0))  // also a size so small that its square is 0
            throw std::invalid_argument("refine_patches: patch " + std::to_string(i) + " is given the size " +
                                        std::to_string(max_edge[i]) + " (must be positive)");
    OpenMesh::FPropHandleT<double> limit;
    OpenMesh::FPropHandleT<int> from;
    mesh.add_property(limit);
    mesh.add_property(from);
    for (auto f : mesh.faces()) {
        const double m = max_edge[static_cast<std::size_t>(f.idx())];
        mesh.property(limit, f) = m * m;
        mesh.property(from, f) = f.idx();
    }
    std::size_t splits = 0;
    std::vector<std::pair<double, TriMesh::FaceHandle>> due;
    for (;;) {
        due.clear();
        for (auto f : mesh.faces()) {
            const double len2 = longest_edge(mesh, f).second;
            if (len2 > mesh.property(limit, f)) due.emplace_back(len2, f);
        }
        if (due.empty()) break;
        std::stable_sort(due.begin(), due.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
        for (const auto& [len2, f] : due)
            // An earlier bisection in this pass may have cut this face already.
            if (longest_edge(mesh, f).second > mesh.property(limit, f)) splits += bisect(scene, f);
    }
    scene.finalize(threads);
    // Both halves of a split contact edge keep the mark: the count the record shows.
    scene.contact_edges = 0;
    for (auto e : mesh.edges()) scene.contact_edges += mesh.property(scene.contact_edge_handle, e) ? 1 : 0;
    if (origin) {
        origin->clear();
        origin->reserve(mesh.n_faces());
        for (auto f : mesh.faces()) origin->push_back(static_cast<std::uint32_t>(mesh.property(from, f)));
    }
    mesh.remove_property(limit);
    mesh.remove_property(from);
    return splits;
}

namespace {

// A count with thousands separators: 20,000,000.
std::string grouped(double count) {
    std::ostringstream text;
    text.imbue(std::locale::classic());
    text << std::fixed << std::setprecision(0) << count;
    std::string digits = text.str();
    for (int k = static_cast<int>(digits.size()) - 3; k > 0; k -= 3) digits.insert(static_cast<std::size_t>(k), ",");
    return digits;
}

std::string shown_size(double max_edge) {
    std::ostringstream size;
    size << max_edge;
    return size.str();
}

}  // namespace

PatchBudget patch_budget(double max_patches, const MemoryShare& memory) {
    const double held = static_cast<double>(memory.bytes) / kPreparationBytes;
    if (memory.bytes > 0 && held < max_patches)
        return {held, "limit " + grouped(held) + ": about " + shown_size(kPreparationBytes / 1e3) +
                          " KB each while the scene is prepared, and " + memory.text()};
    return {max_patches, "limit " + grouped(max_patches)};
}

void check_refinement(const Scene& scene, double max_edge, const std::string& shown, const PatchBudget& budget) {
    if (!(max_edge > 0.0) || !std::isfinite(max_edge))
        throw SceneError(shown, "patch_size", "must be a positive number, got " + shown_size(max_edge));
    // Per triangle, the pieces its area needs or, for a sliver, its longest edge: a
    // 1000 x 0.001 sliver has little area but is cut along all of its length.
    double estimate = 0.0;
    const auto& pos = scene.vertex_positions();
    for (const auto& p : scene.patch_list()) {
        double longest = 0.0;
        for (int k = 0; k < 3; ++k) longest = std::max(longest, (pos[p.v[k]] - pos[p.v[(k + 1) % 3]]).norm());
        estimate += std::max({1.0, p.area / (0.25 * max_edge * max_edge), longest / max_edge});
    }
    if (estimate > budget.patches)
        throw SceneError(shown, "patch_size",
                         shown_size(max_edge) + " would make about " + grouped(estimate) + " patches (" + budget.why + ")");
}

std::size_t refine_within(Scene& scene, double max_edge, const std::string& shown, const PatchBudget& budget,
                          int threads, Finish finish) {
    check_refinement(scene, max_edge, shown, budget);
    try {
        return subdivide(scene, max_edge, threads, finish, budget.patches);
    } catch (const PatchLimit& e) {
        throw SceneError(shown, "patch_size",
                         shown_size(max_edge) + " makes " + grouped(static_cast<double>(e.patches)) +
                             " patches or more (" + budget.why + ")");
    }
}

}  // namespace raybundle::scenes
