# Renders an `esr export --gltf` asset in Blender (Cycles) from a dataset camera, under its own
# emitters and the dataset's uniform world light, for comparison with the dataset's lights-on
# image. Run by tools/gltf_blender_check.sh:
#   blender -b --factory-startup -P tools/gltf_blender_check.py -- ASSET.glb TRANSFORMS.json FRAME SCENE.json OUT.png SAMPLES
import json
import sys

import bpy
import mathutils
import numpy

# Debian's Blender 3.4 glTF importer still says np.bool, which numpy 1.24 removed
if not hasattr(numpy, 'bool'):
    numpy.bool = bool

asset, transforms, frame_name, scene_json, out_png, samples = sys.argv[sys.argv.index('--') + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=asset)

with open(transforms) as f:
    tr = json.load(f)
frame = next(fr for fr in tr['frames'] if fr['file_path'].split('/')[-1] == frame_name)
cam_data = bpy.data.cameras.new('camera')
cam_data.sensor_fit = 'HORIZONTAL'
cam_data.angle = tr['camera_angle_x']
cam = bpy.data.objects.new('camera', cam_data)
cam.matrix_world = mathutils.Matrix(frame['transform_matrix'])  # the dataset's own Blender frame
bpy.context.scene.collection.objects.link(cam)

scene = bpy.context.scene
scene.camera = cam
with open(scene_json) as f:
    sj = json.load(f)
res = sj.get('resolution', [160, 160])
scene.render.resolution_x, scene.render.resolution_y = res[0], res[1]
scene.render.resolution_percentage = 100
scene.render.engine = 'CYCLES'
scene.cycles.device = 'CPU'
scene.cycles.samples = int(samples)
scene.cycles.use_denoising = False  # Debian's build has no OpenImageDenoise
scene.render.film_transparent = True
scene.view_settings.view_transform = 'Standard'
world = bpy.data.worlds.new('world')
world.use_nodes = True
bg = world.node_tree.nodes['Background']
w = sj['world']
bg.inputs['Color'].default_value = (*w['color_rgb_linear'], 1.0)
bg.inputs['Strength'].default_value = w['strength']
scene.world = world
scene.render.filepath = out_png
scene.render.image_settings.file_format = 'PNG'
scene.render.image_settings.color_mode = 'RGBA'
bpy.ops.render.render(write_still=True)
