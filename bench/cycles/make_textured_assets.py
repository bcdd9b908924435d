"""Makes the textured example asset, a room with per-texel albedo read through UVs, with
Blender's own glTF and OBJ exporters, modelled as people model a scene in Blender (a
closed room, a box standing on its floor, a lamp panel under the ceiling, images on the
materials' Base Color), so that raybundle reads textures as Blender writes them.

    blender -b --factory-startup -t 1 --python bench/cycles/make_textured_assets.py -- scenes/examples

(Blender's glTF exporter needs python3-numpy, which Debian's blender does not pull in.)
Writes, under the examples folder given:

  gltf/textured-room.glb       the scene, its three PNG images embedded, and a camera.
  textured-room/textured-room.obj, .mtl, checker.png, wall.png, cube.png
                               the same meshes through the OBJ exporter (+Y up, the
                               glTF file's coordinates; map_Kd names the PNGs beside
                               the MTL). No camera: an OBJ has none.

The room (Blender: x, y in [-2, 2], z in [0, 2.5]; glTF: x, z in [-2, 2], y up) is one
inward box: its floor shows checker.png (8 x 8 squares of 0.5 m, linear albedo 0.80 0.70
0.55 and 0.12 0.15 0.20), its back wall (Blender y = +2, glTF z = -2) wall.png (256 x 160:
red to green left to right as seen from the room, a white vertical stripe near the left
edge and a dark blue band near the top, so that a flipped u or v shows), the other walls
and the ceiling a plain 0.7 grey. A 0.8 m cube, turned 30 degrees about the vertical,
stands on the floor with cube.png (four coloured quadrants, each with a white mark in
its top left corner): each side face one quadrant, upright as seen from outside with its
mark at the face's top left, the top and bottom faces the whole image. A 1.2 m square
panel 5 cm under the ceiling faces down, emitting 8 x (1 0.95 0.85) (emissiveFactor with
KHR_materials_emissive_strength; Ke in the MTL). The camera looks at the cube with the
textured wall behind it (glTF coordinates: eye -0.3 1.45 1.9, target 0.2 0.8 -1, 70
degrees vertically), the panel's edge at the top of its view.

UVs as Blender counts them (v up from the image's bottom row, as the OBJ's vt): the
floor u = (x + 2) / 4 along glTF +x, v = (2 - z) / 4 along glTF -z; the wall u = (x + 2) / 4,
v = y / 2.5 (up). The glTF exporter writes v' = 1 - v (down from the image's top row),
the same texels. With 8 squares a side, a flipped u or v alone swaps the checker's colours.

Every material is single-sided (doubleSided false) with metallic 0 and roughness 1
(Principled's specular left at 0.5, as in the other assets: the MTL's Ks 0.5, which
raybundle reads as no lobe in a Blender MTL; 0 would make the glTF exporter add
KHR_materials_specular and KHR_materials_ior): diffuse with an emitter, what
bench/cycles/import_obj.py renders with Cycles. The image texels are 8-bit sRGB; the
linear albedos above are what they decode to. The files are committed; this script is
how they were made.
"""

import math
import os
import struct
import sys
import zlib

import bpy
import numpy
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_gltf_assets import camera, reset  # noqa: E402  (the other assets' helpers)

# Blender 3.4's glTF exporter uses numpy.bool, an alias that Debian 12's numpy (1.24)
# no longer has: restored for it.
if "bool" not in numpy.__dict__:
    numpy.bool = bool

LIGHT = (0.80, 0.70, 0.55)  # the checker's two linear albedos
DARK = (0.12, 0.15, 0.20)
RED, GREEN = (0.70, 0.10, 0.08), (0.10, 0.60, 0.15)  # the wall's gradient, left to right
STRIPE, BAND = (0.85, 0.85, 0.85), (0.05, 0.08, 0.40)
QUADRANTS = {  # cube.png, by quadrant (u, v halves, v up as Blender and OBJ count it)
    (0, 0): (0.70, 0.08, 0.06),  # bottom left: red
    (1, 0): (0.10, 0.55, 0.12),  # bottom right: green
    (1, 1): (0.08, 0.15, 0.65),  # top right: blue
    (0, 1): (0.75, 0.60, 0.05),  # top left: yellow
}
MARK = (0.90, 0.90, 0.90)


