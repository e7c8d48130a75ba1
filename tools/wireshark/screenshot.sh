#!/bin/sh
# The screenshot of docs/capture.md: Wireshark (Debian's wireshark-qt) under Xvfb on a capture,
# with candp2.lua, a display filter and a selected packet whose DP layer is expanded; the screen
# is grabbed with ImageMagick's import and stored as an 8-bit PNG.
#   tools/wireshark/screenshot.sh CAPTURE OUT.png [FILTER] [FRAME]
# Needs: wireshark-qt xvfb xdotool imagemagick (apt-get install). The defaults fit the capture of
# the README demo (tests/wireshark/demo_capture, docs/capture.md "Tests").
set -eu
if [ "${1:-}" = "--inside" ]; then
  shift
  cap=$1 out=$2 filter=$3 frame=$4
  wireshark -X "lua_script:$LUA" -r "$cap" -Y "$filter" -g "$frame" >"$HOME/wireshark.log" 2>&1 &
  pid=$!
  name=$(basename "$cap")
  i=0
  until xdotool search --name "$name" >/dev/null 2>&1; do
    i=$((i + 1))
    [ $i -lt 60 ] || { echo "no Wireshark window after 60 s" >&2; kill $pid; exit 1; }
    sleep 1
  done
  sleep 3  # the window is mapped; let it dissect and paint
  win=$(xdotool search --name "$name" | head -1)
  xdotool windowsize "$win" 1600 1000 windowmove "$win" 0 0
  sleep 1
  # The details pane: first row (Frame), down to the fourth (DP), expand it with its subtrees.
  xdotool mousemove 200 536 click 1
  sleep 0.5
  xdotool key Down Down Down shift+Right
  sleep 2
  import -window root "$out.full.png"
  convert "$out.full.png" PNG8:"$out"
  rm -f "$out.full.png"
  kill $pid
  exit 0
fi
[ $# -ge 2 ] || { echo "usage: $0 CAPTURE OUT.png [FILTER] [FRAME]" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
home=$(mktemp -d)
trap 'rm -rf "$home"' EXIT
mkdir -p "$home/.config/wireshark"
cat >"$home/.config/wireshark/recent" <<'RECENT'
gui.geometry_main_x: 0
gui.geometry_main_y: 0
gui.geometry_main_width: 1600
gui.geometry_main_height: 1000
gui.geometry_main_maximized: FALSE
gui.geometry_main_upper_pane: 430
gui.geometry_main_lower_pane: 480
gui.byte_view_show: FALSE
gui.time_format: RELATIVE
RECENT
cat >"$home/.config/wireshark/preferences" <<'PREFS'
gui.column.format: "No.", "%m", "Time", "%t", "Source", "%s", "Destination", "%d", "Protocol", "%p", "Info", "%i"
PREFS
out=$(cd "$(dirname "$2")" && pwd)/$(basename "$2")
cap=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
HOME=$home XDG_RUNTIME_DIR=$home LUA=$here/candp2.lua timeout 180 \
  xvfb-run -a -s "-screen 0 1600x1000x24" "$0" --inside "$cap" "$out" \
  "${3:-candp2.note || can || dp.service != Data_Exchange || dp.changed}" "${4:-443}"
echo "$out"
