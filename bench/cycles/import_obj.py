"""Renders an OBJ file (with its MTL) or a glTF file as Blender imports it, with Cycles
on the CPU.

    blender -b --factory-startup --python bench/cycles/import_obj.py -- \
        --obj MODEL.obj|.gltf|.glb --output OUT.exr --spp 1024 --eye X Y Z --target X Y Z \
        [--fov-y 40] [--size 256] [-t THREADS] [--seed S] [--timing TIMING.json]

Blender's own OBJ importer (bpy.ops.wm.obj_import, the file's axes kept: forward +Y,
up +Z) reads the geometry and the MTL, or its glTF importer (bpy.ops.import_scene.gltf,
whose turn of glTF's +Y up to Blender's +Z is undone, so that the camera is given in
the file's coordinates as for raybundle; the normals and smooth shading it imports
are kept, where an OBJ's faces are flat); raybundle's reading of the same files is
what the comparison checks (bench/run_asset_bench.sh, docs/bench-assets.md). Each imported
material keeps its colours as Blender read them: the Principled BSDF's base colour
becomes a Lambert Diffuse BSDF of that colour (Principled's diffuse is Disney's, with
retro-reflection, not the Lambert reflector an MTL's Kd means), its emission colour
times strength the emitted radiance, one-sided as raybundle's surfaces are
(bench/cycles/import_scene.py: make_material). A textured base colour stays textured:
where the Principled BSDF's Base Color is linked (an Image Texture, or a Mix node
multiplying the glTF baseColorFactor by it, as the glTF importer builds them; an Image
Texture for an MTL's map_Kd; a Color Attribute node for a glTF COLOR_0), those nodes are
copied into the Lambert material and give
its colour, through the same UV map, interpolation and extension (an 8-bit sRGB image
decoded to linear floats first, so that Cycles interpolates the texels as the glTF
specification and raybundle do: see decoded()). This bench compares diffuse assets:
a metallic material is refused, Principled's specular (from Ks) is printed and
dropped. The camera, the Cycles settings (64
bounces, no clamping, box filter, no denoising, Standard view) and the uniform scale
to a diagonal of 1 are import_scene.py's. Faces given twice are removed (see
remove_duplicate_faces: Cycles would darken them).
"""

import argparse
import json
import math
import os
import sys

import bpy
import numpy
from mathutils import Matrix, Vector

# Blender 3.4's glTF importer uses numpy.bool, an alias that Debian 12's numpy (1.24)
# no longer has: restored for it.
if "bool" not in numpy.__dict__:
    numpy.bool = bool

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import import_scene  # noqa: E402  (its functions; its main() does not run)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="import_obj.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--obj", required=True)
    p.add_argument("--output", required=True, help="EXR file to write")
    p.add_argument("--spp", type=int, required=True)
    p.add_argument("--eye", type=float, nargs=3, required=True)
    p.add_argument("--target", type=float, nargs=3, required=True)
    p.add_argument("--up", type=float, nargs=3, default=[0.0, 1.0, 0.0])
    p.add_argument("--fov-y", type=float, default=40.0)
    p.add_argument("--size", type=int, default=256, help="width and height in pixels")
    p.add_argument("-t", "--threads", type=int, default=2)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--timing")
    a = p.parse_args(argv)
    # What import_scene.build's settings read.
    a.half, a.bounces, a.keep_scale, a.no_light_sampling = False, import_scene.BOUNCES, False, False
    return a


# The nodes a textured base colour is made of, as Blender's importers build them, with
# the properties copied besides their inputs' values.
TEXTURE_NODES = {
    "TEX_IMAGE": ("image", "interpolation", "projection", "projection_blend", "extension"),
    "MIX_RGB": ("blend_type", "use_clamp"),
    "MIX": ("data_type", "blend_type", "clamp_factor", "clamp_result", "factor_mode"),
    "UVMAP": ("uv_map", "from_instancer"),
    "MAPPING": ("vector_type",),
    "TEX_COORD": ("from_instancer",),
    "SEPARATE_COLOR": ("mode",),
    "COMBINE_COLOR": ("mode",),
    "VERTEX_COLOR": ("layer_name",),
}


def upstream(socket, seen=None):
    """The nodes that feed an output socket, each once, the socket's own first."""
    seen = [] if seen is None else seen
    if socket.node not in seen:
        seen.append(socket.node)
        for inp in socket.node.inputs:
            for link in inp.links:
                upstream(link.from_socket, seen)
    return seen


DECODED = {}


