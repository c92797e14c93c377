#!/usr/bin/env bash
# COLMAP round trip (issue #14's peer check with COLMAP itself); what `make colmap-roundtrip` runs.
#
#   1. `esr synth` renders SCENE's training views at RES px (the capture) and, with the
#      same seed and so the same cameras, at SIZE px with its test views (the true dataset).
#   2. The capture's renders are laid out as photos (IMAGES/off, IMAGES/on; any alpha composited
#      on white, saved as JPEG, as a camera would) and posed by COLMAP from scratch: one shared
#      CAMERA_MODEL camera, exhaustive matching, mapper, CPU only.
#   3. `esr import colmap ... --align-to TRUE` aligns COLMAP's cameras to the true ones (a
#      similarity on the centres; that alignment also places the scene), reports their rotation
#      and position errors, writes the photos in the true pinhole and copies the true test views.
#   4. The true dataset is also cut down to the photos COLMAP registered (the same training
#      photos as the import's, on the true cameras).
#   5. All three are trained the same way (`--until fine`, `fast` preset) and scored on the same
#      test_nv images.
#
# Writes WORK/roundtrip.json (errors, PSNRs, timings, COLMAP version, registered images) and
# prints a summary. Exit status: 1 when a stage fails, 2 when it ran but missed a target
# (median rotation error < 0.5 degrees; test PSNR within 1 dB of the registered photos trained on
# the true cameras: what the cameras alone cost; the run on all photos is reported beside it).
# Stages whose output exists are reused, with the time they took then (WORK/logs/STAGE.seconds);
# delete WORK, or parts of it, to redo them.
set -euo pipefail

ESR=${ESR:-build/esr}
WORK=${WORK:-/tmp/esr-colmap-roundtrip}
RES=${RES:-1000}            # capture photos, px (issue #14: 1000 px or more)
SPP=${SPP:-16}              # path-tracing samples per pixel of the capture
VIEWS=${VIEWS:-50}          # training views per lighting condition
SIZE=${SIZE:-100}           # true dataset and import, px (what both trainings see)
TEST_VIEWS=${TEST_VIEWS:-5}
THREADS=${THREADS:-2}       # COLMAP's threads (the machine is shared)
SCENE=${SCENE:-capture}     # built-in scene: capture (non-repeating textures) or default (checker, stripes)
SYNTH_OPTS=${SYNTH_OPTS---backdrop} # extra `esr synth` options for both renders (default --backdrop: opaque
                             # photos of the object in a room; SYNTH_OPTS= for renders on white)
# the renders are ideal pinholes: with SIMPLE_RADIAL COLMAP trades focal length against a spurious
# distortion (400 px: focal 541.3 for the true 555.6, k -0.093; its import trained 3 to 9 dB below
# the same photos on the true cameras, on the test views they cover)
CAMERA_MODEL=${CAMERA_MODEL:-SIMPLE_PINHOLE}
# KNOWN_FOCAL=1: COLMAP is given the renders' focal length and keeps it (a calibrated camera);
# 0: it estimates the focal length itself from a default prior, as for photos without EXIF (at
# 1000 px 1.1% short, which cost 2.4 dB against the true cameras where 1: 0.9 dB)
KNOWN_FOCAL=${KNOWN_FOCAL:-1}
FEATURES=${FEATURES:-2048}  # SIFT features per photo: CPU matching is brute force, pairs x features^2
MAX_ROT_DEG=0.5
MAX_PSNR_DIFF_DB=1.0

die() { echo "colmap-roundtrip: $*" >&2; exit 1; }
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

need_package() { # command, Debian package
    command -v "$1" >/dev/null && return 0
    echo "== installing $2"
    local sudo=""; [ "$(id -u)" = 0 ] || sudo=sudo
    $sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "$2" \
        || die "could not install $2"
}

# Runs a stage, timing it; output to WORK/logs/NAME.log (shown when it fails). `set -e` does not
# reach into a function run as an `if` condition, so a stage function returns its failures itself.
run_stage() {
    local name=$1; shift
    local t0; t0=$(now)
    echo "== $name"
    if ! "$@" >"$WORK/logs/$name.log" 2>&1; then
        tail -n 30 "$WORK/logs/$name.log" >&2
        die "stage '$name' failed (log: $WORK/logs/$name.log)"
    fi
    elapsed "$t0" >"$WORK/logs/$name.seconds"
    echo "   $(cat "$WORK/logs/$name.seconds") s"
}