def srgb_byte(linear):
    c = max(0.0, min(1.0, linear))
    s = 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055
    return int(round(255.0 * s))


def write_png(path, width, height, texel):
    """An 8-bit RGB PNG: texel(u, v) is the linear colour at the texel's centre, with v up
    (the image's bottom row v near 0), stored sRGB-encoded, top row first as PNG stores it."""
    rows = []
    for row in range(height):
        v = 1.0 - (row + 0.5) / height
        line = bytearray([0])  # filter: none
        for col in range(width):
            line += bytes(srgb_byte(c) for c in texel((col + 0.5) / width, v))
        rows.append(bytes(line))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                + chunk(b"sRGB", b"\x00") + chunk(b"IDAT", zlib.compress(b"".join(rows), 9)) + chunk(b"IEND", b""))


def checker(u, v):
    return LIGHT if (int(u * 8) + int(v * 8)) % 2 == 0 else DARK


def wall_texel(u, v):
    if 0.10 <= u < 0.16:
        return STRIPE
    if 0.70 <= v < 0.76:
        return BAND
    return tuple(a + (b - a) * u for a, b in zip(RED, GREEN))


def cube_texel(u, v):
    qu, qv = int(u >= 0.5), int(v >= 0.5)
    fu, fv = 2 * u - qu, 2 * v - qv  # within the quadrant, v up
    if fu < 0.3 and fv > 0.7:  # the mark: the quadrant's top left corner
        return MARK
    return QUADRANTS[(qu, qv)]


def material(name, colour=(0.7, 0.7, 0.7), image=None, emission=None, strength=0.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.use_backface_culling = True
    nodes = m.node_tree.nodes
    p = nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*colour, 1.0)
    p.inputs["Metallic"].default_value = 0.0
    p.inputs["Roughness"].default_value = 1.0
    if image:
        tex = nodes.new("ShaderNodeTexImage")  # through the mesh's UV map; Linear, Repeat
        tex.image = bpy.data.images.load(image)
        tex.location = (-400, 200)
        m.node_tree.links.new(tex.outputs["Color"], p.inputs["Base Color"])
    if emission:
        p.inputs["Emission"].default_value = (*emission, 1.0)
        p.inputs["Emission Strength"].default_value = strength
    return m


def box(name, lo, hi, mat, inward=False, size=1.0):
    """An axis-aligned box (Blender's Z up) with outward faces, or inward for a room."""
    bpy.ops.mesh.primitive_cube_add(size=size)
    o = bpy.context.active_object
    o.name = name
    if size == 1.0:
        o.scale = [h - l for l, h in zip(lo, hi)]
        bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    o.location = [(l + h) / 2 for l, h in zip(lo, hi)]
    if inward:
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.mesh.flip_normals()
        bpy.ops.object.mode_set(mode="OBJECT")
    o.data.materials.append(mat)
    return o


def set_uvs(obj, normal, uv_of):
    """The UVs of obj's faces whose (mesh) normal is `normal`: uv_of(p) at each corner p, in the
    mesh's own coordinates, as a person would unwrap them face by face."""
    mesh = obj.data
    uv = mesh.uv_layers.active.data
    for poly in mesh.polygons:
        if (poly.normal - Vector(normal)).length < 1e-4:
            for li in poly.loop_indices:
                uv[li].uv = uv_of(mesh.vertices[mesh.loops[li].vertex_index].co)


