#!/usr/bin/env python3
"""Dense 'statue' meshes for the heavy-asset bench (docs/benchmarks.md, "Heavy
assets"): a bumpy UV sphere with a flat base standing on the floor of a 4 x 3 x 4 m room
lit by a panel under its ceiling, as a scan or a sculpt arrives. Plain python. Writes,
per size, the OBJ (with normals), binary PLY (normals, colours, confidence), GLB (in
centimetres, z up: the scene places it with scale and rotate), an unwelded OBJ (a
vertex per face corner, as flat-shaded exports write it) and versions without normals,
each with its scene file.

    python3 bench/scenes/make_statue.py OUT_DIR [20k 200k 1m ...]
"""
import math, struct, sys, json, array, os

def sphere(nlat, nlon, R=0.6, base=0.75):
    V = [(0.0, R, 0.0)]
    def rad(t, p):
        return R * (1 + 0.08 * math.sin(7 * t) * math.cos(5 * p) + 0.02 * math.sin(23 * t) * math.sin(19 * p))
    for i in range(1, nlat):
        t = math.pi * i / nlat
        for j in range(nlon):
            p = 2 * math.pi * j / nlon
            r = rad(t, p)
            V.append((r * math.sin(t) * math.cos(p), r * math.cos(t), r * math.sin(t) * math.sin(p)))
    V.append((0.0, -R, 0.0))
    # flat base: clamp y at -base*R (a statue's plinth), then lift so min y = 0
    yb = -base * R
    V = [(x, max(y, yb), z) for (x, y, z) in V]
    V = [(x, y - yb, z) for (x, y, z) in V]
    F = []
    bot = len(V) - 1
    def ring(i, j):
        return 1 + (i - 1) * nlon + (j % nlon)
    for j in range(nlon):
        F.append((0, ring(1, j + 1), ring(1, j)))
    for i in range(1, nlat - 1):
        for j in range(nlon):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)
            F.append((a, b, c)); F.append((a, c, d))
    for j in range(nlon):
        F.append((bot, ring(nlat - 1, j), ring(nlat - 1, j + 1)))
    # orientation: outward (positive signed volume)
    vol = 0.0
    for (a, b, c) in F[: len(F) // 7 * 7: 7]:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = V[a], V[b], V[c]
        vol += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    if vol < 0:
        F = [(a, c, b) for (a, b, c) in F]
    return V, F

def normals(V, F):
    N = [[0.0, 0.0, 0.0] for _ in V]
    for (a, b, c) in F:
        ax, ay, az = V[a]; bx, by, bz = V[b]; cx, cy, cz = V[c]
        ux, uy, uz = bx - ax, by - ay, bz - az
        vx, vy, vz = cx - ax, cy - ay, cz - az
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        for k in (a, b, c):
            n = N[k]; n[0] += nx; n[1] += ny; n[2] += nz
    out = []
    for n in N:
        l = math.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2) or 1.0
        out.append((n[0] / l, n[1] / l, n[2] / l))
    return out

def unweld(V, F, N):
    V2, N2, F2 = [], [], []
    for (a, b, c) in F:
        k = len(V2)
        V2 += [V[a], V[b], V[c]]; N2 += [N[a], N[b], N[c]]
        F2.append((k, k + 1, k + 2))
    return V2, F2, N2

def write_obj(path, V, F, N=None):
    with open(path, 'w') as f:
        f.write('# statue %d verts %d tris\n' % (len(V), len(F)))
        f.write(''.join('v %.6f %.6f %.6f\n' % v for v in V))
        if N:
            f.write(''.join('vn %.5f %.5f %.5f\n' % n for n in N))
            f.write(''.join('f %d//%d %d//%d %d//%d\n' % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1) for (a, b, c) in F))
        else:
            f.write(''.join('f %d %d %d\n' % (a + 1, b + 1, c + 1) for (a, b, c) in F))

