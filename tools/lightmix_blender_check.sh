#!/usr/bin/env bash
# Peer check of `esr lightmix`'s EXR: Blender (Debian package, installed when missing) opens one
# view's multi-layer EXR in its compositor, lists the light groups it finds there by name, and
# composites off + every light_K; that sum must be the unedited view, which OpenImageIO's
# oiiotool (Debian openimageio-tools) sums from the same file independently. Prints both and
# their PSNR. Not part of `make test` (Blender is large).
#   tools/lightmix_blender_check.sh LIGHTMIX_DIR [VIEW]      (VIEW: the first view by default)
set -euo pipefail
dir=$1
here=$(cd "$(dirname "$0")" && pwd)
esr=${ESR:-$here/../build/esr}
SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
need=""
command -v blender >/dev/null || need="$need blender"
command -v oiiotool >/dev/null || need="$need openimageio-tools"
[ -z "$need" ] || { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $need; }
[ -f "$dir/lightmix.json" ] || { echo "lightmix_blender_check: $dir/lightmix.json missing (not an esr lightmix folder)" >&2; exit 1; }
view=${2:-$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["views"][0]["name"])' "$dir/lightmix.json" 2>/dev/null || ls "$dir" | sed -n 's/\.exr$//p' | head -1)}
exr=$dir/$view.exr
[ -f "$exr" ] || { echo "lightmix_blender_check: no $exr" >&2; exit 1; }
# the groups that sum to the unedited view: off and each light at its found emission
mapfile -t groups < <(python3 -c 'import json,sys; print("\n".join(l for l in json.load(open(sys.argv[1]))["layers"] if not l.endswith("_value")))' "$dir/lightmix.json")
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
size=$(oiiotool --info "$exr" | sed -nE 's/.*: *([0-9]+) x +([0-9]+),.*/\1 \2/p' | head -1)
blender -b --factory-startup -P "$here/lightmix_blender_check.py" -- "$exr" $size "$out/blender_sum.exr" "${groups[@]}" \
  > "$out/blender.log" 2>&1 || { tail -20 "$out/blender.log"; exit 1; }
grep -E "^(image type|compositor outputs|wrote)" "$out/blender.log"
# Blender may append the frame number to the output name
bsum=$(ls "$out"/blender_sum*.exr | head -1)
args=()
for g in "${groups[@]}"; do args+=("$exr" --ch "$g.R,$g.G,$g.B" --chnames R,G,B); done
oiiotool "${args[@]}" $(printf -- '--add %.0s' $(seq 2 ${#groups[@]})) -d float -o "$out/oiio_sum.exr"
echo "Blender's composite of ${groups[*]} against oiiotool's sum of the same layers:"
"$esr" metrics "$bsum" "$out/oiio_sum.exr"