def decoded(image):
    """The image Cycles is to read for an sRGB byte image: its texels decoded to linear
    values, as floats (the same image otherwise: float and non-colour images).

    Cycles keeps an 8-bit sRGB image as bytes and decodes after the bilinear
    interpolation (kernel/svm/image.h: the colour is interpolated, then
    NODE_IMAGE_COMPRESS_AS_SRGB turns it to linear). The glTF specification asks for the
    other order ("the transfer function SHOULD be decoded before performing linear
    interpolation"), and raybundle follows it. The two differ within a texel of every
    edge: on textured-room's 8 x 8 checker, Cycles' order darkens the texture's mean by
    0.8 % in red, 0.6 % in green, 0.3 % in blue. Given the texels as linear floats, Cycles
    interpolates them as raybundle does, and the bench compares the same scene.
    """
    if image.is_float or image.colorspace_settings.name != "sRGB":
        return image
    if image.name not in DECODED:
        w, h = image.size
        if w * h == 0:
            raise SystemExit("image %s: Blender could not read it" % image.name)
        texels = numpy.empty(w * h * 4, dtype=numpy.float32)
        image.pixels.foreach_get(texels)  # a byte image's values as stored (sRGB) / 255
        texels = texels.reshape(-1, 4)
        c = texels[:, :3].astype(numpy.float64)
        texels[:, :3] = numpy.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
        linear = bpy.data.images.new(image.name + " (linear)", w, h, alpha=True, float_buffer=True)
        linear.colorspace_settings.name = "Linear"
        linear.alpha_mode = image.alpha_mode
        linear.pixels.foreach_set(texels.ravel())
        linear.update()
        DECODED[image.name] = linear
    return DECODED[image.name]


def copy_upstream(socket, tree, copies):
    """Copies the nodes feeding `socket` (an output of another material's node) into tree;
    returns the copy's socket. copies: original node -> copy, shared between calls."""
    node = socket.node
    if node.type not in TEXTURE_NODES:
        raise SystemExit("material %s: its base colour comes through a %s node, which import_obj.py does not copy"
                         % (node.id_data.name, node.bl_idname))
    if node not in copies:
        new = tree.nodes.new(node.bl_idname)
        new.location = (node.location.x - 600, node.location.y)
        for prop in TEXTURE_NODES[node.type]:
            if hasattr(node, prop):
                setattr(new, prop, getattr(node, prop))
        if node.type == "TEX_IMAGE":
            new.image = decoded(node.image)
        for k, inp in enumerate(node.inputs):  # by index: a Mix node has several inputs of a name
            if hasattr(inp, "default_value"):
                new.inputs[k].default_value = inp.default_value
            for link in inp.links:
                tree.links.new(copy_upstream(link.from_socket, tree, copies), new.inputs[k])
        copies[node] = new
    return copies[node].outputs[list(node.outputs).index(socket)]


def describe_texture(socket):
    """What feeds a linked base colour, in words and as JSON-able data."""
    nodes = upstream(socket)
    images = [n for n in nodes if n.type == "TEX_IMAGE"]
    colours = [n for n in nodes if n.type == "VERTEX_COLOR"]
    if (not images and not colours) or any(n.image is None for n in images):
        raise SystemExit("material %s: its base colour is linked but comes from no image and no colour attribute"
                         % socket.id_data.name)
    info = {"image": [n.image.name for n in images], "vertex_colours": [n.layer_name or "(active)" for n in colours],
            "file": [bpy.path.abspath(n.image.filepath) if n.image.packed_file is None else "(packed)" for n in images],
            "size": [list(n.image.size) for n in images],
            "colorspace": [n.image.colorspace_settings.name for n in images],
            "interpolation": [n.interpolation for n in images], "extension": [n.extension for n in images],
            "nodes": [n.bl_idname + (" " + n.blend_type if hasattr(n, "blend_type") else "") for n in nodes]}
    for n in nodes:
        if n.type in ("MIX", "MIX_RGB"):  # the glTF factor: the Mix's constant colour input
            info["factor"] = [list(i.default_value) for i in n.inputs
                              if i.type == "RGBA" and not i.is_linked and i.enabled]
    return info


def diffuse_of(mat):
    """The raybundle material Blender's import of an MTL material means: albedo, emission
    (and a texture, where the base colour is linked: then the albedo printed is unused)."""
    principled = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if principled is None:
        raise SystemExit("material %s: no Principled BSDF after the import" % mat.name)
    if principled.inputs["Emission"].is_linked or principled.inputs["Emission Strength"].is_linked:
        raise SystemExit("material %s: an emission texture: not compared" % mat.name)
    base = list(principled.inputs["Base Color"].default_value)[:3]
    strength = principled.inputs["Emission Strength"].default_value
    emission = [strength * c for c in list(principled.inputs["Emission"].default_value)[:3]]
    if principled.inputs["Metallic"].default_value > 0.0:
        raise SystemExit("material %s: metallic: not a diffuse asset" % mat.name)
    m = {"name": mat.name, "albedo": base, "emission": emission, "two_sided": False,
         "blender_specular": principled.inputs["Specular"].default_value}
    links = principled.inputs["Base Color"].links
    if links:
        m["texture"] = describe_texture(links[0].from_socket)
    return m, (links[0].from_socket if links else None)