def write_ply(path, V, F, N, big=False, claim_v=None, faces=None, countfmt='uchar'):
    e = '>' if big else '<'
    nv = len(V) if claim_v is None else claim_v
    hdr = ('ply\nformat binary_%s_endian 1.0\ncomment scanner export\nobj_info fake scanner\n'
           'element vertex %d\nproperty float x\nproperty float y\nproperty float z\n'
           'property float nx\nproperty float ny\nproperty float nz\n'
           'property uchar red\nproperty uchar green\nproperty uchar blue\nproperty float confidence\n'
           'element face %d\nproperty list %s int vertex_indices\nend_header\n') % (
        'big' if big else 'little', nv, len(F) if faces is None else len(faces), countfmt)
    vs = struct.Struct(e + '6f3Bf')
    buf = bytearray(hdr.encode())
    for v, n in zip(V, N):
        c = int(120 + 100 * max(-1, min(1, n[1])))
        buf += vs.pack(v[0], v[1], v[2], n[0], n[1], n[2], c, 128, 90, 0.93)
    cf = {'uchar': 'B', 'int': 'i', 'uint8': 'B'}[countfmt]
    for f in (F if faces is None else faces):
        buf += struct.pack(e + cf + '%di' % len(f), len(f), *f)
    open(path, 'wb').write(buf)

