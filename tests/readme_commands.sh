#!/usr/bin/env bash
# The README's command lines run as written, as far as a cheap check can tell: every command in
# its fenced code blocks that starts with `esr` (or a path ending in /esr, such as ./build/esr),
# and every inline code span that is a `./build/esr ...` command line, must name a subcommand whose `--help` succeeds, and every --option it uses must appear in that
# --help text. Nothing is trained or rendered. A README line naming an option that --help does not
# list (one renamed or removed, or a typo) fails the test, naming the line.
#
# usage: tests/readme_commands.sh README.md path/to/esr
set -u
readme=${1:?usage: readme_commands.sh README.md ESR_BINARY}
esr=${2:?usage: readme_commands.sh README.md ESR_BINARY}
[ -r "$readme" ] || { echo "readme_commands: cannot read $readme"; exit 1; }
[ -x "$esr" ] || { echo "readme_commands: $esr is not an executable"; exit 1; }

# The fenced blocks' lines (and the inline ./build/esr spans), continuations (a trailing backslash) joined, comments (` # ...`)
# dropped, as "LINENO<TAB>TEXT".
commands=$(awk '
  /^[[:space:]]*```/ { fenced = !fenced; next }
  !fenced {
    # inline code that is a runnable command line: `./build/esr ...` (tables, prose)
    rest = $0
    while (match(rest, /`[^`]+`/)) {
      span = substr(rest, RSTART + 1, RLENGTH - 2)
      rest = substr(rest, RSTART + RLENGTH)
      if (span ~ /^(\/usr\/bin\/time -v )?\.\/build\/esr /) print NR "\t" span
    }
    next
  }
  {
    line = $0
    if (pending != "") { line = pending " " line; start = pstart } else start = NR
    if (line ~ /\\[[:space:]]*$/) { sub(/\\[[:space:]]*$/, "", line); pending = line; pstart = start; next }
    pending = ""
    sub(/(^|[[:space:]])#.*$/, "", line)
    print start "\t" line
  }' "$readme")

name=${readme##*/}
checked=0
failed=0
declare -A help_of

# `esr` or a path ending in /esr
is_esr() { [ "$1" = esr ] || [ "${1##*/}" = esr ]; }

while IFS=$'\t' read -r lineno text; do
    [ -n "${text// /}" ] || continue
    # one command per segment of a shell list or pipeline
    segments=$(printf '%s\n' "$text" | sed -e 's/&&/\n/g' -e 's/||/\n/g' -e 's/;/\n/g' -e 's/ | /\n/g')
    while IFS= read -r seg; do
        read -r -a tok <<<"$seg"
        i=0
        # wrappers before the command: VAR=value, time, /usr/bin/time -v, nice [-n N]
        while [ $i -lt ${#tok[@]} ]; do
            t=${tok[$i]}
            case "$t" in
                *=*) ;;
                time | /usr/bin/time | nice | -v) ;;
                -n) i=$((i + 1)) ;;
                *) break ;;
            esac
            i=$((i + 1))
        done
        if [ $i -ge ${#tok[@]} ] || ! is_esr "${tok[$i]}"; then
            continue
        fi
        sub=${tok[$((i + 1))]:-}
        rest=$((i + 2))
        if [ -z "$sub" ] || [ "${sub#-}" != "$sub" ]; then
            echo "$name:$lineno: '$seg' names no subcommand"
            failed=$((failed + 1))
            continue
        fi
        key=$sub
        if [ "$sub" = import ]; then
            key="import ${tok[$rest]:-}"
            rest=$((rest + 1))
        fi
        if [ -z "${help_of[$key]+set}" ]; then
            # shellcheck disable=SC2086
            if ! help_of[$key]=$("$esr" $key --help 2>&1); then
                echo "$name:$lineno: 'esr $key --help' fails: the README names a command esr does not have"
                failed=$((failed + 1))
                help_of[$key]=""
                continue
            fi
        fi
        [ -n "${help_of[$key]}" ] || continue
        checked=$((checked + 1))
        for ((j = rest; j < ${#tok[@]}; j++)); do
            opt=${tok[$j]}
            case "$opt" in --[a-zA-Z]*) ;; *) continue ;; esac
            opt=${opt%%=*}
            if ! grep -Eq -- "${opt}([^a-zA-Z0-9_-]|\$)" <<<"${help_of[$key]}"; then
                echo "$name:$lineno: 'esr $key' has no option $opt in its --help (line: $seg)"
                failed=$((failed + 1))
            fi
        done
    done <<<"$segments"
done <<<"$commands"

if [ $checked -eq 0 ]; then
    echo "readme_commands: no esr command found in the fenced blocks of $readme"
    exit 1
fi
echo "readme_commands: $checked esr command lines checked against --help, $failed problem(s)"
[ $failed -eq 0 ]
