"""Renders a scene exported by bench/export_scene with Blender Cycles on the CPU.

    blender -b --factory-startup --python bench/cycles/import_scene.py -- \
        --scene SCENE.json --output OUT.exr --spp 1024 [-t THREADS] [--seed S] \
        [--half] [--timing TIMING.json]

(and, to check the conversion: --bounces N, --keep-scale, --no-light-sampling). The
scene is built to mean what raybundle means by it (docs/benchmarks.md, "Against
Blender Cycles"):

- materials: a Diffuse BSDF (Lambert) with the albedo, plus an Emission shader of
  strength 1 whose colour is the emitted radiance; raybundle's surfaces are one-sided,
  so unless the material is two-sided, Geometry.Backfacing mixes the back side to a
  black BSDF: it absorbs everything and emits nothing. Emissive materials are sampled
  as lights.
- the world: the sky (constant radiance above the horizon, or the CIE overcast
  L = radiance (1 + 2 cos theta) / 3, black below the horizon), or black.
- directional lights: a sun of angle 0 (a parallel light) along the same direction,
  of strength the largest channel of the irradiance and colour the irradiance over it
  (Cycles' sun strength is the irradiance in W/m^2 of a surface facing it).
- the camera: raybundle's pinhole (eye, target, up, vertical field of view, sensor fit
  VERTICAL, the same resolution; rows top to bottom as raybundle writes them).
- the scale: scene and camera scaled uniformly to a bounding diagonal of 1, which
  changes no radiance but keeps Blender 3.4 off its imprecise spherical-triangle
  sampling of small emissive triangles (see build()).
- Cycles: CPU, 64 bounces of every kind, no clamping, no light threshold, box pixel
  filter (always one pixel wide in Cycles), no denoising, no adaptive sampling, a fixed seed, exposure 0,
  view transform Standard. The output is linear RGB float EXR (32-bit, or 16-bit
  half with --half, ZIP compressed).

The render call alone (bpy.ops.render.render: scene sync, BVH build and sampling) is
timed with time.perf_counter; the seconds are printed as `cycles_render_seconds S` and,
with --timing, written to a JSON file.
"""

import argparse
import json
import math
import sys
import time

import bpy
from mathutils import Matrix, Vector

BOUNCES = 64


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="import_scene.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", required=True, help="JSON written by bench/export_scene")
    p.add_argument("--output", required=True, help="EXR file to write")
    p.add_argument("--spp", type=int, required=True, help="samples per pixel")
    p.add_argument("-t", "--threads", type=int, default=2, help="render threads (default 2)")
    p.add_argument("--seed", type=int, default=1, help="Cycles seed (default 1)")
    p.add_argument("--half", action="store_true", help="16-bit half float EXR instead of 32-bit float")
    p.add_argument("--timing", help="also write the timing as JSON to this file")
    # Checks of the conversion (docs/benchmarks.md), not for the benchmark:
    p.add_argument("--bounces", type=int, default=BOUNCES,
                   help="bounces of every kind (default %d; 0: direct light only)" % BOUNCES)
    p.add_argument("--keep-scale", action="store_true",
                   help="keep the scene's units (default: scale it uniformly to a diagonal of 1, see below)")
    p.add_argument("--no-light-sampling", action="store_true",
                   help="emissive meshes are not sampled as lights (BSDF sampling only: unbiased, noisy)")
    return p.parse_args(argv)


def node(nodes, kind, location, **inputs):
    n = nodes.new(kind)
    n.location = location
    for name, value in inputs.items():
        n.inputs[name].default_value = value
    return n


def make_material(m, sample_lights):
    """A raybundle material: Lambert albedo + emitted radiance, one-sided unless two_sided."""
    mat = bpy.data.materials.new(m["name"])
    mat.use_nodes = True
    nt = mat.node_tree
    nodes, links = nt.nodes, nt.links
    nodes.clear()
    out = node(nodes, "ShaderNodeOutputMaterial", (800, 0))
    albedo = list(m["albedo"]) + [1.0]
    emission = list(m["emission"]) + [1.0]
    front = node(nodes, "ShaderNodeBsdfDiffuse", (0, 100), Color=albedo, Roughness=0.0).outputs["BSDF"]
    emissive = any(c > 0.0 for c in m["emission"])
    if emissive:
        # Strength 1: the emitted radiance is the colour itself.
        glow = node(nodes, "ShaderNodeEmission", (0, -100), Color=emission, Strength=1.0)
        add = node(nodes, "ShaderNodeAddShader", (250, 0))
        links.new(front, add.inputs[0])
        links.new(glow.outputs["Emission"], add.inputs[1])
        front = add.outputs["Shader"]
    if not m["two_sided"]:
        # The back of a one-sided patch: black, absorbing, emitting nothing.
        geometry = node(nodes, "ShaderNodeNewGeometry", (250, 300))
        black = node(nodes, "ShaderNodeBsdfDiffuse", (250, -250), Color=(0.0, 0.0, 0.0, 1.0), Roughness=0.0)
        mix = node(nodes, "ShaderNodeMixShader", (550, 0))
        links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
        links.new(front, mix.inputs[1])  # Fac 0: the front side
        links.new(black.outputs["BSDF"], mix.inputs[2])  # Fac 1: the back side
        front = mix.outputs["Shader"]
    links.new(front, out.inputs["Surface"])
    mat.cycles.sample_as_light = emissive and sample_lights
    return mat


