"""Makes the vertex-coloured example asset, a room with things painted by their vertices'
colours, with Blender's own glTF exporter, modelled as people model a scene in Blender
(a closed room, a box and a subdivided monkey standing on its floor, a lamp panel
under the ceiling, colour attributes painted on the meshes), so that raybundle reads
vertex colours (glTF COLOR_0) as Blender writes them.

    blender -b --factory-startup -t 1 --python bench/cycles/make_painted_assets.py -- scenes/examples

(Blender's glTF exporter needs python3-numpy, which Debian's blender does not pull in.)
Writes, under the examples folder given:

  gltf/painted-room.glb   the scene and a camera; COLOR_0 on the box and the monkey.

The room (Blender: x, y in [-2, 2], z in [0, 2.5]; glTF: x, z in [-2, 2], y up) is one
inward box of a plain 0.7 grey (its floor 0.6). A 0.8 m box, turned 25 degrees about the
vertical, stands on the floor, each of its eight corners a colour of its own (the faces'
colours blend from corner to corner); Blender's monkey, subdivided twice and smooth
(15,744 triangles), sits on the floor beside it, its colour a hue that turns
around the vertical and brightens upwards. Both materials' base colour is the colour
attribute: the exporter writes COLOR_0 (linear floats) with a base colour factor of 1,
and glTF multiplies the two. A 1.2 m square panel 5 cm under the ceiling faces
down, emitting 8 x (1 0.95 0.85). The camera looks at both from the front, 60 degrees
vertically.

Every material is single-sided (doubleSided false) with metallic 0 and roughness 1:
diffuse with an emitter, what bench/cycles/import_obj.py renders with Cycles. The file
is committed; this script is how it was made.
"""

import colorsys
import math
import os
import sys

import bpy
import numpy
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_gltf_assets import camera, reset  # noqa: E402  (the other assets' helpers)
from make_textured_assets import box, material, srgb_byte  # noqa: E402

# Blender 3.4's glTF exporter uses numpy.bool, an alias that Debian 12's numpy (1.24)
# no longer has: restored for it.
if "bool" not in numpy.__dict__:
    numpy.bool = bool

CORNERS = {  # the box's corners (mesh coordinates' signs) and their linear colours
    (-1, -1, -1): (0.80, 0.10, 0.08), (1, -1, -1): (0.85, 0.65, 0.05), (1, 1, -1): (0.10, 0.60, 0.15),
    (-1, 1, -1): (0.08, 0.15, 0.70), (-1, -1, 1): (0.90, 0.90, 0.90), (1, -1, 1): (0.60, 0.10, 0.60),
    (1, 1, 1): (0.05, 0.55, 0.60), (-1, 1, 1): (0.20, 0.20, 0.20),
}


def on_byte(linear):
    """The linear value of the 8-bit sRGB value nearest `linear`."""
    c = srgb_byte(linear) / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def paint(obj, colour_of):
    """A float colour attribute on obj's face corners: colour_of(position in the world),
    each channel moved to the nearest 8-bit sRGB value. Blender's glTF importer keeps
    COLOR_0 as 8-bit sRGB: so it reads back the very colours raybundle reads."""
    mesh = obj.data
    attribute = mesh.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
    world = obj.matrix_world
    for loop in mesh.loops:
        colour = colour_of(world @ mesh.vertices[loop.vertex_index].co)
        attribute.data[loop.index].color = (*[on_byte(c) for c in colour], 1.0)
    mesh.color_attributes.active_color = attribute


def painted(name):
    """A material whose base colour is the mesh's colour attribute (the glTF exporter
    writes it as COLOR_0 and a base colour factor of 1)."""
    m = material(name)
    nodes = m.node_tree.nodes
    attribute = nodes.new("ShaderNodeVertexColor")
    attribute.layer_name = "Col"
    m.node_tree.links.new(attribute.outputs["Color"], nodes["Principled BSDF"].inputs["Base Color"])
    return m


def painted_room(examples):
    reset()
    plain = material("plain wall")
    floor = material("floor", (0.6, 0.6, 0.6))
    room = box("room", (-2.0, -2.0, 0.0), (2.0, 2.0, 2.5), plain, inward=True)
    room.data.materials.append(floor)
    for poly in room.data.polygons:  # the floor (its centre at z = 0 in the world)
        if (room.matrix_world @ poly.center).z < 1e-6:
            poly.material_index = 1

    block = box("painted box", (-0.9, -0.2, 0.0), (-0.1, 0.6, 0.8), painted("painted box"), size=0.8)
    block.rotation_euler = (0.0, 0.0, math.radians(25.0))
    bpy.context.view_layer.update()
    inverse = block.matrix_world.inverted()

    def corner_colour(p):
        local = inverse @ p
        return CORNERS[tuple(1 if c > 0 else -1 for c in local)]
    paint(block, corner_colour)

    bpy.ops.mesh.primitive_monkey_add(size=0.9, location=(0.8, 0.3, 0.0))
    monkey = bpy.context.active_object
    monkey.name = "monkey"
    modifier = monkey.modifiers.new("subdivision", "SUBSURF")
    modifier.levels = modifier.render_levels = 2
    bpy.ops.object.modifier_apply(modifier="subdivision")
    bpy.ops.object.shade_smooth()
    bpy.context.view_layer.update()
    lowest = min((monkey.matrix_world @ v.co).z for v in monkey.data.vertices)
    monkey.location.z -= lowest  # sitting on the floor
    bpy.context.view_layer.update()
    monkey.data.materials.append(painted("painted monkey"))

    def hue(p):
        angle = math.atan2(p.y - 0.3, p.x - 0.8)
        r, g, b = colorsys.hsv_to_rgb((angle / (2 * math.pi)) % 1.0, 0.75, 0.35 + 0.5 * min(1.0, p.z / 0.9))
        return (r, g, b)
    paint(monkey, hue)

    panel = material("panel", (0.8, 0.8, 0.8), emission=(1.0, 0.95, 0.85), strength=8.0)
    bpy.ops.mesh.primitive_plane_add(size=1.2, location=(0.0, 0.0, 2.45))
    light = bpy.context.active_object
    light.name = "ceiling panel"
    light.rotation_euler = (math.pi, 0.0, 0.0)  # facing down
    light.data.materials.append(panel)

    camera(Vector((0.0, -1.9, 1.3)), Vector((0.0, 0.5, 0.45)), 60.0)

    bpy.ops.export_scene.gltf(filepath=os.path.join(examples, "gltf", "painted-room.glb"), export_format="GLB",
                              export_cameras=True, export_lights=True, export_apply=True, export_yup=True,
                              export_texcoords=False, export_normals=True, export_colors=True)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 1:
        raise SystemExit("usage: blender -b --factory-startup --python make_painted_assets.py -- EXAMPLES_DIR")
    painted_room(os.path.abspath(argv[0]))


if __name__ == "__main__":
    try:
        main()
    except SystemExit:
        raise
    except Exception as e:  # one line, and a failing exit status (Blender would exit 0)
        print("make_painted_assets.py: error: %s" % e, file=sys.stderr, flush=True)
        sys.exit(1)
