#!/usr/bin/env bash
# Peer check of `esr export --gltf`, a benchmark: Blender (Debian package, installed when missing)
# imports the asset and renders it with Cycles from every lights-on test camera of the dataset,
# under the asset's own emitters and esr's own environment map as the world (not the dataset's);
# prints the PSNR of each render against the lights-on photo beside esr's own renders of the
# view (the direct relight unedited: the same BRDF, emitters and map as the asset; and the
# radiance field), their means, and writes them to RUN/gltf_check/gltf_check.json.
# Not part of `make test` (Blender is large); `make gltf-blender-check RUN=...` runs it.
#   tools/gltf_blender_check.sh RUN [DATA] [SAMPLES] [FRAMES] [MATERIALS]
# DATA: the dataset (default: the one RUN was trained on); SAMPLES: Cycles samples per pixel
# (default 256: at 64 the mean PSNR is 0.4 dB lower from Cycles noise alone); FRAMES: comma-separated test_nv frames (default, or empty: every *_on frame);
# MATERIALS: `esr export --materials` (default 8).
set -euo pipefail
run=${1:?usage: tools/gltf_blender_check.sh RUN [DATA] [SAMPLES] [FRAMES] [MATERIALS]}
here=$(cd "$(dirname "$0")" && pwd)
esr=${ESR:-$here/../build/esr}
[ -f "$run/run.json" ] || { echo "gltf_blender_check: $run has no run.json (not a run folder)" >&2; exit 1; }
data=${2:-$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["data"])' "$run/run.json")}
samples=${3:-256}
tnv=$data/transforms/transforms_test_nv.json
[ -f "$tnv" ] || { echo "gltf_blender_check: $tnv is missing (a dataset with test views is needed)" >&2; exit 1; }
frames=${4:-$(python3 -c 'import json,sys
print(",".join(f["file_path"].split("/")[-1] for f in json.load(open(sys.argv[1]))["frames"]
               if f["file_path"].endswith("_on")))' "$tnv")}
[ -n "$frames" ] || { echo "gltf_blender_check: $tnv has no lights-on frame" >&2; exit 1; }
command -v blender >/dev/null && python3 -c "import numpy" 2>/dev/null || { SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo;
  $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends blender python3-numpy; }
out=$run/gltf_check
rm -rf "$out/blender" "$out/direct" "$out/esr"
mkdir -p "$out/blender"
"$esr" export "$run" --gltf "$out/scene.glb" --materials "${5:-8}" 2>&1 | sed 's/^/  /'
# esr's own renders: the radiance field (which also writes the map, env.exr) and the direct relight
{ "$esr" render "$run" --data "$data" --frames "$frames" --out "$out/esr" &&
  "$esr" edit "$run" --data "$data" --light all --intensity 1 --method direct --frames "$frames" \
    --out "$out/direct"; } > "$out/esr.log" 2>&1 || { tail -20 "$out/esr.log"; exit 1; }
start=$(date +%s)
blender -b --factory-startup -P "$here/gltf_blender_check.py" -- "$out/scene.glb" "$tnv" \
  "$data/scene.json" "$out/esr/env.exr" "$out/blender" "$samples" "$frames" \
  > "$out/blender.log" 2>&1 || { tail -20 "$out/blender.log"; exit 1; }
echo "Blender: $(echo "$frames" | tr ',' '\n' | wc -l) views at $samples spp in $(( $(date +%s) - start )) s"
rows=""
for f in ${frames//,/ }; do
  b=$("$esr" metrics "$out/blender/$f.png" "$data/test_nv/$f.png")
  d=$("$esr" metrics "$out/direct/$f.png" "$data/test_nv/$f.png")
  e=$("$esr" metrics "$out/esr/$f.png" "$data/test_nv/$f.png")
  rows="$rows{\"view\": \"$f\", \"blender\": $b, \"direct\": $d, \"field\": $e}"$'\n'
done
printf '%s' "$rows" | python3 -c '
import json, sys
rows = [json.loads(l) for l in sys.stdin if l.strip()]
keys = [("blender", "Blender Cycles, the glTF"), ("direct", "esr direct (unedited)"), ("field", "esr radiance field")]
print("PSNR dB against the lights-on photos (SSIM in brackets):")
print("%-10s" % "view" + "".join("%28s" % t for _, t in keys))
for r in rows:
    print("%-10s" % r["view"] + "".join("%20.2f (%.3f)" % (r[k]["psnr"], r[k]["ssim"]) for k, _ in keys))
mean = {k: sum(r[k]["psnr"] for r in rows) / len(rows) for k, _ in keys}
print("%-10s" % "mean" + "".join("%20.2f        " % mean[k] for k, _ in keys))
print("Blender - esr direct: %+.2f dB" % (mean["blender"] - mean["direct"]))
doc = {"samples": int(sys.argv[2]), "views": rows, "mean_psnr": mean,
       "blender_minus_direct_db": mean["blender"] - mean["direct"]}
tmp = sys.argv[1] + ".tmp"
json.dump(doc, open(tmp, "w"), indent=1)
import os; os.replace(tmp, sys.argv[1])
print("wrote", sys.argv[1])
' "$out/gltf_check.json" "$samples"
