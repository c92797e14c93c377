#!/bin/sh
# Runs every libFuzzer harness of a fuzz build for SECONDS each, one after the other, on one
# core: fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]   (what `make fuzz` calls)
# Each harness starts from its seed corpus (fuzz/corpus/<name>, only read) and its regressions,
# grows a scratch corpus in BUILD_DIR/corpus/<name>, and leaves any crashing, leaking or
# out-of-memory input in BUILD_DIR/findings/<name>/. Exit status 1 when any harness found one.
set -u
build=$1 seconds=$2
shift 2
fuzz=$(cd "$(dirname "$0")" && pwd)
names=${*:-$(cd "$fuzz" && ls fuzz_*.c | sed 's/^fuzz_//; s/\.c$//')}
failed=""
for name in $names; do
  bin=$build/fuzz/fuzz_$name
  [ -x "$bin" ] || { echo "fuzz: $bin is not built"; exit 1; }
  case $name in
    png|exr|npz|colmap_bin) dict="" ;;
    ply) dict="-dict=$fuzz/ply.dict" ;;
    colmap_text) dict="-dict=$fuzz/colmap.dict" ;;
    jpeg) dict="-dict=$fuzz/jpeg.dict" ;;
    *) dict="-dict=$fuzz/json.dict" ;;
  esac
  mkdir -p "$build/corpus/$name" "$build/findings/$name"
  echo "== fuzz_$name for ${seconds}s"
  # libFuzzer's own memory cap (2 GiB) stated; the harnesses set esr's limits well below it
  "$bin" -max_total_time="$seconds" -print_final_stats=1 -rss_limit_mb=2048 -timeout=10 $dict \
    -artifact_prefix="$build/findings/$name/" "$build/corpus/$name" "$fuzz/corpus/$name" \
    "$fuzz/regressions/$name" > "$build/fuzz_$name.log" 2>&1
  status=$?
  grep -E '^(#[0-9]+[[:space:]]+DONE|stat::|==[0-9]+==ERROR|SUMMARY)' "$build/fuzz_$name.log"
  [ $status -eq 0 ] && [ -z "$(ls "$build/findings/$name")" ] || failed="$failed $name"
done
if [ -n "$failed" ]; then
  echo "fuzz: findings in:$failed (inputs in $build/findings/, logs $build/fuzz_<name>.log)"
  exit 1
fi
echo "fuzz: no findings"