def write_glb(path, V, F, N, to_cm_zup=True):
    # store in centimetres, z up (as many DCC exports): y->z, z->-y ; scene undoes with scale/rotate
    if to_cm_zup:
        V = [(100 * x, -100 * z, 100 * y) for (x, y, z) in V]
        N = [(x, -z, y) for (x, y, z) in N]
    pos = array.array('f', [c for v in V for c in v])
    nor = array.array('f', [c for n in N for c in n])
    idx = array.array('I', [i for f in F for i in f])
    if sys.byteorder != 'little':
        for a in (pos, nor, idx): a.byteswap()
    bp, bn, bi = pos.tobytes(), nor.tobytes(), idx.tobytes()
    mn = [min(v[k] for v in V) for k in range(3)]
    mx = [max(v[k] for v in V) for k in range(3)]
    g = {
        'asset': {'version': '2.0', 'generator': 'gen.py'},
        'scene': 0, 'scenes': [{'nodes': [0]}],
        'nodes': [{'mesh': 0, 'name': 'statue'}],
        'materials': [{'name': 'stone', 'pbrMetallicRoughness': {'baseColorFactor': [0.6, 0.55, 0.5, 1], 'metallicFactor': 0, 'roughnessFactor': 1}}],
        'meshes': [{'name': 'statue', 'primitives': [{'attributes': {'POSITION': 0, 'NORMAL': 1}, 'indices': 2, 'material': 0, 'mode': 4}]}],
        'buffers': [{'byteLength': len(bp) + len(bn) + len(bi)}],
        'bufferViews': [
            {'buffer': 0, 'byteOffset': 0, 'byteLength': len(bp), 'target': 34962},
            {'buffer': 0, 'byteOffset': len(bp), 'byteLength': len(bn), 'target': 34962},
            {'buffer': 0, 'byteOffset': len(bp) + len(bn), 'byteLength': len(bi), 'target': 34963}],
        'accessors': [
            {'bufferView': 0, 'componentType': 5126, 'count': len(V), 'type': 'VEC3', 'min': mn, 'max': mx},
            {'bufferView': 1, 'componentType': 5126, 'count': len(V), 'type': 'VEC3'},
            {'bufferView': 2, 'componentType': 5125, 'count': 3 * len(F), 'type': 'SCALAR'}],
    }
    js = json.dumps(g).encode()
    js += b' ' * ((4 - len(js) % 4) % 4)
    bin_ = bp + bn + bi
    bin_ += b'\0' * ((4 - len(bin_) % 4) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(path, 'wb') as f:
        f.write(struct.pack('<4sII', b'glTF', 2, total))
        f.write(struct.pack('<I4s', len(js), b'JSON')); f.write(js)
        f.write(struct.pack('<I4s', len(bin_), b'BIN\0')); f.write(bin_)

ROOM = [
    {"quad": [[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]], "material": "floor", "name": "floor"},
    {"quad": [[-2, 3, -2], [2, 3, -2], [2, 3, 2], [-2, 3, 2]], "material": "plaster", "name": "ceiling"},
    {"quad": [[-2, 0, -2], [2, 0, -2], [2, 3, -2], [-2, 3, -2]], "material": "plaster", "name": "back wall"},
    {"quad": [[-2, 0, 2], [-2, 3, 2], [2, 3, 2], [2, 0, 2]], "material": "plaster", "name": "front wall"},
    {"quad": [[-2, 0, -2], [-2, 3, -2], [-2, 3, 2], [-2, 0, 2]], "material": "red", "name": "left wall"},
    {"quad": [[2, 0, -2], [2, 0, 2], [2, 3, 2], [2, 3, -2]], "material": "green", "name": "right wall"},
    {"quad": [[-0.5, 2.99, -0.5], [0.5, 2.99, -0.5], [0.5, 2.99, 0.5], [-0.5, 2.99, 0.5]], "material": "lamp", "name": "lamp"},
]

def scene(path, mesh_obj, extra=None, w=160, h=120):
    objs = [dict(o) for o in ROOM] + ([mesh_obj] if isinstance(mesh_obj, dict) else list(mesh_obj))
    s = {"camera": {"eye": [0, 1.3, 1.9], "target": [0, 0.55, 0], "fov_y": 55, "width": w, "height": h},
         "materials": {"plaster": {"albedo": [0.75, 0.73, 0.7]}, "floor": {"albedo": [0.5, 0.45, 0.4]},
                       "red": {"albedo": [0.7, 0.15, 0.12]}, "green": {"albedo": [0.15, 0.6, 0.2]},
                       "stone": {"albedo": [0.6, 0.55, 0.5]},
                       "lamp": {"albedo": [0.8, 0.8, 0.8], "emission": [12, 11, 10]}},
         "objects": objs}
    if extra: s.update(extra)
    json.dump(s, open(path, 'w'), indent=1)

if __name__ == '__main__':
    if len(sys.argv) < 2:
        sys.exit('usage: make_statue.py OUT_DIR [20k 200k 1m 5k 2k ...]')
    os.makedirs(sys.argv[1], exist_ok=True)
    os.chdir(sys.argv[1])
    os.makedirs('m', exist_ok=True)
    which = sys.argv[2:] or ['200k', '1m']
    sizes = {'1m': (501, 1000), '200k': (251, 400), '20k': (51, 200), '5k': (26, 100), '2k': (17, 60)}
    for tag in which:
        nlat, nlon = sizes[tag]
        V, F = sphere(nlat, nlon); N = normals(V, F)
        print(tag, len(V), 'verts', len(F), 'tris', flush=True)
        write_obj('m/statue_%s.obj' % tag, V, F, N)
        write_ply('m/statue_%s.ply' % tag, V, F, N)
        write_glb('m/statue_%s.glb' % tag, V, F, N)
        Vu, Fu, Nu = unweld(V, F, N)
        write_obj('m/statue_%s_unwelded.obj' % tag, Vu, Fu, Nu)
        write_obj('m/statue_%s_nonormals.obj' % tag, V, F)
        write_obj('m/statue_%s_unwelded_nonormals.obj' % tag, Vu, Fu)
        for fmt in ('obj', 'ply'):
            scene('scene_%s_%s.json' % (tag, fmt), {"mesh": "m/statue_%s.%s" % (tag, fmt), "material": "stone", "name": "statue"})
        scene('scene_%s_unwelded.json' % tag, {"mesh": "m/statue_%s_unwelded.obj" % tag, "material": "stone", "name": "statue"})
        scene('scene_%s_nonormals.json' % tag, {"mesh": "m/statue_%s_nonormals.obj" % tag, "material": "stone", "name": "statue"})
        scene('scene_%s_unwelded_nonormals.json' % tag, {"mesh": "m/statue_%s_unwelded_nonormals.obj" % tag, "material": "stone", "name": "statue"})
        scene('scene_%s_glb.json' % tag, {"mesh": "m/statue_%s.glb" % tag, "name": "statue", "scale": 0.01,
                                          "rotate": [-90, 0, 0], "translate": [0.0, 0, 0]})
