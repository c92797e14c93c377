# Blender side of tools/lightmix_blender_check.sh: opens one view's EXR from `esr lightmix` in the
# compositor as an Image node and prints the passes Blender offers (one output socket per light
# group), then composites the sum of the groups' sockets named on the command line into OUT.exr,
# which the shell script compares with the EXR's own layers summed by esr.
#   blender -b --factory-startup -P lightmix_blender_check.py -- VIEW.exr W H OUT.exr LAYER...
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
exr, width, height, out, layers = argv[0], int(argv[1]), int(argv[2]), argv[3], argv[4:]
img = bpy.data.images.load(exr)
scene = bpy.context.scene
scene.use_nodes = True
tree = scene.node_tree
for n in list(tree.nodes):
    tree.nodes.remove(n)
node = tree.nodes.new("CompositorNodeImage")
node.image = img
names = [s.name for s in node.outputs if s.enabled]
print("image type:", img.type)
print("compositor outputs:", ", ".join(names))
missing = [l for l in layers if l not in names]
if missing:
    print("missing layers:", ", ".join(missing))
    sys.exit(1)
acc = node.outputs[layers[0]]
for l in layers[1:]:
    add = tree.nodes.new("CompositorNodeMixRGB")
    add.blend_type = "ADD"
    add.use_clamp = False
    add.inputs[0].default_value = 1.0
    tree.links.new(acc, add.inputs[1])
    tree.links.new(node.outputs[l], add.inputs[2])
    acc = add.outputs[0]
comp = tree.nodes.new("CompositorNodeComposite")
comp.use_alpha = False
tree.links.new(acc, comp.inputs[0])
scene.render.resolution_x, scene.render.resolution_y = width, height
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.image_settings.color_mode = "RGB"
scene.view_settings.view_transform = "Standard"
scene.render.filepath = out
scene.render.use_compositing = True
scene.render.use_sequencer = False
# the compositor runs on a render; an empty scene renders fast and its result is replaced
scene.render.engine = "BLENDER_EEVEE" if "BLENDER_EEVEE" in [e.identifier for e in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items] else scene.render.engine
bpy.ops.render.render(write_still=True)
print("wrote", out)
