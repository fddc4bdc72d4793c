"""Render a vkrad .glb in Blender, as a user who opens it there would see it.

    blender -b --factory-startup --python tools/lightmap/blender_render.py -- JOB.json

JOB.json: {"glb", "out", "width", "height", "eye", "look_at", "up", "fov"
(vertical, degrees), "samples", "normal" (optional: a second PNG of the
shading normals)} in vkrad's (glTF's) Y-up frame. Blender's own
glTF importer reads the file; Cycles draws it on the CPU with a one-pixel box
filter (vkrad's antialiasing), the Standard view transform (no filmic curve:
an unlit texel shows as its own value) and a transparent film, so the PNG's
alpha is each pixel's coverage. One line of JSON on stdout says what the
importer made of the file.
"""

import json
import sys

import bpy
import numpy
from mathutils import Matrix, Vector

# Debian bookworm's Blender 3.4.1 importer still calls numpy.bool, which
# NumPy 1.24 (the same distribution's) removed; it meant the builtin.
if "bool" not in numpy.__dict__:
    numpy.bool = bool


def to_blender(v):
    """glTF's Y-up to Blender's Z-up, as the importer converts the model."""
    x, y, z = v
    return Vector((x, -z, y))


def main():
    job = json.load(open(sys.argv[sys.argv.index("--") + 1]))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=job["glb"])

    scene = bpy.context.scene
    eye, look, up = (to_blender(job[k]) for k in ("eye", "look_at", "up"))
    forward = (look - eye).normalized()
    right = forward.cross(up).normalized()
    true_up = right.cross(forward)
    # A Blender camera looks down its -Z with +Y up.
    rot = Matrix((right, true_up, -forward)).transposed()
    cam_data = bpy.data.cameras.new("vkrad")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = job["fov"] * 3.141592653589793 / 180.0
    cam_data.clip_start = 1e-3
    cam_data.clip_end = 1e5
    cam = bpy.data.objects.new("vkrad", cam_data)
    cam.matrix_world = Matrix.Translation(eye) @ rot.to_4x4()
    scene.collection.objects.link(cam)
    scene.camera = cam

    world = bpy.data.worlds.new("black")
    world.color = (0.0, 0.0, 0.0)
    scene.world = world

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = job.get("samples", 64)
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 1.0
    scene.cycles.max_bounces = 0
    scene.render.film_transparent = True
    scene.render.dither_intensity = 0.0  # no noise added to the 8-bit PNG
    scene.render.resolution_x = job["width"]
    scene.render.resolution_y = job["height"]
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.display_settings.display_device = "sRGB"
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.image_settings.color_depth = "8"
    scene.render.filepath = job["out"]
    bpy.ops.render.render(write_still=True)
    if job.get("normal"):
        # Again with every surface showing its shading normal, for the
        # bench's mask of pixels with no crease, edge or seam nearby.
        mat = bpy.data.materials.new("normal")
        mat.use_nodes = True
        nodes, links = mat.node_tree.nodes, mat.node_tree.links
        nodes.clear()
        geometry = nodes.new("ShaderNodeNewGeometry")
        half = nodes.new("ShaderNodeVectorMath")
        half.operation = "MULTIPLY_ADD"
        half.inputs[1].default_value = (0.5, 0.5, 0.5)
        half.inputs[2].default_value = (0.5, 0.5, 0.5)
        emission = nodes.new("ShaderNodeEmission")
        output = nodes.new("ShaderNodeOutputMaterial")
        links.new(geometry.outputs["Normal"], half.inputs[0])
        links.new(half.outputs["Vector"], emission.inputs["Color"])
        links.new(emission.outputs["Emission"], output.inputs["Surface"])
        bpy.context.view_layer.material_override = mat
        scene.render.filepath = job["normal"]
        bpy.ops.render.render(write_still=True)
        bpy.context.view_layer.material_override = None

    meshes = [o for o in scene.objects if o.type == "MESH"]
    materials = []
    for m in (m for m in bpy.data.materials if m.name != "normal"):
        nodes = [n.bl_idname for n in m.node_tree.nodes] if m.use_nodes else []
        uv_maps = [n.uv_map for n in m.node_tree.nodes if n.bl_idname == "ShaderNodeUVMap"] if m.use_nodes else []
        images = [n.image.name for n in m.node_tree.nodes
                  if n.bl_idname == "ShaderNodeTexImage" and n.image] if m.use_nodes else []
        materials.append({"name": m.name, "emission": "ShaderNodeEmission" in nodes, "uv_maps": uv_maps,
                          "images": images})
    print(json.dumps({
        "blender": bpy.app.version_string,
        "meshes": len(meshes),
        "triangles": sum(len(o.data.polygons) for o in meshes),
        "uv_layers": sorted({uv.name for o in meshes for uv in o.data.uv_layers}),
        "color_attributes": sorted({a.name for o in meshes for a in o.data.attributes
                                    if a.domain in ("POINT", "CORNER") and a.data_type in ("FLOAT_COLOR",
                                                                                           "BYTE_COLOR")}),
        "materials": materials,
        "images": [{"name": i.name, "size": list(i.size)} for i in bpy.data.images if i.size[0] > 0],
    }), flush=True)


main()
