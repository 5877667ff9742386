#!/usr/bin/env bash
# Checks the layout rules of docs/architecture.md on the source tree:
#   1. no include circle between files, nor between folders (tsort finds any loop);
#   2. a folder includes only headers of the folders its CMake library links (the build makes
#      a wrong include fail too; this names the file and line);
#   3. no folder holds more than a quarter of the non-test code;
#   4. every header opens with a comment saying what the module is for.
# usage: tools/check_layout.sh [SOURCE_DIR]   (exit 0: all hold; 1: a rule broken, named)
set -euo pipefail
cd "${1:-$(dirname "$0")/..}"

# The library folders, bottom-up, with what each may include (its CMake links, transitively).
declare -A ALLOWED=(
  [base]=""
  [spectral]="base" [optics]="base" [sampling]="base" [scenefile]="base" [imageio]="base"
  [bsdf]="optics sampling base"
  [scene]="bsdf scenefile imageio optics sampling spectral base"
  [photons]="scene bsdf scenefile imageio optics sampling spectral base"
  [film]="imageio spectral base"
  [render]="photons film scene bsdf scenefile imageio optics sampling spectral base"
  [proto]="base"
  [net]="proto base"
  [settings]="proto scene bsdf scenefile imageio optics sampling spectral base"
  [dashboard]="net proto base"
  [master]="dashboard settings net proto photons film scene bsdf scenefile imageio optics sampling spectral base"
  [worker]="settings render net proto photons film scene bsdf scenefile imageio optics sampling spectral base"
  [cli]="master dashboard worker settings render net proto photons film scene bsdf scenefile imageio optics sampling spectral base"
)
FOLDERS="${!ALLOWED[*]}"
status=0
fail() { echo "check_layout: $*" >&2; status=1; }

# Which folder each header lives in (header names are unique across folders).
declare -A HOME_OF=()
for d in $FOLDERS; do
  for h in "$d"/*.h; do
    [ -e "$h" ] || continue
    n=${h##*/}
    [ -z "${HOME_OF[$n]:-}" ] || fail "header $n is in both ${HOME_OF[$n]}/ and $d/"
    HOME_OF[$n]=$d
  done
done

file_edges=$(mktemp); folder_edges=$(mktemp)
trap 'rm -f "$file_edges" "$folder_edges"' EXIT
for d in $FOLDERS; do
  for f in "$d"/*.c "$d"/*.h; do
    [ -e "$f" ] || continue
    base=${f##*/}; stem=${base%.*}
    echo "$f $f" >>"$file_edges"
    while IFS=: read -r line inc; do
      inc=${inc#*\"}; inc=${inc%\"*}
      home=${HOME_OF[$inc]:-}
      [ -n "$home" ] || continue # a system or generated header
      if [ "$home" != "$d" ]; then
        case " ${ALLOWED[$d]} " in
          *" $home "*) echo "$d $home" >>"$folder_edges" ;;
          *) fail "$f:$line includes $home/$inc, but $d/ may use only: ${ALLOWED[$d]:-libc}" ;;
        esac
      fi
      # A module's .c including its own header is not an edge between modules.
      [ "${inc%.h}" = "$stem" ] && continue
      echo "${f%.*} $home/${inc%.h}" >>"$file_edges"
    done < <(grep -n '^#include "' "$f" || true)
  done
done
# Modules (a .c and its .h) are the nodes: an edge from module A to B when either of A's files
# includes B's header.
sed -E 's/\.(c|h)( |$)/\2/g' "$file_edges" | awk '$1 != $2 || NF == 1' >"$file_edges.m"
if ! tsort "$file_edges.m" >/dev/null 2>"$file_edges.err"; then
  fail "include circle between modules: $(grep -v 'input contains a loop' "$file_edges.err" | sed 's/^tsort: //' | tr '\n' ' ')"
fi
if ! sort -u "$folder_edges" | tsort >/dev/null 2>"$folder_edges.err"; then
  fail "include circle between folders: $(tr '\n' ' ' <"$folder_edges.err")"
fi
rm -f "$file_edges.m" "$file_edges.err" "$folder_edges.err"

# Size: non-test code is every .c/.h outside tests/ (libraries, cli, bench).
total=$(find $FOLDERS bench -name '*.[ch]' -print0 | xargs -0 cat | wc -l)
for d in $FOLDERS; do
  n=$(find "$d" -name '*.[ch]' -print0 | xargs -0 cat | wc -l)
  if [ $((n * 4)) -gt "$total" ]; then
    fail "$d/ holds $n of $total lines of non-test code, more than a quarter"
  fi
done

# Headers open with what the module is for.
for d in $FOLDERS; do
  for h in "$d"/*.h; do
    [ -e "$h" ] || continue
    head -c 2 "$h" | grep -q '/\*' || fail "$h does not open with a comment saying what it is for"
  done
done

[ $status -eq 0 ] && echo "check_layout: $(echo $FOLDERS | wc -w) folders, no include circle, none over a quarter of $total lines"
exit $status
