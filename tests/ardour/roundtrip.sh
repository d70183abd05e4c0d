#!/usr/bin/env bash
# Struck.vst3 in Ardour 7, headless (ardour7-lua, its dummy backend), for
# every instrument: a new session with Struck on a MIDI track is saved and
# rendered; a second Ardour process reopens it, as a user would, and renders
# it again. The two renders must be the same bytes and sound, the parameters
# set away from their defaults must come back, and reopening must not flood
# the plugin's event lists (the wrapper says so in its log when one grows).
# Then automation: a piano session whose hammer mass steps from 0.6 to 1.7
# at the sample of its one note is bounced, reopened and bounced again, and
# a session with the mass at 1.7 throughout is bounced: all three must be the
# same samples (not late, every bounce alike). The same step with E4 struck a
# second before it must be a session with the mass at 0.6 throughout up to
# where Ardour hands the step over: Ardour 7.3's bounce applies a plugin's
# automation once per 8192-sample cycle, at the start of the cycle that holds
# the point (here 5888 samples early); within a block the plugin takes a
# change at its sample (tests/plugin_host.rs, in a CLAP host).
#
# usage: roundtrip.sh STRUCK_VST3_BUNDLE LOG_DIR
set -euo pipefail
bundle=$(realpath "$1")
logs=$(realpath -m "$2")
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$logs"
mkdir -p "$logs"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Ardour's settings, plugin cache and export formats in a folder of their own.
export HOME=$work/home XDG_CONFIG_HOME=$work/config XDG_CACHE_HOME=$work/cache XDG_DATA_HOME=$work/data
mkdir -p "$HOME" "$XDG_CONFIG_HOME" "$XDG_CACHE_HOME" "$XDG_DATA_HOME"
mkdir -p "$work/vst3"
cp -r "$bundle" "$work/vst3/"
export VST3_PATH=$work/vst3

# ardour7-lua only reads the plugin cache: index the bundle first. Ardour
# trusts an entry only if it is newer than the plugin (one-second times).
so=$(find "$work/vst3" -name '*.so' | head -n 1)
while [ "$(date +%s)" -le "$(stat -c %Y "$so")" ]; do sleep 0.2; done
if ! LD_LIBRARY_PATH=/usr/lib/ardour7 /usr/lib/ardour7/ardour-vst3-scanner -f "$work/vst3/$(basename "$bundle")" \
  >"$logs/scan.log" 2>&1; then
  echo "ardour: the VST3 scanner refused Struck (see $logs/scan.log)"
  exit 1
fi

instruments=(piano fortepiano santoor dulcimer cimbalom clavichord harpsichord)
for i in "${!instruments[@]}"; do
  name=${instruments[$i]}
  export STRUCK_INSTRUMENT=$i NICE_LOG=$logs/$name-plugin.log
  for step in create reopen; do
    out=$logs/$name-$step.log
    if ! ardour7-lua "$here/struck_session.lua" "$step" "$work/$name" "$step" >"$out" 2>&1; then
      echo "ardour: $name: $step failed (see $out)"
      tail -n 5 "$out"
      exit 1
    fi
  done
  first=$(grep -h '^struck-session: params:' "$logs/$name-create.log")
  again=$(grep -h '^struck-session: params:' "$logs/$name-reopen.log")
  if [ "$first" != "$again" ]; then
    echo "ardour: $name: the parameters did not come back: '$first', reopened '$again'"
    exit 1
  fi
  if grep -q 'filled up' "$NICE_LOG" 2>/dev/null; then
    echo "ardour: $name: an event list grew on the audio thread (see $NICE_LOG)"
    exit 1
  fi
  mapfile -t first_files < <(sed -n 's/^struck-session: rendered: //p' "$logs/$name-create.log")
  mapfile -t again_files < <(sed -n 's/^struck-session: rendered: //p' "$logs/$name-reopen.log")
  if [ "${#first_files[@]}" -ne 2 ] || [ "${#again_files[@]}" -ne 2 ]; then
    echo "ardour: $name: a render is missing its two channels"
    exit 1
  fi
  for c in 0 1; do
    python3 "$here/same_sound.py" "${first_files[$c]}" "${again_files[$c]}" "$name, channel $((c + 1))"
  done
done

# Automation at the sample, and bounces alike.
export STRUCK_INSTRUMENT=0 NICE_LOG=$logs/automation-plugin.log
for step in "automated automate" "automated reopen" "steady steady" "early automate-early" "light light-early"; do
  read -r session mode <<<"$step"
  out=$logs/automation-$mode.log
  if ! ardour7-lua "$here/struck_session.lua" "$mode" "$work/$session" "$mode" >"$out" 2>&1; then
    echo "ardour: automation: $mode failed (see $out)"
    tail -n 5 "$out"
    exit 1
  fi
done
mapfile -t automated < <(sed -n 's/^struck-session: rendered: //p' "$logs/automation-automate.log")
mapfile -t again < <(sed -n 's/^struck-session: rendered: //p' "$logs/automation-reopen.log")
mapfile -t steady < <(sed -n 's/^struck-session: rendered: //p' "$logs/automation-steady.log")
mapfile -t early < <(sed -n 's/^struck-session: rendered: //p' "$logs/automation-automate-early.log")
mapfile -t light < <(sed -n 's/^struck-session: rendered: //p' "$logs/automation-light-early.log")
for c in 0 1; do
  python3 "$here/same_sound.py" "${automated[$c]}" "${again[$c]}" "automated piano, channel $((c + 1))" \
    "the automated session's second bounce"
  python3 "$here/same_sound.py" "${automated[$c]}" "${steady[$c]}" "automated piano, channel $((c + 1))" \
    "the mass stepped at the note's sample against the mass there throughout"
  # E4 struck at 1 s with the light mass, up to where Ardour hands the step
  # to the plugin: the start of the bounce's 8192-sample cycle that holds it
  # (frame 90112; Ardour 7.3 applies a plugin's automation per cycle there).
  python3 "$here/same_sound.py" "${early[$c]}" "${light[$c]}" "automated piano, channel $((c + 1))" \
    "up to the cycle holding the step, the light mass throughout" 90112
done
