#!/usr/bin/env bash
# Peer check of `esr export --gltf`: Blender (Debian package, installed when missing) imports the
# asset and renders it with Cycles from a test camera under the asset's own emitters and the
# dataset's world light; prints PSNR/SSIM of that render and of esr's own render of the view
# against the dataset's lights-on image. Not part of `make test` (Blender is large).
#   tools/gltf_blender_check.sh RUN DATA [VIEW] [SAMPLES]     (VIEW default c000_on)
set -euo pipefail
run=$1 data=$2 view=${3:-c000_on} samples=${4:-64}
here=$(cd "$(dirname "$0")" && pwd)
esr=${ESR:-$here/../build/esr}
command -v blender >/dev/null && python3 -c "import numpy" 2>/dev/null || { SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo;
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends blender python3-numpy; }
out=$run/gltf_check
mkdir -p "$out"
"$esr" export "$run" --gltf "$out/scene.glb"
blender -b --factory-startup -P "$here/gltf_blender_check.py" -- "$out/scene.glb" \
  "$data/transforms/transforms_test_nv.json" "$view" "$data/scene.json" "$out/blender_$view.png" "$samples" \
  > "$out/blender.log" 2>&1 || { tail -20 "$out/blender.log"; exit 1; }
"$esr" render "$run" --frames "$view" --out "$out/esr" > /dev/null 2>&1
echo "blender (Cycles, $samples spp) render of the glTF vs the lights-on image:"
"$esr" metrics "$out/blender_$view.png" "$data/test_nv/$view.png"
echo "esr's own render of the view vs the lights-on image:"
"$esr" metrics "$out/esr/$view.png" "$data/test_nv/$view.png"
