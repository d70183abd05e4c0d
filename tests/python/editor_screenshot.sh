#!/usr/bin/env bash
# Open the standalone's egui editor under Xvfb, take a screenshot, check it is not blank.
#
# Usage: editor_screenshot.sh STRUCK_BIN [OUT.png]
#   OUT.png defaults to target/editor.png; the editor's window alone is also written
#   to OUT-window.png (cropped from the screenshot). The dummy backend has no MIDI, so
#   the live view shows its idle placeholders; for a picture with a note sounding (the
#   one in docs/editor.png) use `jack_session.py STRUCK_BIN --screenshot OUT.png`.
#
# Steps: starts `Xvfb :N -screen 0 1280x900x24` (N = $STRUCK_XVFB_DISPLAY or 99, the next
# free number if that one is taken), runs `DISPLAY=:N STRUCK_BIN -b dummy`, waits for its
# top-level window to be mapped (xwininfo), waits until the picture has settled (two
# screenshots in a row, 0.5 s apart, above the threshold and within 10% of each other
# in colour count; at most 30 s), saves it with
# `import -window root`, then stops struck (SIGTERM: it must exit within 5 s with status 0
# or 143) and Xvfb.
# Then plays it with no MIDI device (xdotool): holds the computer's key A
# (C4), then clicks and holds a key of the panel's keyboard, a screenshot each
# time (the first kept as OUT-played.png).
# Checks: the window appears within $STRUCK_WINDOW_TIMEOUT s (default 60); the screenshot
# has at least $STRUCK_MIN_COLOURS distinct colours (default 64; a black or empty screen
# has 1, a flat window a handful; text and widgets give hundreds), and so does the window
# alone; the key held lights up in the keyboard each time, and the string view
# draws the struck string. Exit status 0 on success, 1 with a last line "editor_screenshot: FAIL: <reason>".
#
# Needs: Xvfb (xvfb), xwininfo and xdpyinfo (x11-utils), import/identify/convert
# (imagemagick), xdotool. xvfb pulls in Mesa's software OpenGL, which the egui editor uses.
set -u

me=editor_screenshot
say() { echo "$me: $*"; }

