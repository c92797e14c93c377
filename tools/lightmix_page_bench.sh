#!/usr/bin/env bash
# How fast the LightMix page (src/cli/lightmix_page.html, what `esr lightmix` writes as
# DIR/index.html) redraws after a slider moves, in headless Chromium (Debian package `chromium`;
# software WebGL through SwiftShader unless a GPU is there): LIGHTS lights (default 8) at
# SIZE x SIZE pixels (default 512), DRAWS redraws (default 200), each waited for by reading a
# pixel back. The layers are made up (every value 0.125): the recombination's cost does not
# depend on them. Prints, for a drag of one slider, the first redraw (which sums the other lights
# once) and the mean and slowest of the rest, and the mean when each redraw changes another light.
# A benchmark, not part of the tests.
#   tools/lightmix_page_bench.sh [LIGHTS] [SIZE] [DRAWS]
set -euo pipefail
lights=${1:-8} size=${2:-512} draws=${3:-200}
here=$(cd "$(dirname "$0")" && pwd)
browser=$(command -v chromium || command -v chromium-browser || true)
[ -n "$browser" ] || { echo "lightmix_page_bench: no chromium (Debian package chromium)" >&2; exit 2; }
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cp "$here/../src/cli/lightmix_page.html" "$dir/index.html"
python3 - "$dir" "$lights" "$size" <<'PY'
import base64, json, sys
d, k, s = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
lights = [{"id": i, "centroid": [0, 0, 0], "rgb": [1, 1, 1], "hsv": [0, 0, 1], "chroma": [1, 1, 1]}
          for i in range(k)]
meta = {"run": "RUN", "method": "direct", "spp": 8, "orbit": 1, "size": 0, "phase": "",
        "lights": lights, "views": [{"name": "orbit_000", "width": s, "height": s, "file": "orbit_000.js"}]}
open(d + "/lightmix.js", "w").write("window.LIGHTMIX = " + json.dumps(meta) + ";\n")
data = base64.b64encode(b"\x00\x30" * ((1 + 2 * k) * s * s * 3)).decode()
open(d + "/orbit_000.js", "w").write('LIGHTMIX_VIEW("orbit_000", %d, %d, "%s");\n' % (s, s, data))
PY
"$browser" --headless --no-sandbox --user-data-dir="$dir/profile" --use-angle=swiftshader \
  --enable-unsafe-swiftshader --window-size="$((size + 480)),$((size + 100))" --dump-dom \
  "file://$dir/index.html#view=orbit_000&bench=$draws" 2>"$dir/log" | grep -o '<title>[^<]*' | sed 's/<title>//' \
  || { cat "$dir/log" >&2; exit 1; }