def textured_room(examples):
    reset()
    obj_dir = os.path.join(examples, "textured-room")
    os.makedirs(obj_dir, exist_ok=True)
    os.makedirs(os.path.join(examples, "gltf"), exist_ok=True)
    images = {"checker": (256, 256, checker), "wall": (256, 160, wall_texel), "cube": (128, 128, cube_texel)}
    for name, (w, h, texel) in images.items():
        write_png(os.path.join(obj_dir, name + ".png"), w, h, texel)
    png = {name: os.path.join(obj_dir, name + ".png") for name in images}

    plain = material("plain wall")
    floor = material("checker floor", image=png["checker"])
    back = material("gradient wall", image=png["wall"])
    room = box("room", (-2.0, -2.0, 0.0), (2.0, 2.0, 2.5), plain, inward=True)
    room.data.materials.append(floor)
    room.data.materials.append(back)
    for poly in room.data.polygons:  # by their (inward) normals: the mesh is centred on its origin
        if poly.normal.z > 0.5:
            poly.material_index = 1
        elif poly.normal.y < -0.5:
            poly.material_index = 2
    # Mesh coordinates: the box's centre at its origin (0, 0, 1.25 in the world).
    set_uvs(room, (0, 0, 1), lambda p: ((p.x + 2.0) / 4.0, (p.y + 2.0) / 4.0))  # the floor, seen from above
    set_uvs(room, (0, -1, 0), lambda p: ((p.x + 2.0) / 4.0, (p.z + 1.25) / 2.5))  # the back wall, from inside

    cube = box("cube", (-0.15, 0.05, 0.0), (0.65, 0.85, 0.8), material("quadrant cube", image=png["cube"]), size=0.8)
    cube.rotation_euler = (0.0, 0.0, math.radians(30.0))
    sides = [  # the face's normal, its quadrant's lower left corner, its right as seen from outside
        ((0, -1, 0), (0.0, 0.0), Vector((1, 0, 0))),
        ((1, 0, 0), (0.5, 0.0), Vector((0, 1, 0))),
        ((0, 1, 0), (0.5, 0.5), Vector((-1, 0, 0))),
        ((-1, 0, 0), (0.0, 0.5), Vector((0, -1, 0))),
    ]
    for normal, (u0, v0), right in sides:  # mesh coordinates -0.4..0.4: the quadrant, upright
        set_uvs(cube, normal, lambda p, u0=u0, v0=v0, r=right: (u0 + (p.dot(r) + 0.4) / 1.6, v0 + (p.z + 0.4) / 1.6))
    set_uvs(cube, (0, 0, 1), lambda p: ((p.x + 0.4) / 0.8, (p.y + 0.4) / 0.8))  # the whole image
    set_uvs(cube, (0, 0, -1), lambda p: ((p.x + 0.4) / 0.8, (0.4 - p.y) / 0.8))

    panel = material("panel", (0.8, 0.8, 0.8), emission=(1.0, 0.95, 0.85), strength=8.0)
    bpy.ops.mesh.primitive_plane_add(size=1.2, location=(0.0, 0.0, 2.45))
    light = bpy.context.active_object
    light.name = "ceiling panel"
    light.rotation_euler = (math.pi, 0.0, 0.0)  # facing down
    light.data.materials.append(panel)

    camera(Vector((-0.3, -1.9, 1.45)), Vector((0.2, 1.0, 0.8)), 70.0)

    bpy.ops.export_scene.gltf(filepath=os.path.join(examples, "gltf", "textured-room.glb"), export_format="GLB",
                              export_cameras=True, export_lights=True, export_apply=True, export_yup=True,
                              export_texcoords=True, export_normals=True, export_image_format="AUTO")
    bpy.ops.object.select_all(action="DESELECT")
    bpy.ops.wm.obj_export(filepath=os.path.join(obj_dir, "textured-room.obj"), export_selected_objects=False,
                          forward_axis="NEGATIVE_Z", up_axis="Y", export_uv=True, export_normals=True,
                          export_materials=True, path_mode="RELATIVE")


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 1:
        raise SystemExit("usage: blender -b --factory-startup --python make_textured_assets.py -- EXAMPLES_DIR")
    textured_room(os.path.abspath(argv[0]))


if __name__ == "__main__":
    try:
        main()
    except SystemExit:
        raise
    except Exception as e:  # one line, and a failing exit status (Blender would exit 0)
        print("make_textured_assets.py: error: %s" % e, file=sys.stderr, flush=True)
        sys.exit(1)