if [ $# -lt 1 ] || [ $# -gt 2 ]; then
    echo "usage: $0 STRUCK_BIN [OUT.png]" >&2
    exit 2
fi
struck=$1
out=${2:-target/editor.png}
window_out="${out%.png}-window.png"
min_colours=${STRUCK_MIN_COLOURS:-64}
window_timeout=${STRUCK_WINDOW_TIMEOUT:-60}

workdir=$(mktemp -d /tmp/struck-xvfb.XXXXXX)
xvfb_pid=
struck_pid=
failure=

fail() {
    failure=$1
    exit 1
}

cleanup() {
    local status=$?
    if [ -n "$struck_pid" ] && kill -0 "$struck_pid" 2>/dev/null; then
        kill -TERM "$struck_pid" 2>/dev/null
        for _ in $(seq 50); do kill -0 "$struck_pid" 2>/dev/null || break; sleep 0.1; done
        kill -KILL "$struck_pid" 2>/dev/null
        wait "$struck_pid" 2>/dev/null
    fi
    if [ -n "$xvfb_pid" ] && kill -0 "$xvfb_pid" 2>/dev/null; then
        kill -TERM "$xvfb_pid" 2>/dev/null
        for _ in $(seq 50); do kill -0 "$xvfb_pid" 2>/dev/null || break; sleep 0.1; done
        kill -KILL "$xvfb_pid" 2>/dev/null
        wait "$xvfb_pid" 2>/dev/null
    fi
    if [ -n "$failure" ]; then
        for log in struck xvfb; do
            if [ -s "$workdir/$log.log" ]; then
                echo "--- last lines of $log's output:"
                tail -n 15 "$workdir/$log.log" | sed 's/^/    /'
            fi
        done
        echo "$me: FAIL: $failure"
        status=1
    fi
    rm -rf "$workdir"
    exit $status
}
trap cleanup EXIT
trap 'failure="interrupted"; exit 1' INT TERM

for tool in Xvfb xwininfo xdpyinfo import identify convert xdotool; do
    command -v "$tool" >/dev/null || fail "$tool not found (Debian: xvfb, x11-utils, imagemagick, xdotool)"
done
[ -x "$struck" ] || fail "$struck is not an executable"
mkdir -p "$(dirname "$out")" || fail "cannot create $(dirname "$out")"

# --- Xvfb on a free display number
n=${STRUCK_XVFB_DISPLAY:-99}
for _ in $(seq 20); do
    [ -e "/tmp/.X$n-lock" ] || [ -e "/tmp/.X11-unix/X$n" ] || break
    n=$((n + 1))
done
display=":$n"
Xvfb "$display" -screen 0 1280x900x24 -nolisten tcp >"$workdir/xvfb.log" 2>&1 &
xvfb_pid=$!
for _ in $(seq 100); do
    DISPLAY=$display xdpyinfo >/dev/null 2>&1 && break
    kill -0 "$xvfb_pid" 2>/dev/null || fail "Xvfb $display exited at start"
    sleep 0.1
done
DISPLAY=$display xdpyinfo >/dev/null 2>&1 || fail "Xvfb $display did not come up within 10 s"
say "Xvfb up on $display (1280x900x24)"

# --- the standalone, dummy backend (no audio device, no MIDI)
DISPLAY=$display "$struck" -b dummy >"$workdir/struck.log" 2>&1 &
struck_pid=$!
say "started DISPLAY=$display $struck -b dummy (pid $struck_pid)"

# The largest mapped top-level window of at least 200x150: "id w h x y".
find_window() {
    DISPLAY=$display xwininfo -root -children 2>/dev/null |
        sed -n 's/^ *\(0x[0-9a-f]*\) .* \([0-9]*\)x\([0-9]*\)+\(-\{0,1\}[0-9]*\)+\(-\{0,1\}[0-9]*\) .*$/\1 \2 \3 \4 \5/p' |
        while read -r id w h x y; do
            [ "$w" -ge 200 ] && [ "$h" -ge 150 ] || continue
            DISPLAY=$display xwininfo -id "$id" 2>/dev/null | grep -q 'Map State: IsViewable' || continue
            echo "$((w * h)) $id $w $h $x $y"
        done | sort -n | tail -n 1 | cut -d' ' -f2-
}

win=
start=$(date +%s)
while :; do
    win=$(find_window)
    [ -n "$win" ] && break
    if ! kill -0 "$struck_pid" 2>/dev/null; then
        wait "$struck_pid"
        fail "struck exited with status $? before its window appeared"
    fi
    [ $(($(date +%s) - start)) -ge "$window_timeout" ] &&
        fail "no editor window within $window_timeout s"
    sleep 0.2
done
read -r win_id win_w win_h win_x win_y <<<"$win"
win_name=$(DISPLAY=$display xwininfo -id "$win_id" | sed -n 's/^xwininfo: Window id: [^ ]* //p')
say "window $win_id $win_name ${win_w}x${win_h}+${win_x}+${win_y} after $(($(date +%s) - start)) s"

colours() { identify -format '%k' "$1" 2>/dev/null || echo 0; }

# Let it draw: take screenshots until the colour count is above the threshold and the
# same twice in a row (the live view moves, so "the same" is within 10%), at most 30 s.
shot="$workdir/shot.png"
prev=0
k=0
settled=
for _ in $(seq 60); do
    sleep 0.5
    kill -0 "$struck_pid" 2>/dev/null || break
    DISPLAY=$display import -window root "$shot" 2>"$workdir/import.log" || continue
    k=$(colours "$shot")
    if [ "$k" -ge "$min_colours" ] && [ $((k * 10)) -ge $((prev * 9)) ] && [ $((prev * 10)) -ge $((k * 9)) ]; then
        settled=1
        break
    fi
    prev=$k
done
[ -s "$shot" ] || fail "import could not take a screenshot: $(cat "$workdir/import.log")"
cp "$shot" "$out" || fail "cannot write $out"
convert "$out" -crop "${win_w}x${win_h}+${win_x}+${win_y}" +repage "$window_out" ||
    fail "cannot crop the window to $window_out"

# --- play it as a newcomer would, with no MIDI device: the computer's key A
# (C4) held, then a click on the panel's keyboard held. Each time the key
# lights up in the keyboard's held colour (235,150,70) and the string view
# draws the string where it said "play a key".
held_pixels() {
    # Pixels of the held colour in the window's lowest 110 rows (the keyboard).
    convert "$1" -crop "${win_w}x110+${win_x}+$((win_y + win_h - 110))" +repage \
        -fill black +opaque 'rgb(235,150,70)' -fill white -opaque 'rgb(235,150,70)' \
        -format '%[fx:round(mean*w*h)]' info: 2>/dev/null || echo 0
}
string_view_colours() {
    convert "$1" -crop "600x150+$((win_x + 360))+$((win_y + 40))" +repage -format '%k' info: 2>/dev/null || echo 0
}
idle_held=$(held_pixels "$out")
idle_string=$(string_view_colours "$out")
played=
if kill -0 "$struck_pid" 2>/dev/null; then
    DISPLAY=$display xdotool windowfocus "$win_id" 2>/dev/null
    DISPLAY=$display xdotool keydown --window "$win_id" a
    sleep 1
    DISPLAY=$display import -window root "$workdir/typed.png" 2>>"$workdir/import.log"
    DISPLAY=$display xdotool keyup --window "$win_id" a
    sleep 0.5
    # A click near the front edge of a key right of the keyboard's middle (it
    # ends some 18 pixels above the window's bottom).
    DISPLAY=$display xdotool mousemove --window "$win_id" $((win_w - 160)) $((win_h - 30)) mousedown 1
    sleep 1
    DISPLAY=$display import -window root "$workdir/clicked.png" 2>>"$workdir/import.log"
    DISPLAY=$display xdotool mouseup 1
    played=1
fi
if [ -n "$played" ]; then
    typed_held=$(held_pixels "$workdir/typed.png")
    clicked_held=$(held_pixels "$workdir/clicked.png")
    typed_string=$(string_view_colours "$workdir/typed.png")
    cp "$workdir/typed.png" "${out%.png}-played.png" 2>/dev/null
    say "held-colour pixels: idle $idle_held, key A down $typed_held, clicked $clicked_held; string view colours: idle $idle_string, played $typed_string"
fi

# --- stop struck: SIGTERM, it must be gone within 5 s
alive_before_stop=0
if kill -0 "$struck_pid" 2>/dev/null; then
    alive_before_stop=1
    kill -TERM "$struck_pid"
    t0=$(date +%s%N)
    for _ in $(seq 50); do kill -0 "$struck_pid" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$struck_pid" 2>/dev/null; then
        fail "struck still running 5 s after SIGTERM (the editor window does not close on SIGTERM)"
    fi
    wait "$struck_pid"
    struck_status=$?
    struck_pid=
    ms=$((($(date +%s%N) - t0) / 1000000))
    say "struck exited $ms ms after SIGTERM with status $struck_status"
    case $struck_status in
        0 | 143) ;;
        *) fail "struck exited with status $struck_status after SIGTERM" ;;
    esac
