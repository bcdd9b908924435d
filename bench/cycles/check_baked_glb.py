"""Imports a baked asset (raybundle solve ... -o lit.glb) with Blender's glTF importer and
prints what Blender made of it: the mesh, its colour attribute and a few colours, the
material. Exits 1 when Blender imports no mesh with a colour attribute.

    blender -b --factory-startup --python-exit-code 1 --python bench/cycles/check_baked_glb.py -- lit.glb
"""

import sys

import bpy
import numpy

# Blender 3.4's glTF importer uses numpy.bool, an alias that Debian 12's numpy (1.24)
# no longer has: restored for it.
if "bool" not in numpy.__dict__:
    numpy.bool = bool


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 1:
        raise SystemExit("usage: blender -b --factory-startup --python check_baked_glb.py -- FILE.glb")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=argv[0])
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    coloured = [o for o in meshes if len(o.data.color_attributes) > 0]
    for o in coloured:
        c = o.data.color_attributes[0]
        step = max(1, len(c.data) // 4)
        sample = [tuple(round(x, 4) for x in c.data[i].color[:3]) for i in range(0, len(c.data), step)][:4]
        nodes = sorted({n.type for s in o.material_slots if s.material for n in s.material.node_tree.nodes})
        print("baked: %s, %d faces, colour attribute %s (%s, %s), e.g. %s; material nodes %s"
              % (o.name, len(o.data.polygons), c.name, c.domain, c.data_type, sample, ", ".join(nodes)))
    if not coloured:
        raise SystemExit("%s: Blender imported no mesh with vertex colours" % argv[0])


if __name__ == "__main__":
    main()