[ -x "$ESR" ] || die "no esr binary at $ESR (build first: make build)"
need_package colmap colmap
need_package jq jq
need_package convert imagemagick
mkdir -p "$WORK/logs"
CAPTURE_SRC=$WORK/capture_render TRUE=$WORK/truth IMAGES=$WORK/images DB=$WORK/colmap.db SPARSE=$WORK/sparse
IMPORTED=$WORK/imported
COLMAP_VERSION=$(colmap -h 2>&1 | grep -m1 -o 'COLMAP [^ ]*' || echo unknown)

# 1. renders
[ -f "$CAPTURE_SRC/scene.json" ] || run_stage synth_capture \
    "$ESR" synth --scene "$SCENE" $SYNTH_OPTS --res "$RES" --spp "$SPP" --train "$VIEWS" --test 1 --force "$CAPTURE_SRC"
[ -f "$TRUE/scene.json" ] || run_stage synth_true \
    "$ESR" synth --scene "$SCENE" $SYNTH_OPTS --res "$SIZE" --train "$VIEWS" --test "$TEST_VIEWS" --force "$TRUE"
# same seed, same cameras: the import is matched to the true frames by name
cmp -s <(jq -c '[.frames[] | [.file_path, .transform_matrix]]' "$CAPTURE_SRC/transforms/transforms_train.json") \
       <(jq -c '[.frames[] | [.file_path, .transform_matrix]]' "$TRUE/transforms/transforms_train.json") \
    || die "the capture's and the true dataset's train cameras differ"

# 2. the capture as photos, then COLMAP
make_photos() {
    rm -rf "$IMAGES.tmp" && mkdir -p "$IMAGES.tmp/off" "$IMAGES.tmp/on" || return 1
    jq -r '.frames[] | "\(.file_path) \(.lights[0].mode)"' "$CAPTURE_SRC/transforms/transforms_train.json" |
    while read -r path mode; do
        convert "$CAPTURE_SRC/$path.png" -background white -alpha remove -alpha off -quality 95 \
            "$IMAGES.tmp/$mode/$(basename "$path").jpg" || exit 1
    done || return 1
    mv "$IMAGES.tmp" "$IMAGES"
}
[ -d "$IMAGES" ] || run_stage photos make_photos