fi

# --- the checks
total=$(colours "$out")
in_window=$(colours "$window_out")
mean=$(identify -format '%[fx:mean]' "$window_out" 2>/dev/null || echo 0)
say "screenshot $out: $total colours; window $window_out: $in_window colours, mean level $mean"
[ "$alive_before_stop" = 1 ] || fail "struck died while its window was open"
[ -n "$settled" ] || say "warning: the picture had not settled after 30 s"
[ "$total" -ge "$min_colours" ] ||
    fail "screenshot has only $total colours (< $min_colours): blank or unrendered editor"
[ "$in_window" -ge "$min_colours" ] ||
    fail "editor window has only $in_window colours (< $min_colours): blank or unrendered"
[ -n "$played" ] || fail "struck was gone before it could be played"
[ "$idle_held" -lt 20 ] || fail "$idle_held pixels of held keys before any was played"
[ "$typed_held" -ge 50 ] || fail "the computer's key A lit no key ($typed_held pixels)"
[ "$clicked_held" -ge 50 ] || fail "a click on the panel's keyboard lit no key ($clicked_held pixels)"
[ "$typed_string" -gt $((idle_string * 2)) ] ||
    fail "the string view did not draw a string when C4 was played ($idle_string colours idle, $typed_string played)"
say "PASS"
