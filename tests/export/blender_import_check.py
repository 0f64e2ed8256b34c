# Run by export_blender_test inside Blender (headless):
#   blender -b --factory-startup --python-exit-code 1 --python THIS -- MAP.glb \
#       "NAME|x,y,z|diameter,height|alpha" ...
# Imports the glTF and checks, per expected object: it exists, stands at its
# base point in Blender's Z-up frame, is upright (its height along +Z), and
# its material's Principled BSDF alpha is pi with alpha blending. Also checks
# that no other mesh object besides trajectories and the grid was imported.
import sys

import numpy

numpy.bool = bool  # Blender 3.4's glTF importer still uses numpy.bool (gone in numpy 1.24)

import bpy  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=args[0])
objects = {o.name: o for o in bpy.context.scene.objects if o.type == "MESH"}
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)


expected_names = set()
for spec in args[1:]:
    name, base, size, alpha = spec.split("|")
    expected_names.add(name)
    base = [float(v) for v in base.split(",")]
    diameter, height = [float(v) for v in size.split(",")]
    alpha = float(alpha)
    obj = objects.get(name)
    check(obj is not None, f"{name}: not imported")
    if obj is None:
        continue
    check(all(abs(a - b) < 1e-4 for a, b in zip(obj.location, base)),
          f"{name}: location {tuple(obj.location)} != base point {base}")
    dims = obj.dimensions
    check(abs(dims.z - height) < 1e-4 and abs(dims.x - diameter) < 1e-4
          and abs(dims.y - diameter) < 1e-4,
          f"{name}: dimensions {tuple(dims)} are not upright diameter {diameter}, height {height}")
    corners = [obj.matrix_world @ v.co for v in obj.data.vertices]
    check(abs(min(c.z for c in corners) - base[2]) < 1e-4, f"{name}: does not stand on its base")
    material = obj.data.materials[0]
    bsdf = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    check(abs(bsdf.inputs["Alpha"].default_value - alpha) < 1e-4,
          f"{name}: alpha {bsdf.inputs['Alpha'].default_value} != {alpha}")
    check(material.blend_method == "BLEND", f"{name}: blend method {material.blend_method}")
    check(abs(obj["existence_probability"] - alpha) < 1e-9, f"{name}: extras existence_probability {obj['existence_probability']} != {alpha}")

others = [n for n in objects if n not in expected_names
          and not n.startswith("trajectory ") and n != "floor grid"]
check(not others, f"unexpected objects: {others}")
print("blender import check:", "OK" if not failures else "FAILED")
for failure in failures:
    print("  " + failure)
sys.exit(1 if failures else 0)