# Each COLMAP stage is skipped when its record (logs/STAGE.seconds) and the database exist:
# exhaustive_matcher itself skips the pairs the database already holds.
if [ ! -f "$SPARSE/0/images.bin" ]; then
    export QT_QPA_PLATFORM=offscreen  # no display; COLMAP's CPU paths need none
    intrinsics=() refine_focal=1
    if [ "$KNOWN_FOCAL" = 1 ]; then # the capture's focal length in pixels, principal point centred
        params=$(jq -r --argjson res "$RES" '(0.5 * $res / ((.camera_angle_x / 2) | tan)) as $f
            | "\($f),\($res / 2),\($res / 2)"' "$CAPTURE_SRC/transforms/transforms_train.json")
        [ "$CAMERA_MODEL" = SIMPLE_PINHOLE ] || params="$params,0"
        intrinsics=(--ImageReader.camera_params "$params") refine_focal=0
    fi
    if [ ! -f "$DB" ] || [ ! -f "$WORK/logs/colmap_features.seconds" ]; then
        rm -f "$DB" "$WORK"/logs/colmap_*.seconds
        run_stage colmap_features colmap feature_extractor --database_path "$DB" --image_path "$IMAGES" \
            --ImageReader.camera_model "$CAMERA_MODEL" --ImageReader.single_camera 1 "${intrinsics[@]}" \
            --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads "$THREADS" \
            --SiftExtraction.max_num_features "$FEATURES"
    fi
    # RANSAC trials capped at 1000 (default 10000): pairs of cameras that see little in common
    # run every trial for E, F and H; pairs that do match stop early either way. On the shared
    # 2-core machine the first block of 1225 pairs took 453 s with the default, 336 s with this.
    [ -f "$WORK/logs/colmap_matching.seconds" ] ||
        run_stage colmap_matching colmap exhaustive_matcher --database_path "$DB" \
            --SiftMatching.use_gpu 0 --SiftMatching.num_threads "$THREADS" --SiftMatching.max_num_trials 1000
    rm -rf "$SPARSE" && mkdir -p "$SPARSE"
    run_stage colmap_mapper colmap mapper --database_path "$DB" --image_path "$IMAGES" --output_path "$SPARSE" \
        --Mapper.num_threads "$THREADS" --Mapper.ba_refine_focal_length "$refine_focal"
fi
# the largest model when the mapper made several
MODEL=$(ls -S "$SPARSE"/*/images.bin | head -n 1 | xargs dirname)

# 3. import, aligned to the true cameras (a new import invalidates the run on it)
TRUE_REG=$WORK/truth_registered
if [ ! -f "$IMPORTED/import.json" ]; then
    rm -rf "$WORK/run_imported" "$WORK/run_true_registered" "$TRUE_REG"
    run_stage import "$ESR" import colmap "$MODEL" "$IMAGES" --out "$IMPORTED" --align-to "$TRUE" --force
fi
sed -n '1,12p' "$WORK/logs/import.log"

# 4. the true dataset with only the photos COLMAP registered: the same training data as the
# import's, on the true cameras, so that the PSNR difference measures the cameras alone (the run
# on all true cameras also shows what the unregistered photos cost)
make_true_registered() {
    rm -rf "$TRUE_REG.tmp" && cp -r "$TRUE" "$TRUE_REG.tmp" || return 1
    jq --slurpfile imp "$IMPORTED/transforms/transforms_train.json" '
        ($imp[0].frames | map(.file_path | ltrimstr("train/"))) as $names
        | .frames |= map(select(((.file_path | ltrimstr("train/")) + "_" + .lights[0].mode) as $n
                                | $names | index($n)))' \
        "$TRUE/transforms/transforms_train.json" >"$TRUE_REG.tmp/transforms/transforms_train.json" || return 1
    mv "$TRUE_REG.tmp" "$TRUE_REG"
}
[ -d "$TRUE_REG" ] || run_stage true_registered make_true_registered
[ "$(jq '.frames | length' "$TRUE_REG/transforms/transforms_train.json")" = \
  "$(jq '.frames | length' "$IMPORTED/transforms/transforms_train.json")" ] ||
    die "the registered photos could not all be matched to true frames"

# 5. the same training on all three, scored on the same test views
for which in true true_registered imported; do
    case $which in
        true) data=$TRUE ;;
        true_registered) data=$TRUE_REG ;;
        imported) data=$IMPORTED ;;
    esac
    run=$WORK/run_$which
    [ -f "$run/eval/test_nv.json" ] && continue
    if [ -f "$run/config.json" ]; then # an interrupted run picks up where it stopped (timed apart)
        run_stage "train_${which}_resumed" "$ESR" train "$data" --out "$run" --until fine --resume
    else
        rm -rf "$run"
        run_stage "train_$which" "$ESR" train "$data" --out "$run" --until fine --preset fast
    fi
    run_stage "eval_$which" "$ESR" eval "$run" --phase test_nv
done

# 6. result file and summary
A=$IMPORTED/import.json
jq -n --slurpfile imp "$A" --slurpfile ea "$WORK/run_true/eval/test_nv.json" \
      --slurpfile et "$WORK/run_true_registered/eval/test_nv.json" --slurpfile ei "$WORK/run_imported/eval/test_nv.json" \
      --arg colmap "$COLMAP_VERSION" --arg scene "$SCENE" --arg camera_model "$CAMERA_MODEL" --argjson known_focal "$KNOWN_FOCAL" --argjson res "$RES" --argjson spp "$SPP" --argjson views "$VIEWS" --argjson features "$FEATURES" \
      --argjson size "$SIZE" --argjson max_rot "$MAX_ROT_DEG" --argjson max_drop "$MAX_PSNR_DIFF_DB" \
      --argjson timings "$(for f in "$WORK"/logs/*.seconds; do [ -f "$f" ] && echo "{\"$(basename "$f" .seconds)\": $(cat "$f")}"; done | jq -s 'add // {}')" '
  ($imp[0].alignment) as $a | ($et[0].mean.psnr) as $pt | ($ei[0].mean.psnr) as $pi | ($ea[0].mean.psnr) as $pa |
  {
    colmap_version: $colmap,
    capture: {scene: $scene, resolution: $res, spp: $spp, sift_features: $features, views_per_lighting: $views, photos: (2 * $views), camera_model: $camera_model, known_focal: ($known_focal == 1)},
    registered_images: $a.registered_images, matched_images: $a.matched_images,
    rotation_error_deg: {median: $a.rotation_error_median_deg, max: $a.rotation_error_max_deg},
    position_error: {median: $a.position_error_median, max: $a.position_error_max,
                     median_rel: $a.position_error_median_rel, max_rel: $a.position_error_max_rel,
                     scene_radius: $a.scene_radius},
    inliers: {count: $a.inliers, threshold: $a.inlier_threshold,
              rotation_error_deg: {median: $a.inlier_rotation_error_median_deg, max: $a.inlier_rotation_error_max_deg},
              position_error: {median: $a.inlier_position_error_median, max: $a.inlier_position_error_max}},
    colmap_to_true_scale: $a.colmap_to_true_scale, view_coverage: $a.view_coverage,
    train_size: $size, test_views: $a.test_views,
    psnr_true: $pt, psnr_imported: $pi, psnr_difference: ($pi - $pt), psnr_true_all_photos: $pa,
    psnr_by_mode: {true: {off: $et[0].by_mode.off.psnr, on: $et[0].by_mode.on.psnr},
                   true_all_photos: {off: $ea[0].by_mode.off.psnr, on: $ea[0].by_mode.on.psnr},
                   imported: {off: $ei[0].by_mode.off.psnr, on: $ei[0].by_mode.on.psnr}},
    ssim_true: $et[0].mean.ssim, ssim_imported: $ei[0].mean.ssim, ssim_true_all_photos: $ea[0].mean.ssim,
    timings_s: $timings,
    targets: {rotation_median_below_deg: $max_rot, psnr_within_db: $max_drop,
              rotation_ok: ($a.rotation_error_median_deg < $max_rot),
              psnr_ok: ((if $pi > $pt then $pi - $pt else $pt - $pi end) < $max_drop)}
  }' >"$WORK/roundtrip.json.tmp"
mv "$WORK/roundtrip.json.tmp" "$WORK/roundtrip.json"

jq -r '"COLMAP round trip (\(.colmap_version)), \(.capture.photos) photos of \(.capture.resolution) px",
  "registered   \(.registered_images) of \(.capture.photos)",
  "rotation     median \(.rotation_error_deg.median * 1e4 | round / 1e4) deg, max \(.rotation_error_deg.max * 1e4 | round / 1e4) deg",
  "inliers      \(.inliers.count) of \(.registered_images) within \(.inliers.threshold) of the true centre: rotation median \(.inliers.rotation_error_deg.median * 1e4 | round / 1e4) deg, max \(.inliers.rotation_error_deg.max * 1e4 | round / 1e4) deg",
  "position     median \(.position_error.median_rel * 1e5 | round / 1e5), max \(.position_error.max_rel * 1e5 | round / 1e5) scene radii (radius \(.position_error.scene_radius))",
  "test PSNR    the registered photos on the true cameras \(.psnr_true * 100 | round / 100) dB, on COLMAP'"'"'s \(.psnr_imported * 100 | round / 100) dB, difference \(.psnr_difference * 100 | round / 100) dB",
  "             all \(.capture.photos) photos on the true cameras \(.psnr_true_all_photos * 100 | round / 100) dB",
  "targets      rotation median < \(.targets.rotation_median_below_deg) deg: \(.targets.rotation_ok); PSNR within \(.targets.psnr_within_db) dB: \(.targets.psnr_ok)",
  "timings (s)  \(.timings_s | to_entries | map("\(.key) \(.value)") | join(", "))"' "$WORK/roundtrip.json"
echo "result: $WORK/roundtrip.json"
jq -e '.targets.rotation_ok and .targets.psnr_ok' "$WORK/roundtrip.json" >/dev/null || { echo "a target was missed" >&2; exit 2; }