def make_world(sky):
    world = bpy.data.worlds.new("sky" if sky else "black")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes.clear()
    out = node(nodes, "ShaderNodeOutputWorld", (1000, 0))
    if sky is None:
        bg = node(nodes, "ShaderNodeBackground", (700, 0), Color=(0.0, 0.0, 0.0, 1.0), Strength=0.0)
        links.new(bg.outputs["Background"], out.inputs["Surface"])
        world.cycles.sampling_method = "NONE"
        return world
    # cos theta = up . d, with d the direction of the background ray (towards the sky).
    coords = node(nodes, "ShaderNodeTexCoord", (0, 0))
    unit = node(nodes, "ShaderNodeVectorMath", (200, 0))
    unit.operation = "NORMALIZE"
    links.new(coords.outputs["Generated"], unit.inputs[0])
    dot = node(nodes, "ShaderNodeVectorMath", (400, 0))
    dot.operation = "DOT_PRODUCT"
    links.new(unit.outputs["Vector"], dot.inputs[0])
    dot.inputs[1].default_value = sky["up"]
    above = node(nodes, "ShaderNodeMath", (600, 100))  # 1 above the horizon, 0 below
    above.operation = "GREATER_THAN"
    links.new(dot.outputs["Value"], above.inputs[0])
    above.inputs[1].default_value = 0.0
    factor = above.outputs["Value"]
    if sky["model"] == "overcast":
        shape = node(nodes, "ShaderNodeMath", (600, -100))  # (1 + 2 cos theta) / 3
        shape.operation = "MULTIPLY_ADD"
        links.new(dot.outputs["Value"], shape.inputs[0])
        shape.inputs[1].default_value = 2.0 / 3.0
        shape.inputs[2].default_value = 1.0 / 3.0
        both = node(nodes, "ShaderNodeMath", (800, 0))
        both.operation = "MULTIPLY"
        links.new(above.outputs["Value"], both.inputs[0])
        links.new(shape.outputs["Value"], both.inputs[1])
        factor = both.outputs["Value"]
    elif sky["model"] != "constant":
        raise SystemExit("unknown sky model " + sky["model"])
    bg = node(nodes, "ShaderNodeBackground", (800, 200), Color=list(sky["radiance"]) + [1.0])
    links.new(factor, bg.inputs["Strength"])
    links.new(bg.outputs["Background"], out.inputs["Surface"])
    world.cycles.sampling_method = "AUTOMATIC"  # importance-sampled as a light
    return world


def make_sun(scene, k, light):
    """A directional light: a sun of angle 0, its -z along the light's direction of travel."""
    strength = max(light["irradiance"])
    sun = bpy.data.lights.new("sun %d" % k, type="SUN")
    sun.angle = 0.0
    sun.energy = strength
    sun.color = [c / strength for c in light["irradiance"]] if strength > 0.0 else [0.0, 0.0, 0.0]
    obj = bpy.data.objects.new("sun %d" % k, sun)
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = Vector(light["direction"]).to_track_quat("-Z", "Y")
    scene.collection.objects.link(obj)


def make_camera(scene, cam, extent):
    eye, target, up = Vector(cam["eye"]), Vector(cam["target"]), Vector(cam["up"])
    # raybundle's frame (render/camera.cpp): right = forward x up, up' = right x forward.
    forward = (target - eye).normalized()
    right = forward.cross(up).normalized()
    true_up = right.cross(forward)
    data = bpy.data.cameras.new("camera")
    data.type = "PERSP"
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(cam["fov_y"])
    data.shift_x = data.shift_y = 0.0
    data.clip_start = 1e-6 * extent
    data.clip_end = 100.0 * extent
    obj = bpy.data.objects.new("camera", data)
    # Blender's camera looks down its local -Z with +Y up and +X right.
    obj.matrix_world = Matrix((
        (right.x, true_up.x, -forward.x, eye.x),
        (right.y, true_up.y, -forward.y, eye.y),
        (right.z, true_up.z, -forward.z, eye.z),
        (0.0, 0.0, 0.0, 1.0),
    ))
    scene.collection.objects.link(obj)
    scene.camera = obj
    return data


