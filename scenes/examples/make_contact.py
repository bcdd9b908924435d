#!/usr/bin/env python3
"""Writes scenes/examples/contact.json and its meshes: a room modelled as people model
rooms, full of contacts. An icosphere of 20,480 triangles resting on the floor at one
vertex, two boxes standing on the floor and touching each other along a face (each box
closed, its bottom lying on the floor), the tall one 0.2 from a wall; a light panel just
under the ceiling. No patch_size: the scene as a modeller hands it over (the loader's
automatic size refines it).

Usage: python3 scenes/examples/make_contact.py   (rewrites the files beside it)
"""
import json
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def icosphere(subdivisions):
    """Unit icosphere: the icosahedron, each triangle cut into four, projected."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
             (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        midpoint = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in midpoint:
                m = [(p + q) / 2.0 for p, q in zip(verts[a], verts[b])]
                n = math.sqrt(sum(x * x for x in m))
                verts.append(tuple(x / n for x in m))
                midpoint[key] = len(verts) - 1
            return midpoint[key]

        refined = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            refined += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = refined
    return verts, faces


def write_sphere(path, centre_xz, radius, subdivisions):
    verts, faces = icosphere(subdivisions)
    # Snapped to the floor as a modeller would: its lowest vertex at y = 0.
    lowest = min(v[1] for v in verts)
    cx, cz = centre_xz
    cy = -lowest * radius
    with open(path, "w") as f:
        f.write("# An icosphere (%d subdivisions of the icosahedron: %d triangles), radius %g,\n"
                "# its lowest vertex on the floor y = 0; faces counter-clockwise seen from outside.\n"
                "# Written by scenes/examples/make_contact.py.\n" % (subdivisions, len(faces), radius))
        for v in verts:
            f.write("v %.6f %.6f %.6f\n" % (cx + radius * v[0], cy + radius * v[1], cz + radius * v[2]))
        for a, b, c in faces:
            f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))
    return len(faces)


def box_quads(lo, hi):
    """The six faces of an axis-aligned box, outward (corners counter-clockwise seen
    from outside), the bottom included."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return {
        "bottom": [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]],
        "top": [[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]],
        "front": [[x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]],
        "back": [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
        "left": [[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]],
        "right": [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]],
    }


def main():
    triangles = write_sphere(os.path.join(HERE, "meshes", "icosphere.obj"), (1.2, 2.8), 0.45, 5)
    room = box_quads((0, 0, 0), (4, 3, 4))
    objects = []
    # The room seen from inside: each face of the box turned inward (corners reversed).
    for name in ("bottom", "top", "front", "back", "left", "right"):
        label = {"bottom": "floor", "top": "ceiling", "front": "wall z-", "back": "wall z+",
                 "left": "wall x-", "right": "wall x+"}[name]
        objects.append({"quad": room[name][::-1], "material": "plaster", "name": label})
    objects.append({"quad": [[1.5, 2.99, 1.6], [2.5, 2.99, 1.6], [2.5, 2.99, 2.6], [1.5, 2.99, 2.6]],
                    "material": "lamp", "name": "lamp"})
    for box, material, lo, hi in (("short box", "red", (2.4, 0, 2.6), (3.2, 0.8, 3.4)),
                                  ("tall box", "plaster", (3.2, 0, 2.8), (3.8, 1.6, 3.4))):
        for face, quad in box_quads(lo, hi).items():
            objects.append({"quad": quad, "material": material, "name": "%s %s" % (box, face)})
    objects.append({"mesh": "meshes/icosphere.obj", "material": "blue", "name": "sphere"})
    scene = {
        "camera": {"eye": [2.0, 1.6, 0.3], "target": [2.2, 0.5, 2.9], "fov_y": 60, "width": 256,
                   "height": 256},
        "materials": {
            "plaster": {"albedo": [0.75, 0.73, 0.7]},
            "red": {"albedo": [0.7, 0.15, 0.12]},
            "blue": {"albedo": [0.15, 0.3, 0.65]},
            "lamp": {"albedo": [0.8, 0.8, 0.8], "emission": [16, 15, 13.5]},
        },
        "objects": objects,
    }
    with open(os.path.join(HERE, "contact.json"), "w") as f:
        f.write("{\n")
        f.write('  "camera": %s,\n' % json.dumps(scene["camera"]))
        f.write('  "materials": {\n')
        mats = list(scene["materials"].items())
        for i, (k, v) in enumerate(mats):
            f.write('    "%s": %s%s\n' % (k, json.dumps(v), "," if i + 1 < len(mats) else ""))
        f.write("  },\n")
        f.write('  "objects": [\n')
        for i, o in enumerate(objects):
            f.write("    %s%s\n" % (json.dumps(o), "," if i + 1 < len(objects) else ""))
        f.write("  ]\n}\n")
    print("wrote contact.json and meshes/icosphere.obj (%d triangles)" % triangles)


if __name__ == "__main__":
    main()
