# Renders an `esr export --gltf` asset in Blender (Cycles) from a dataset's cameras, under the
# asset's own emitters and esr's own environment map (its `esr render` env.exr) as the world, for
# comparison with the dataset's lights-on photos. Run by tools/gltf_blender_check.sh:
#   blender -b --factory-startup -P tools/gltf_blender_check.py -- \
#       ASSET.glb TRANSFORMS.json SCENE.json ENV.exr OUT_DIR SAMPLES FRAME[,FRAME...]
# writes OUT_DIR/<FRAME>.png (RGBA, transparent where no surface, the sRGB curve).
import json
import sys

import bpy
import mathutils
import numpy

# Debian's Blender 3.4 glTF importer still says np.bool, which numpy 1.24 removed
if not hasattr(numpy, 'bool'):
    numpy.bool = bool

asset, transforms, scene_json, env_exr, out_dir, samples, frames = sys.argv[sys.argv.index('--') + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=asset)

with open(transforms) as f:
    tr = json.load(f)
with open(scene_json) as f:
    sj = json.load(f)
cam_data = bpy.data.cameras.new('camera')
cam_data.sensor_fit = 'HORIZONTAL'
cam_data.angle = tr['camera_angle_x']
cam = bpy.data.objects.new('camera', cam_data)
scene = bpy.context.scene
scene.collection.objects.link(cam)
scene.camera = cam
res = sj.get('resolution', [160, 160])
scene.render.resolution_x, scene.render.resolution_y = res[0], res[1]
scene.render.resolution_percentage = 100
scene.render.engine = 'CYCLES'
scene.cycles.device = 'CPU'
scene.cycles.samples = int(samples)
scene.cycles.use_denoising = False  # Debian's build has no OpenImageDenoise
scene.render.film_transparent = True
scene.view_settings.view_transform = 'Standard'
scene.render.image_settings.file_format = 'PNG'
scene.render.image_settings.color_mode = 'RGBA'

# The world: esr's map. esr's equirectangular image (fields/env_sg.h) puts +Z in row 0 and the
# direction (cos phi, sin phi) at column phi / 2 pi; Cycles reads column 1/2 - phi / 2 pi (checked
# with cameras looking along +X, +Y, -X and an oblique direction at a map that encodes its own
# coordinates), so the columns are reordered: Blender's column b shows esr's W/2 - 1 - b.
src = bpy.data.images.load(env_exr)
w, h = src.size
pix = numpy.array(src.pixels[:], dtype=numpy.float32).reshape(h, w, src.channels)
rgba = numpy.ones((h, w, 4), dtype=numpy.float32)
rgba[..., :3] = pix[..., :3]
rgba = rgba[:, (w // 2 - 1 - numpy.arange(w)) % w]
env = bpy.data.images.new('esr_env', w, h, float_buffer=True, alpha=True)
env.pixels.foreach_set(rgba.ravel())
world = bpy.data.worlds.new('world')
world.use_nodes = True
tex = world.node_tree.nodes.new('ShaderNodeTexEnvironment')
tex.image = env
world.node_tree.links.new(tex.outputs['Color'], world.node_tree.nodes['Background'].inputs['Color'])
world.node_tree.nodes['Background'].inputs['Strength'].default_value = 1.0
scene.world = world

by_name = {fr['file_path'].split('/')[-1]: fr for fr in tr['frames']}
for name in frames.split(','):
    cam.matrix_world = mathutils.Matrix(by_name[name]['transform_matrix'])  # the dataset's Blender frame
    scene.render.filepath = '%s/%s.png' % (out_dir, name)
    bpy.ops.render.render(write_still=True)