def settings(scene, args, width, height):
    """The render and Cycles settings of every benchmark image (import_obj.py's too)."""
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x = width
    r.resolution_y = height
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.use_border = False
    r.film_transparent = False
    r.use_compositing = False
    r.use_sequencer = False
    r.use_persistent_data = False
    r.threads_mode = "FIXED"
    r.threads = args.threads
    r.use_motion_blur = False
    s = r.image_settings
    s.file_format = "OPEN_EXR"
    s.color_mode = "RGB"
    s.color_depth = "16" if args.half else "32"
    s.exr_codec = "ZIP"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.display_settings.display_device = "sRGB"

    c = scene.cycles
    c.device = "CPU"
    c.samples = args.spp
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = args.seed
    c.use_animated_seed = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.max_bounces = args.bounces
    c.diffuse_bounces = args.bounces
    c.glossy_bounces = args.bounces
    c.transmission_bounces = args.bounces
    c.transparent_max_bounces = args.bounces
    c.volume_bounces = args.bounces
    c.min_light_bounces = 0
    c.min_transparent_bounces = 0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.blur_glossy = 0.0
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0  # Cycles' box filter is one pixel wide whatever this says
    c.time_limit = 0.0
    c.film_exposure = 1.0  # Cycles' film exposure is a factor: 1 = 0 stops
    c.use_auto_tile = False
    for layer in scene.view_layers:
        layer.cycles.use_denoising = False


def build(doc, args):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    # A uniform scale changes no radiance: emission is a radiance, the camera moves with
    # the scene. It matters to Blender 3.4, whose choice between area and solid-angle
    # (spherical triangle) sampling of an emissive triangle compares the edge length with
    # distance / |e0 x e1|, a test that depends on the units: in millimetres it picks
    # the spherical triangle for nearly every triangle, whose solid angle (a spherical
    # excess from approximate arc cosines) loses precision for small, distant triangles
    # and darkens the direct light (docs/benchmarks.md: 5 % on the Cornell box's back
    # wall). Scaled to a diagonal of 1 it picks area sampling, which is exact.
    eye = doc["camera"]["eye"]
    pts = doc["positions"] + [eye]
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(p[k] for p in pts) for k in range(3)]
    scale = 1.0 if args.keep_scale else 1.0 / math.dist(lo, hi)
    positions = [tuple(scale * x for x in p) for p in doc["positions"]]
    mesh = bpy.data.meshes.new("patches")
    mesh.from_pydata(positions, [], [tuple(t) for t in doc["triangles"]])
    for m in doc["materials"]:
        mesh.materials.append(make_material(m, not args.no_light_sampling))
    mesh.polygons.foreach_set("material_index", doc["triangle_materials"])
    mesh.polygons.foreach_set("use_smooth", [False] * len(mesh.polygons))  # flat: geometric normals
    mesh.update()
    if len(mesh.polygons) != len(doc["triangles"]):
        raise SystemExit("Blender made %d faces of %d triangles" % (len(mesh.polygons), len(doc["triangles"])))
    scene.collection.objects.link(bpy.data.objects.new("patches", mesh))

    camera = dict(doc["camera"])
    camera["eye"] = [scale * x for x in camera["eye"]]
    camera["target"] = [scale * x for x in camera["target"]]
    cam = make_camera(scene, camera, scale * math.dist(lo, hi))
    scene.world = make_world(doc.get("sky"))
    for k, light in enumerate(doc.get("directional_lights", [])):
        make_sun(scene, k, light)

    settings(scene, args, doc["camera"]["width"], doc["camera"]["height"])
    return scene, cam, scale


def render_timed(scene, args):
    """Renders, saves args.output and prints (and with args.timing writes) the render's seconds."""
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    seconds = time.perf_counter() - t0
    bpy.data.images["Render Result"].save_render(filepath=args.output, scene=scene)
    print("cycles_render_seconds %.6f" % seconds, flush=True)
    if args.timing:
        with open(args.timing, "w") as f:
            json.dump({"seconds_render": seconds, "spp": args.spp, "threads": args.threads, "seed": args.seed,
                       "blender": bpy.app.version_string, "output": args.output}, f)
            f.write("\n")


def main():
    args = parse_args()
    with open(args.scene) as f:
        doc = json.load(f)
    scene, cam, scale = build(doc, args)
    print("cycles: %s, %d triangles, %dx%d, fov_y %.6g (Blender: %.6g), %d spp, %d threads, seed %d, scale %.6g" % (
        doc.get("scene", args.scene), len(doc["triangles"]), scene.render.resolution_x, scene.render.resolution_y,
        doc["camera"]["fov_y"], math.degrees(cam.angle_y), args.spp, args.threads, args.seed, scale), flush=True)
    render_timed(scene, args)


if __name__ == "__main__":
    try:
        main()
    except SystemExit:
        raise
    except Exception as e:  # one line, and a failing exit status (Blender would exit 0)
        print("import_scene.py: error: %s" % e, file=sys.stderr, flush=True)
        sys.exit(1)
