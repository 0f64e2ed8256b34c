# Run by export_blender_test inside Blender (headless):
#   blender -b --factory-startup --python-exit-code 1 --python THIS -- MAP.glb [--render OUT.png] \
#       "NAME|x,y,z|diameter,height|alpha|shape" ...
# Imports the glTF and checks what a user will see, per expected object: it
# exists, stands at its base point in Blender's Z-up frame, is as tall as its
# height and no wider than its diameter (round shapes exactly as wide), has
# faces, and its material blends with alpha = pi and culls back faces. Each
# trajectory is a mesh with faces (not loose edges, which never render) in a
# material of its own name and colour; the floor has faces; nothing else was
# imported. With --render, renders the scene with Workbench (the solid
# viewport's engine) from a fixed view fitted to the scene into OUT.png.
import math
import sys

import numpy

numpy.bool = bool  # Blender 3.4's glTF importer still uses numpy.bool (gone in numpy 1.24)

import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
render_path = None
if "--render" in args:
    i = args.index("--render")
    render_path = args[i + 1]
    del args[i:i + 2]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=args[0])
objects = {o.name: o for o in bpy.context.scene.objects if o.type == "MESH"}
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)


expected_names = set()
for spec in args[1:]:
    name, base, size, alpha, shape = spec.split("|")
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
    check(abs(dims.z - height) < 1e-4, f"{name}: height {dims.z} != {height}")
    check(max(dims.x, dims.y) <= diameter + 1e-4, f"{name}: wider than {diameter}: {tuple(dims)}")
    if shape in ("cylinder", "sphere"):
        check(abs(dims.x - diameter) < 1e-4 and abs(dims.y - diameter) < 1e-4,
              f"{name}: a {shape} {tuple(dims)} not {diameter} across")
    check(len(obj.data.polygons) > 0, f"{name}: no faces")
    corners = [obj.matrix_world @ v.co for v in obj.data.vertices]
    check(abs(min(c.z for c in corners) - base[2]) < 1e-4, f"{name}: does not stand on its base")
    material = obj.data.materials[0]
    bsdf = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    check(abs(bsdf.inputs["Alpha"].default_value - alpha) < 1e-4,
          f"{name}: alpha {bsdf.inputs['Alpha'].default_value} != {alpha}")
    check(material.blend_method == "BLEND", f"{name}: blend method {material.blend_method}")
    check(material.use_backface_culling, f"{name}: back faces not culled")
    check(abs(obj["existence_probability"] - alpha) < 1e-9,
          f"{name}: extras existence_probability {obj['existence_probability']} != {alpha}")
    check(obj["shape"] == shape, f"{name}: extras shape {obj['shape']} != {shape}")

trajectory_colours = {}
for name, obj in objects.items():
    if not name.startswith("trajectory "):
        continue
    mesh = obj.data
    check(len(mesh.polygons) > 0, f"{name}: no faces (would not render)")
    loose = [e for e in mesh.edges if e.is_loose]
    check(not loose, f"{name}: {len(loose)} loose edges")
    check(mesh.materials[0].name == name, f"{name}: material {mesh.materials[0].name}")
    trajectory_colours[name] = tuple(round(c, 3) for c in mesh.materials[0].diffuse_color)
check(len(set(trajectory_colours.values())) == len(trajectory_colours),
      f"trajectories share viewport colours: {trajectory_colours}")
check("floor" in objects and len(objects["floor"].data.polygons) > 0, "no floor with faces")

others = [n for n in objects if n not in expected_names and not n.startswith("trajectory ")
          and n not in ("floor", "floor grid", "cameras")]
check(not others, f"unexpected objects: {others}")

if render_path:
    scene = bpy.context.scene
    low = Vector((1e9, 1e9, 1e9))
    high = -low
    for obj in objects.values():
        for corner in obj.bound_box:
            world = obj.matrix_world @ Vector(corner)
            low = Vector(map(min, low, world))
            high = Vector(map(max, high, world))
    target = (low + high) / 2
    fov = math.radians(40)  # horizontal; the render is 4:3
    azimuth, elevation = -2.2, 0.6  # as perspective.png
    direction = Vector((math.cos(elevation) * math.cos(azimuth),
                        math.cos(elevation) * math.sin(azimuth), math.sin(elevation)))
    forward = -direction
    right = forward.cross(Vector((0, 0, 1))).normalized()
    up = right.cross(forward)
    corners = [Vector((x, y, z)) for x in (low.x, high.x) for y in (low.y, high.y)
               for z in (low.z, high.z)]

    def fits(distance):
        eye = target + direction * distance
        for corner in corners:
            d = corner - eye
            depth = d.dot(forward)
            if depth <= 0 or abs(d.dot(right)) / depth > math.tan(fov / 2) * 0.95 \
                    or abs(d.dot(up)) / depth > math.tan(fov / 2) * 0.75 * 0.95:
                return False
        return True

    near, far = 0.01, 1000.0  # the closest distance at which the whole scene is in view
    for _ in range(60):
        middle = (near + far) / 2
        near, far = (near, middle) if fits(middle) else (middle, far)
    camera_data = bpy.data.cameras.new("view")
    camera_data.angle = fov
    camera = bpy.data.objects.new("view", camera_data)
    scene.collection.objects.link(camera)
    camera.location = target + direction * far
    camera.rotation_euler = forward.to_track_quat("-Z", "Y").to_euler()
    scene.camera = camera
    world = bpy.data.worlds.new("background")
    world.color = (1.0, 1.0, 1.0)
    scene.world = world
    scene.render.engine = "BLENDER_WORKBENCH"
    shading = scene.display.shading
    shading.light = "STUDIO"
    shading.color_type = "MATERIAL"
    shading.show_backface_culling = True
    scene.display.render_aa = "8"
    scene.view_settings.view_transform = "Standard"
    scene.render.resolution_x, scene.render.resolution_y = 800, 600
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = render_path
    bpy.ops.render.render(write_still=True)

print("blender import check:", "OK" if not failures else "FAILED")
for failure in failures:
    print("  " + failure)
sys.exit(1 if failures else 0)