def keep_texture(mat, socket):
    """Links the copy of what gives `socket` (the imported material's base colour) to the
    front Lambert BSDF's Color of mat (import_scene.make_material's; its other Diffuse BSDF,
    the black back, feeds the second shader of the Backfacing mix)."""
    tree = mat.node_tree
    back = {link.from_node for link in tree.links
            if link.to_node.type == "MIX_SHADER" and link.to_socket == link.to_node.inputs[2]}
    front = [n for n in tree.nodes if n.type == "BSDF_DIFFUSE" and n not in back]
    if len(front) != 1:
        raise SystemExit("material %s: %d front Diffuse BSDFs" % (mat.name, len(front)))
    tree.links.new(copy_upstream(socket, tree, {}), front[0].inputs["Color"])


def remove_duplicate_faces(obj):
    """Removes every face whose vertices another face has (the count removed).

    Cycles skips only the triangle a ray leaves: the twin of a face given twice is hit
    at distance 0 by the rays leaving it, from behind, and darkens it (a dark band on the
    tall block of McGuire's box, whose 'bottom' faces repeat a side). raybundle keeps
    one of the two in front of the other, the surface as one face.
    """
    import bmesh
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    seen, twins = set(), []
    for f in bm.faces:
        key = frozenset(v.index for v in f.verts)
        if key in seen:
            twins.append(f)
        seen.add(key)
    bmesh.ops.delete(bm, geom=twins, context="FACES_ONLY")
    bm.to_mesh(obj.data)
    bm.free()
    return len(twins)


def main():
    args = parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    gltf = args.obj.lower().endswith((".gltf", ".glb"))
    if gltf:
        bpy.ops.import_scene.gltf(filepath=os.path.abspath(args.obj))
    else:
        bpy.ops.wm.obj_import(filepath=os.path.abspath(args.obj), forward_axis="Y", up_axis="Z")
    objects = [o for o in scene.objects if o.type == "MESH"]
    if not objects:
        raise SystemExit("%s: Blender imported no mesh" % args.obj)
    if gltf:
        # Back to the file's coordinates: the importer turned +Y up to +Z (x, -z, y).
        back = Matrix.Rotation(-math.pi / 2, 4, "X")
        for o in objects:
            world = o.matrix_world.copy()
            o.parent = None
            o.matrix_world = back @ world
        if any(o.type == "LIGHT" for o in scene.objects):
            raise SystemExit("%s: punctual lights: this bench compares emissive surfaces" % args.obj)
    duplicates = sum(remove_duplicate_faces(o) for o in objects)
    # The scale import_scene uses: the bounds with the eye to a diagonal of 1.
    pts = [o.matrix_world @ v.co for o in objects for v in o.data.vertices] + [Vector(args.eye)]
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(p[k] for p in pts) for k in range(3)]
    scale = 1.0 / math.dist(lo, hi)
    materials = {}
    for o in objects:
        o.matrix_world = Matrix.Scale(scale, 4) @ o.matrix_world
        if not gltf:
            o.data.polygons.foreach_set("use_smooth", [False] * len(o.data.polygons))
        for slot in o.material_slots:
            if slot.material and slot.material.name not in materials:
                m, texture = diffuse_of(slot.material)
                lambert = import_scene.make_material(m, True)
                if texture is not None:
                    keep_texture(lambert, texture)
                    t = m["texture"]
                    print("material %s: texture kept: image %s (%s, %s, %s, %s), vertex colours %s, through %s%s" % (
                        m["name"], ", ".join(t["image"]) or "none", " ".join("%dx%d" % tuple(z) for z in t["size"]),
                        ", ".join(t["colorspace"]), ", ".join(t["interpolation"]), ", ".join(t["extension"]),
                        ", ".join(t["vertex_colours"]) or "none", " <- ".join(t["nodes"]),
                        ", factor %s" % t["factor"] if "factor" in t else ""), flush=True)
                else:
                    print("material %s: no texture, albedo %s" % (m["name"], [round(c, 6) for c in m["albedo"]]),
                          flush=True)
                materials[slot.material.name] = (m, lambert)
            if slot.material:
                slot.material = materials[slot.material.name][1]
    camera = {"eye": [scale * x for x in args.eye], "target": [scale * x for x in args.target], "up": args.up,
              "fov_y": args.fov_y, "width": args.size, "height": args.size}
    import_scene.make_camera(scene, camera, scale * math.dist(lo, hi))
    scene.world = import_scene.make_world(None)
    import_scene.settings(scene, args, args.size, args.size)
    print("cycles: %s, %d objects, %d duplicate faces removed, materials %s, %dx%d, %d spp, %d threads, seed %d, "
          "scale %.6g" % (args.obj, len(objects), duplicates, json.dumps({k: v[0] for k, v in materials.items()}),
                          args.size, args.size, args.spp, args.threads, args.seed, scale), flush=True)
    import_scene.render_timed(scene, args)


if __name__ == "__main__":
    try:
        main()
    except SystemExit:
        raise
    except Exception as e:  # one line, and a failing exit status (Blender would exit 0)
        print("import_obj.py: error: %s" % e, file=sys.stderr, flush=True)
        sys.exit(1)
