"""Builds a Blender scene from a frame folder of `volcano export` (docs/EXPORT.md) and
optionally renders it with Cycles:

    blender -b --factory-startup -P tools/blender_load.py -- DIR [--frame N]
        [--render OUT.png] [--width 960] [--height 540] [--samples 32] [--only-ash]
        [--glow X] [--save SCENE.blend]

It loads DIR/frame_NNNN.vdb (grids `ash`, `temperature`, `cloud`, `ash_fall`) as volume
objects with a Principled Volume each, DIR/terrain.glb and DIR/frame_NNNN.glb (lava, fold
ropes) with Blender's glTF importer, and the camera and sun of DIR/frame_NNNN.json.

Axes: the export is Bevy's world frame (metres, y up, the camera looking along its -z). The
volumes are turned +90 degrees about x (Bevy (x, y, z) is Blender (x, -z, y)); the glTF
importer does the same for the meshes; camera and sun are converted here.

Densities (Blender reads a volume's density as extinction per metre, one unit being a metre):
- ash and ash_fall: kg/m^3 times the mass extinction coefficient of fine ash,
  ASH_EXTINCTION m^2/kg (the engine's ash light uses the same, `AshLightSettings`);
- cloud: g/m^3 times CLOUD_EXTINCTION per metre per g/m^3 (the engine's cloud pass,
  `CloudRenderSettings::extinction_per_gram`; about 3 / (2 rho_w r_eff));
- temperature is the `ash` volume's temperature attribute; its blackbody emission is off
  unless `--glow X` sets the Principled Volume's blackbody intensity (Blender's blackbody
  turns all of sigma T^4, the infrared included, into light: at intensity 1 the column's
  500-1,000 K gas outshines the sun a hundredfold, so a day render keeps it off and a night
  render takes a small value, e.g. 1e-5);
- the lava's `_TEMPERATURE` vertex attribute drives its emission (a blackbody colour, strength
  20 (T / 1,400 K)^4: fresh lava glows, frozen lava does not).

`--only-ash` renders the column's `ash` alone over a transparent film: the silhouette
`tools/silhouette_iou.py` compares with the engine's frame.
"""

import argparse
import json
import math
import os
import struct
import sys

import bpy
import numpy
from mathutils import Quaternion, Vector, kdtree

# Blender 3.4's glTF importer still says `numpy.bool`, an alias NumPy 1.24 removed (Debian 12
# ships both); the builtin is what it meant.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

ASH_EXTINCTION = 0.003  # m^2/kg
CLOUD_EXTINCTION = 0.05  # 1/m per g/m^3


def bevy_to_blender(v):
    """A Bevy (y-up) vector in Blender's z-up frame."""
    return Vector((v[0], -v[2], v[1]))


Y_UP_TO_Z_UP = Quaternion((1.0, 0.0, 0.0), math.radians(90.0))


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="blender_load.py")
    p.add_argument("dir")
    p.add_argument("--frame", type=int, default=0)
    p.add_argument("--render")
    p.add_argument("--width", type=int, default=960)
    p.add_argument("--height", type=int, default=540)
    p.add_argument("--samples", type=int, default=32)
    p.add_argument("--only-ash", action="store_true")
    p.add_argument("--glow", type=float, default=0.0)
    p.add_argument("--save")
    return p.parse_args(argv)


def clear_scene():
    bpy.ops.object.select_all(action="SELECT")
    bpy.ops.object.delete()


def volume_material(name, grid, extinction, colour, temperature=None, glow=0.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    vol = nodes.new("ShaderNodeVolumePrincipled")
    vol.inputs["Color"].default_value = colour
    vol.inputs["Density"].default_value = extinction
    vol.inputs["Density Attribute"].default_value = grid
    if temperature:
        vol.inputs["Temperature Attribute"].default_value = temperature
        vol.inputs["Blackbody Intensity"].default_value = glow
    links.new(vol.outputs["Volume"], out.inputs["Volume"])
    return mat


def load_volumes(vdb, only_ash, glow):
    """One volume object per grid: ash (with temperature), ash fall, clouds."""
    specs = [("ash", ASH_EXTINCTION, (0.40, 0.37, 0.33, 1.0), "temperature")]
    if not only_ash:
        specs.append(("ash_fall", ASH_EXTINCTION, (0.30, 0.28, 0.26, 1.0), None))
        specs.append(("cloud", CLOUD_EXTINCTION, (0.95, 0.95, 0.97, 1.0), None))
    objects = []
    for grid, extinction, colour, temperature in specs:
        bpy.ops.object.volume_import(filepath=vdb, align="WORLD", location=(0, 0, 0))
        obj = bpy.context.active_object
        obj.name = f"volcano_{grid}"
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = Y_UP_TO_Z_UP
        mat = volume_material(f"{grid}_volume", grid, extinction, colour, temperature, glow)
        obj.data.materials.append(mat)
        objects.append(obj)
    return objects


def lava_emission(obj):
    """The lava's glow: a blackbody at the vertex temperature `_TEMPERATURE`, its strength
    the Stefan-Boltzmann law relative to 1,400 K (incandescent lava)."""
    for slot in obj.material_slots:
        mat = slot.material
        if not mat or not mat.use_nodes:
            continue
        nodes, links = mat.node_tree.nodes, mat.node_tree.links
        bsdf = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is None:
            continue
        attr = nodes.new("ShaderNodeAttribute")
        attr.attribute_name = "_TEMPERATURE"
        body = nodes.new("ShaderNodeBlackbody")
        links.new(attr.outputs["Fac"], body.inputs["Temperature"])
        links.new(body.outputs["Color"], bsdf.inputs["Emission"])
        # (T / 1400)^4 * 20: fresh lava glows, lava at the air's temperature does not.
        ratio = nodes.new("ShaderNodeMath")
        ratio.operation = "DIVIDE"
        ratio.inputs[1].default_value = 1400.0
        links.new(attr.outputs["Fac"], ratio.inputs[0])
        power = nodes.new("ShaderNodeMath")
        power.operation = "POWER"
        power.inputs[1].default_value = 4.0
        links.new(ratio.outputs["Value"], power.inputs[0])
        scale = nodes.new("ShaderNodeMath")
        scale.operation = "MULTIPLY"
        scale.inputs[1].default_value = 20.0
        links.new(power.outputs["Value"], scale.inputs[0])
        links.new(scale.outputs["Value"], bsdf.inputs["Emission Strength"])


def glb_attribute(path, mesh_name, attribute):
    """`(positions, values)` of a float vertex attribute of a mesh in a .glb, read from the
    file itself: Blender 3.4's glTF importer drops custom attributes such as `_TEMPERATURE`."""
    with open(path, "rb") as f:
        data = f.read()
    json_len = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + json_len])
    bin_at = 20 + json_len + 8

    def accessor(i, width):
        acc = doc["accessors"][i]
        view = doc["bufferViews"][acc["bufferView"]]
        start = bin_at + view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        flat = struct.unpack_from(f"<{acc['count'] * width}f", data, start)
        return [flat[k * width:(k + 1) * width] for k in range(acc["count"])]

    for mesh in doc.get("meshes", []):
        if mesh.get("name") != mesh_name:
            continue
        attrs = mesh["primitives"][0]["attributes"]
        if attribute not in attrs:
            return None
        return accessor(attrs["POSITION"], 3), [v[0] for v in accessor(attrs[attribute], 1)]
    return None


