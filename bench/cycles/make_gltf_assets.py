"""Makes the three glTF example assets of scenes/examples/gltf/ with Blender's own glTF
exporter, modelled as people model scenes in Blender (things standing on floors, a lamp
under the ceiling, a dense mesh), so that raybundle reads glTF as Blender writes it.

    blender -b --factory-startup --python bench/cycles/make_gltf_assets.py -- OUT_DIR

(Blender's glTF exporter needs python3-numpy, which Debian's blender does not pull in.)

  cornell-box.glb   McGuire's CornellBox-Original.obj + .mtl (scenes/examples/) through
                    Blender's OBJ importer: its light an emissive material (Ke 17 12 4:
                    emissiveFactor with KHR_materials_emissive_strength), and a camera.
  lamp-room.gltf    (+ lamp-room.bin) a room 4 x 3 x 2.6 m with a table and a stool on
                    its floor and a 60 W point lamp under the ceiling
                    (KHR_lights_punctual), and a camera; separate buffer file.
  suzanne.glb       Blender's monkey, subdivided twice (~16,000 triangles) and smoothed,
                    sitting on a floor before a back wall, lit by an emissive panel under
                    the ceiling, and a camera.

Every material is single-sided (backface culling on: doubleSided false) and has
metallic 0, so that the assets are diffuse with emitters, what bench/run_asset_bench.sh
compares with Cycles. The files are committed; this script is how they were made.
"""

import math
import os
import sys

import bpy
from mathutils import Vector


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def material(name, colour, emission=None, strength=0.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.use_backface_culling = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*colour, 1.0)
    p.inputs["Metallic"].default_value = 0.0
    p.inputs["Roughness"].default_value = 1.0
    if emission:
        p.inputs["Emission"].default_value = (*emission, 1.0)
        p.inputs["Emission Strength"].default_value = strength
    return m


def box(name, lo, hi, mat, inward=False):
    """An axis-aligned box (Blender's Z up) with outward faces, or inward for a room."""
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    o = bpy.context.active_object
    o.name = name
    o.scale = [h - l for l, h in zip(lo, hi)]
    o.location = [(l + h) / 2 for l, h in zip(lo, hi)]
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    if inward:
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.mesh.flip_normals()
        bpy.ops.object.mode_set(mode="OBJECT")
    o.data.materials.append(mat)
    return o


def camera(eye, target, fov_y_deg, aspect=1.0):
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(fov_y_deg)
    cam = bpy.data.objects.new("camera", data)
    bpy.context.scene.collection.objects.link(cam)
    cam.location = eye
    direction = Vector(target) - Vector(eye)
    cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.camera = cam
    bpy.context.scene.render.resolution_x = int(round(512 * aspect))
    bpy.context.scene.render.resolution_y = 512


def export(path, fmt):
    bpy.ops.export_scene.gltf(filepath=path, export_format=fmt, export_cameras=True, export_lights=True,
                              export_apply=True, export_yup=True, export_texcoords=False)


def cornell(out_dir, examples):
    reset()
    bpy.ops.wm.obj_import(filepath=os.path.join(examples, "CornellBox-Original.obj"))  # Y up -> Blender's Z up
    for m in bpy.data.materials:
        m.use_backface_culling = True
    # The view of the box through its open front (file coordinates: y up, front at +z).
    camera(Vector((0.0, -3.9, 1.0)), Vector((0.0, 0.0, 1.0)), 40.0)
    export(os.path.join(out_dir, "cornell-box.glb"), "GLB")


