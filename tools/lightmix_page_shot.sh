#!/usr/bin/env bash
# A still of esr lightmix's page (DIR/index.html) in headless Chromium (Debian package
# `chromium`; software WebGL through SwiftShader): the view VIEW under the mix MIX_JSON (the JSON
# text, as the page's address takes it), at 1:1 in the top-left corner (#...&still=1) of OUT.png,
# a window of at least WIDTH x HEIGHT pixels (400 x 400 at least: a smaller headless window came
# back black). The page's image read back, for comparing it with esr edit's PNG of the same mix
# (tests/test_cli_lightmix_tiny.c does).
#   tools/lightmix_page_shot.sh DIR/index.html VIEW MIX_JSON WIDTH HEIGHT OUT.png
set -euo pipefail
index=$1 view=$2 mix=$3 width=$4 height=$5 out=$6
[ -f "$index" ] || { echo "lightmix_page_shot: no page $index" >&2; exit 1; }
browser=$(command -v chromium || command -v chromium-browser || true)
[ -n "$browser" ] || { echo "lightmix_page_shot: no chromium (Debian package chromium)" >&2; exit 2; }
enc=$(printf '%s' "$mix" | python3 -c 'import sys, urllib.parse; print(urllib.parse.quote(sys.stdin.read(), safe=""))')
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
dir=$(cd "$(dirname "$index")" && pwd)
url="file://$dir/$(basename "$index")#view=$view&mix=$enc&still=1"
# --no-sandbox: Chromium refuses to run as root with its sandbox (containers, CI)
"$browser" --headless --no-sandbox --user-data-dir="$profile" --use-angle=swiftshader \
  --enable-unsafe-swiftshader --hide-scrollbars --force-device-scale-factor=1 \
  --window-size="$((width > 400 ? width : 400)),$((height > 400 ? height : 400))" --screenshot="$out" "$url" \
  > "$profile/log" 2>&1 || { cat "$profile/log" >&2; exit 1; }
! grep -q "Page load failed" "$profile/log" || { grep "Page load failed" "$profile/log" >&2; exit 1; }
[ -s "$out" ] || { cat "$profile/log" >&2; exit 1; }