def copy_attribute(obj, path, attribute):
    """Gives the imported mesh `attribute` as a point attribute, each vertex taking the value
    of the file's vertex at its position (the importer drops unused vertices and may reorder
    the rest)."""
    found = glb_attribute(path, obj.data.name, attribute) or glb_attribute(path, obj.name, attribute)
    if not found:
        return False
    positions, values = found
    tree = kdtree.KDTree(len(positions))
    for k, p in enumerate(positions):
        tree.insert(bevy_to_blender(p), k)
    tree.balance()
    world = obj.matrix_world
    attr = obj.data.attributes.new(attribute, "FLOAT", "POINT")
    for v, a in zip(obj.data.vertices, attr.data):
        _, k, _ = tree.find(world @ v.co)
        a.value = values[k]
    return True


def load_meshes(folder, frame):
    for name in ["terrain.glb", f"frame_{frame:04d}.glb"]:
        path = os.path.join(folder, name)
        if not os.path.exists(path):
            continue
        before = set(bpy.data.objects)
        bpy.ops.import_scene.gltf(filepath=path)
        for obj in set(bpy.data.objects) - before:
            if obj.type == "MESH" and obj.name.startswith("lava"):
                bpy.context.view_layer.update()
                if copy_attribute(obj, path, "_TEMPERATURE"):
                    lava_emission(obj)


def set_view(info, width, height):
    scene = bpy.context.scene
    view = info.get("view") or {}
    cam = view.get("camera")
    if cam:
        data = bpy.data.cameras.new("camera")
        data.sensor_fit = "VERTICAL"
        data.angle_y = math.radians(cam["vertical_fov_deg"])
        data.clip_start = 1.0
        data.clip_end = 400_000.0
        obj = bpy.data.objects.new("camera", data)
        scene.collection.objects.link(obj)
        obj.location = bevy_to_blender(cam["position"])
        x, y, z, w = cam["rotation"]
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = Y_UP_TO_Z_UP @ Quaternion((w, x, y, z))
        scene.camera = obj
    sun = view.get("sun")
    if sun:
        data = bpy.data.lights.new("sun", "SUN")
        # Blender's sun strength is irradiance in W/m^2 (683 lm/W at 555 nm); scaled so that a
        # 100,000 lux noon is 4, a level Filmic shows without clipping.
        data.energy = 4.0 * sun["illuminance_lux"] / 100_000.0
        obj = bpy.data.objects.new("sun", data)
        scene.collection.objects.link(obj)
        towards = bevy_to_blender(sun["direction"]).normalized()
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = towards.to_track_quat("Z", "Y")
    scene.render.resolution_x = width
    scene.render.resolution_y = height
    scene.render.resolution_percentage = 100


def main():
    a = args()
    frame_json = os.path.join(a.dir, f"frame_{a.frame:04d}.json")
    vdb = os.path.join(a.dir, f"frame_{a.frame:04d}.vdb")
    with open(frame_json) as f:
        info = json.load(f)
    clear_scene()
    load_volumes(os.path.abspath(vdb), a.only_ash, a.glow)
    if not a.only_ash:
        load_meshes(a.dir, a.frame)
    set_view(info, a.width, a.height)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = a.samples
    # Debian's Blender is built without OpenImageDenoise.
    scene.cycles.use_denoising = False
    scene.cycles.volume_step_rate = 4.0
    scene.cycles.volume_max_steps = 256
    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.35, 0.5, 0.8, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
    scene.world = world
    if a.only_ash:
        scene.render.film_transparent = True
    if a.save:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(a.save))
    if a.render:
        scene.render.filepath = os.path.abspath(a.render)
        scene.render.image_settings.file_format = "PNG"
        scene.render.image_settings.color_mode = "RGBA"
        bpy.ops.render.render(write_still=True)
        print(f"volcano: rendered {a.render}")


main()