def lamp_room(out_dir):
    reset()
    wall = material("wall", (0.75, 0.72, 0.66))
    floor = material("floor", (0.45, 0.30, 0.18))
    wood = material("table", (0.55, 0.40, 0.25))
    seat = material("stool", (0.20, 0.35, 0.60))
    shade = material("lampshade", (0.85, 0.85, 0.80))
    room = box("room", (-2.0, -1.5, 0.0), (2.0, 1.5, 2.6), wall, inward=True)
    room.data.materials.append(floor)
    for poly in room.data.polygons:  # the floor, its own material (its centre at z = 0 in the world)
        if (room.matrix_world @ poly.center).z < 1e-6:
            poly.material_index = 1
    box("table top", (-0.6, -0.4, 0.72), (0.6, 0.4, 0.76), wood)
    for i, (x, y) in enumerate([(-0.55, -0.35), (0.55, -0.35), (-0.55, 0.35), (0.55, 0.35)]):
        box("table leg %d" % i, (x - 0.03, y - 0.03, 0.0), (x + 0.03, y + 0.03, 0.72), wood)
    box("stool", (0.9, -0.2, 0.0), (1.3, 0.2, 0.45), seat)
    box("lampshade", (-0.15, -0.15, 2.3), (0.15, 0.15, 2.5), shade)
    data = bpy.data.lights.new("lamp", "POINT")
    data.energy = 60.0
    data.shadow_soft_size = 0.0
    lamp = bpy.data.objects.new("lamp", data)
    lamp.location = (0.0, 0.0, 2.2)  # under the shade
    bpy.context.scene.collection.objects.link(lamp)
    camera(Vector((-1.8, -1.3, 1.6)), Vector((0.3, 0.3, 0.6)), 60.0, aspect=4 / 3)
    export(os.path.join(out_dir, "lamp-room.gltf"), "GLTF_SEPARATE")


def suzanne(out_dir):
    reset()
    wall = material("wall", (0.70, 0.70, 0.70))
    skin = material("monkey", (0.80, 0.45, 0.20))
    panel = material("panel", (0.80, 0.80, 0.80), emission=(1.0, 0.95, 0.85), strength=12.0)
    box("room", (-1.5, -1.5, 0.0), (1.5, 1.5, 2.4), wall, inward=True)
    bpy.ops.mesh.primitive_monkey_add(size=1.0, location=(0.0, 0.2, 0.5))
    monkey = bpy.context.active_object
    monkey.name = "suzanne"
    monkey.rotation_euler = (math.radians(-20), 0.0, 0.0)
    mod = monkey.modifiers.new("subdivision", "SUBSURF")
    mod.levels = mod.render_levels = 2
    bpy.ops.object.shade_smooth()
    monkey.data.materials.append(skin)
    # Sitting on the floor: its lowest point at z = 0 once subdivided.
    bpy.context.view_layer.update()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = monkey.evaluated_get(depsgraph)
    lowest = min((evaluated.matrix_world @ v.co).z for v in evaluated.to_mesh().vertices)
    evaluated.to_mesh_clear()
    monkey.location.z -= lowest
    bpy.ops.mesh.primitive_plane_add(size=0.8, location=(0.0, 0.0, 2.35))
    light = bpy.context.active_object
    light.name = "ceiling panel"
    light.rotation_euler = (math.pi, 0.0, 0.0)  # facing down
    light.data.materials.append(panel)
    camera(Vector((0.0, -1.45, 1.0)), Vector((0.0, 0.2, 0.55)), 55.0)
    export(os.path.join(out_dir, "suzanne.glb"), "GLB")


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 1:
        raise SystemExit("usage: blender -b --factory-startup --python make_gltf_assets.py -- OUT_DIR")
    out_dir = os.path.abspath(argv[0])
    os.makedirs(out_dir, exist_ok=True)
    examples = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scenes", "examples")
    cornell(out_dir, examples)
    lamp_room(out_dir)
    suzanne(out_dir)


if __name__ == "__main__":
    try:
        main()
    except SystemExit:
        raise
    except Exception as e:  # one line, and a failing exit status (Blender would exit 0)
        print("make_gltf_assets.py: error: %s" % e, file=sys.stderr, flush=True)
        sys.exit(1)
