#!/usr/bin/env python3
"""Struck's VST3 in a real host: pedalboard (Spotify's Python wrapper of JUCE's
plugin hosting) loads the bundle as an instrument, lists its parameters and
renders a few notes with a sustain pedal and a pitch bend.

It fails (exit status 1, one line per failure) when the plugin is not an
instrument, when a parameter of EXPECTED_PARAMETERS is missing, or when the
audio is silent, not finite, blown up, or sounds before the first note. The
same notes are then rendered with load smoothing on and off: it fails unless
the plugin reports 128 samples of latency at 48 kHz with it on and none with
it off, and sounds the same samples either way, later by what it reports
(pedalboard does not make up an instrument's latency); and switched on again
in the same instance, it reports and sounds as it first did.

Then, in a child process logging to a file, the plugin is handed damaged
states (as a damaged or hand-edited session would): every choice out of
range, numbers beyond their ranges, values of the wrong type, persisted
fields that do not read, and states that are truncated, random, empty or not
JSON at all. It fails unless the host lives through every one, the plugin
saves its state again, the damaged values are back at their defaults (a
state refused whole changes nothing), a note still sounds, finite, and each
repaired value has its line in the plugin's log.

Usage: pedalboard_check.py PATH/TO/Struck.vst3 [--wav OUT.wav]
       pedalboard_check.py --self-test   (the checks on made-up audio)
(`cargo xtask test` runs it in a venv under target/ with pedalboard pinned.)
"""

import argparse
import json
import os
import random
import re
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np
import pedalboard

# The plugin's name as the host sees it.
EXPECTED_PLUGIN_NAME = "Struck"

# Parameters the host must see, by their display names (not pedalboard's
# snake_case keys). A name missing from the plugin fails the check. The names are
# not final: this is the list the plugin showed when the check was written; keep
# it in step with the plugin's parameters.
EXPECTED_PARAMETERS = [
    "Instrument",
    "Touch min",
    "Touch max",
    "Touch curve",
    "Hammer mass",
    "Felt stiffness K",
    "Felt exponent alpha",
    "Strike position",
    "Damping",
    "Unison detune",
    "Felt hysteresis",
    "Polyphony",
    "Bend range",
    "Level",
    "Sympathetic resonance",
    "Phantom partials",
    "Key noise",
    "Damper noise",
    "Pedal noise",
]

SAMPLE_RATE_HZ = 48_000
DURATION_S = 3.0
# Nothing is played before this: the output must be silent until then.
FIRST_NOTE_S = 0.25
BLOCK_SIZE = 512

# The latency load smoothing reports (2.7 ms: 128 samples at 48 kHz), and none
# without it.
SMOOTHED_LATENCY_SAMPLES = 128

# Silence, sound and blow-up thresholds, in full-scale units.
SILENT_PEAK = 1e-4  # -80 dBFS
AUDIBLE_PEAK = 1e-3  # -60 dBFS
BLOWN_UP_PEAK = 10.0  # +20 dBFS

# nice-plug's VST3 wrapper adds 16 x 130 hidden, read-only parameters for MIDI
# CCs, channel pressure and pitch bend ("MIDI Ch. 1 CC 64"). pedalboard's own
# filter only knows JUCE's "MIDI CC " names, and building its Python parameter
# objects for these 2080 would be slow, so they are filtered here first.
HIDDEN_MIDI_PARAMETER = re.compile(r"^(MIDI Ch\. \d+ (CC \d+|Channel Pressure|Pitch Bend)|MIDI CC \d+)")


def is_hidden_midi_parameter(name: str) -> bool:
    return HIDDEN_MIDI_PARAMETER.match(name) is not None


def midi_events():
    """A chord arpeggiated from FIRST_NOTE_S, the sustain pedal, a pitch bend."""

    def note_on(key, velocity, t):
        return (bytes([0x90, key, velocity]), t)

    def note_off(key, t):
        return (bytes([0x80, key, 0]), t)

    def sustain(on, t):
        return (bytes([0xB0, 64, 127 if on else 0]), t)

    def pitch_bend(value_14bit, t):
        return (bytes([0xE0, value_14bit & 0x7F, value_14bit >> 7]), t)

    t0 = FIRST_NOTE_S
    return [
        note_on(60, 100, t0),
        note_on(64, 80, t0 + 0.3),
        note_on(67, 110, t0 + 0.6),
        sustain(True, t0 + 0.8),
        note_off(60, t0 + 1.0),
        note_off(64, t0 + 1.0),
        note_off(67, t0 + 1.0),
        pitch_bend(0x2000 + 0x800, t0 + 1.2),  # a quarter of the range up
        pitch_bend(0x2000, t0 + 1.6),  # back to the centre
        sustain(False, t0 + 2.0),
        note_on(48, 127, t0 + 2.1),
        note_off(48, t0 + 2.5),
    ]


def parameters(plugin):
    """The plugin's own parameters (pedalboard's low-level list, hidden MIDI ones left out)."""
    return [p for p in plugin._parameters if not is_hidden_midi_parameter(p.name)]


def missing_names(expected, present):
    present = set(present)
    return [name for name in expected if name not in present]


def check_audio(audio):
    """Failures of the rendered audio, as sentences (an empty list when it is fine)."""
    failures = []
    if audio.ndim != 2 or audio.shape[0] != 2:
        return [f"expected stereo audio of shape (2, n), got {audio.shape}"]
    expected_frames = int(round(DURATION_S * SAMPLE_RATE_HZ))
    if abs(audio.shape[1] - expected_frames) > BLOCK_SIZE:
        failures.append(f"expected about {expected_frames} frames, got {audio.shape[1]}")
    finite = np.isfinite(audio)
    if not finite.all():
        bad = np.argwhere(~finite)[0]
        failures.append(
            f"{np.count_nonzero(~finite)} samples are NaN or infinite "
            f"(the first in channel {bad[0]} at {bad[1] / SAMPLE_RATE_HZ:.4f} s)"
        )
        audio = np.nan_to_num(audio, nan=0.0, posinf=0.0, neginf=0.0)
    first = int(FIRST_NOTE_S * SAMPLE_RATE_HZ)
    before = float(np.max(np.abs(audio[:, :first]))) if first > 0 else 0.0
    after = float(np.max(np.abs(audio[:, first:])))
    if before > SILENT_PEAK:
        failures.append(f"sound before the first note: peak {before:.3g} in the first {FIRST_NOTE_S} s")
    if after < AUDIBLE_PEAK:
        failures.append(f"silent: the peak after the first note is {after:.3g} (below {AUDIBLE_PEAK})")
    if after > BLOWN_UP_PEAK:
        failures.append(f"blown up: peak {after:.3g} (above {BLOWN_UP_PEAK})")
    for channel in range(audio.shape[0]):
        if float(np.max(np.abs(audio[channel, first:]))) < AUDIBLE_PEAK:
            failures.append(f"channel {channel} is silent")
    return failures


def latency_failures(smoothed, plain, reported_smoothed, reported_plain):
    """Failures of load smoothing's renders (`smoothed`, `plain`: the same
    notes with it on and off) and the latencies the plugin reported, as
    sentences."""
    failures = []
    if reported_smoothed != SMOOTHED_LATENCY_SAMPLES:
        failures.append(
            f"with load smoothing on the plugin reports {reported_smoothed} samples of latency, "
            f"expected {SMOOTHED_LATENCY_SAMPLES} at {SAMPLE_RATE_HZ} Hz"
        )
    if reported_plain != 0:
        failures.append(f"with load smoothing off the plugin reports {reported_plain} samples of latency, expected 0")
    if smoothed.shape != plain.shape:
        return failures + [f"the renders with load smoothing on and off differ in shape: {smoothed.shape}, {plain.shape}"]
    late = reported_smoothed - reported_plain
    if late == 0 and np.array_equal(smoothed, plain):
        return failures
    if 0 < late < smoothed.shape[-1]:
        silent_at_first = not np.any(smoothed[:, :late])
        if silent_at_first and np.array_equal(smoothed[:, late:], plain[:, :-late]):
            return failures
    largest = float(np.max(np.abs(smoothed.astype(np.float64) - plain)))
    return failures + [
        f"with load smoothing on the plugin does not sound the samples it sounds without it, "
        f"{late} samples later (the reported latency; largest difference {largest:.3g})"
    ]


def self_test():
    """The checks themselves, on made-up audio (no plugin needed)."""
    n = int(DURATION_S * SAMPLE_RATE_HZ)
    t = np.arange(n) / SAMPLE_RATE_HZ
    tone = np.where(t >= FIRST_NOTE_S, 0.3 * np.sin(2 * np.pi * 440 * t) * np.exp(-(t - FIRST_NOTE_S)), 0.0)
    good = np.stack([tone, tone]).astype(np.float32)
    assert check_audio(good) == [], check_audio(good)
    nan = good.copy()
    nan[1, n // 2] = np.nan
    assert any("NaN" in f for f in check_audio(nan))
    assert any("silent" in f for f in check_audio(np.zeros_like(good)))
    early = good.copy()
    early[0, 10] = 0.5
    assert any("before the first note" in f for f in check_audio(early))
    assert any("blown up" in f for f in check_audio(good * 100))
    assert any("channel 1 is silent" in f for f in check_audio(np.stack([tone, 0 * tone])))
    assert any("shape" in f for f in check_audio(good[:1]))
    late = SMOOTHED_LATENCY_SAMPLES
    delayed = np.concatenate([np.zeros((2, late), np.float32), good[:, :-late]], axis=1)
    assert latency_failures(delayed, good, late, 0) == [], latency_failures(delayed, good, late, 0)
    assert any("does not sound" in f for f in latency_failures(good, good, late, 0))
    assert any("does not sound" in f for f in latency_failures(delayed, good, late - 1, 0))
    assert any("does not sound" in f for f in latency_failures(delayed * 1.001, good, late, 0))
    # No latency reported and no delay: only the report fails.
    assert latency_failures(good, good, 0, 0) == [
        f"with load smoothing on the plugin reports 0 samples of latency, expected {late} at {SAMPLE_RATE_HZ} Hz"
    ]
    assert any("does not sound" in f for f in latency_failures(delayed, good, 0, 0))
    assert any("off the plugin reports 5" in f for f in latency_failures(delayed, good, late, 5))
    assert missing_names(["A", "B"], ["B", "C"]) == ["A"]
    assert is_hidden_midi_parameter("MIDI Ch. 16 CC 127")
    assert is_hidden_midi_parameter("MIDI Ch. 1 Pitch Bend")
    assert is_hidden_midi_parameter("MIDI Ch. 3 Channel Pressure")
    assert not is_hidden_midi_parameter("Level")
    assert not is_hidden_midi_parameter("MIDI learn")
    data = bytes(range(256)) + b"Struck"
    assert juce_base64_decode(juce_base64_encode(data)) == data
    assert juce_base64_encode(b"") == "0." and juce_base64_decode("0.") == b""
    xml = '<?xml version="1.0"?> <VST3PluginState><IComponent>0.</IComponent></VST3PluginState>'
    assert component_state(with_component_state(xml, data)) == (data, xml.replace("0.", juce_base64_encode(data)))
    default = {
        "version": "1",
        "params": {"inst": {"string": "piano"}, "gain": {"f32": 0.0}, "poly": {"i32": 64}, "mpe": {"bool": False}},
        "fields": {"scala-scale": "null", "scala-files": '""', "state-version": "1"},
    }
    cases = damaged_states(default)
    assert len({name for name, _, _, _ in cases}) == len(cases)
    for name, data, ids, refused in cases:
        assert data != json.dumps(default).encode(), name
        assert refused or ids, name
        if not refused:
            state = json.loads(data)
            for i in ids:
                group = "params" if i in default["params"] else "fields"
                assert state[group][i] != default[group][i], (name, i)
    one = cases[0]
    assert one[2] == ["inst"] and json.loads(one[1])["params"]["inst"] == {"i32": 99}
    assert state_failures("x", default, default, ["inst"], False) == []
    bad = json.loads(json.dumps(default))
    bad["params"]["gain"] = {"f32": 3.0}
    assert state_failures("x", default, bad, ["inst"], False) == []
    assert any("gain" in f for f in state_failures("x", default, bad, [], True))
    assert any("gain" in f for f in state_failures("x", default, bad, ["gain"], False))
    said = ' WARN Struck: the saved "inst" (Instrument): choice 99 is not one of 7; it is set to its default, "piano"'
    assert log_failures("x", said, ["inst"]) == []
    assert log_failures("x", said, ["inst", "temp"]) == ["x: no line in the log for temp"]
    print("pedalboard check self-test: passed")


def render(plugin):
    """The notes of midi_events() through the plugin, and the latency it then reports."""
    audio = plugin(
        midi_events(),
        duration=DURATION_S,
        sample_rate=SAMPLE_RATE_HZ,
        num_channels=2,
        buffer_size=BLOCK_SIZE,
    )
    return np.asarray(audio), plugin.reported_latency_samples


# --- Damaged states -----------------------------------------------------------

# JUCE's VST3 host (pedalboard's) wraps the plugin's state in its own: "VC2!",
# the XML's length (little-endian u32), the XML, a NUL; the plugin's bytes are
# the <IComponent> element's text in JUCE's MemoryBlock base64 ("size.chars",
# six bits a character, least significant first, from this alphabet).
JUCE_BASE64 = ".ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+"
ICOMPONENT = re.compile(r"<IComponent>([^<]*)</IComponent>")


def juce_base64_decode(text):
    size, _, chars = text.partition(".")
    size = int(size)
    n = 0
    for i, c in enumerate(chars):
        n |= JUCE_BASE64.index(c) << (6 * i)
    return (n & ((1 << (8 * size)) - 1)).to_bytes(size, "little")


def juce_base64_encode(data):
    n = int.from_bytes(data, "little")
    chars = (len(data) * 8 + 5) // 6
    return f"{len(data)}." + "".join(JUCE_BASE64[(n >> (6 * i)) & 63] for i in range(chars))


def component_state(raw):
    """The plugin's own state bytes inside pedalboard's raw_state, and the XML around them."""
    if raw[:4] != b"VC2!":
        raise ValueError(f"raw_state does not start with VC2! ({raw[:8]!r})")
    (length,) = struct.unpack("<I", raw[4:8])
    xml = raw[8 : 8 + length].decode()
    found = ICOMPONENT.search(xml)
    if not found:
        raise ValueError("raw_state has no <IComponent>")
    return juce_base64_decode(found.group(1)), xml


def with_component_state(xml, component):
    """pedalboard's raw_state holding `component` as the plugin's state."""
    body = ICOMPONENT.sub(lambda _: f"<IComponent>{juce_base64_encode(component)}</IComponent>", xml).encode()
    return b"VC2!" + struct.pack("<I", len(body)) + body + b"\0"


def param_kinds(state):
    """Parameter ids by the type their state holds: f32, i32, bool, string (a choice)."""
    kinds = {}
    for pid, value in state["params"].items():
        (kind,) = value.keys()
        kinds.setdefault(kind, []).append(pid)
    return kinds


def damaged_states(default):
    """(name, bytes, ids of the parameters and fields it damages, refused whole)
    for every kind of damage, made from the plugin's default state (a dict)."""
    kinds = param_kinds(default)

    def damaged(name, params=None, fields=None, text=None):
        state = json.loads(json.dumps(default))
        state["params"].update(params or {})
        state["fields"].update(fields or {})
        data = (text if text is not None else json.dumps(state)).encode()
        return (name, data, sorted((params or {}).keys()) + sorted((fields or {}).keys()), False)

    def refused(name, data):
        return (name, data, [], True)

    def every(kind, value):
        return {pid: value for pid in kinds.get(kind, [])}

    good = json.dumps(default)
    rng = random.Random(1234)
    return [
        damaged("every choice at index 99", every("string", {"i32": 99})),
        damaged("every choice at index -1", every("string", {"i32": -1})),
        damaged("every choice an unknown id", every("string", {"string": "organ"})),
        damaged(
            "every number far above its range",
            {**every("f32", {"f32": 3e38}), **every("i32", {"i32": 2**31 - 1})},
        ),
        damaged(
            "every number below its range",
            {**every("f32", {"f32": -1e30}), **every("i32", {"i32": -(2**31)})},
        ),
        damaged(
            "every value of the wrong type",
            {
                **every("f32", {"string": "loud"}),
                **every("i32", {"f32": 1.5}),
                **every("bool", {"i32": 1}),
                **every("string", {"bool": True}),
            },
        ),
        damaged(
            "persisted fields of the wrong type",
            fields={"scala-scale": "42", "scala-files": "[1, 2]", "state-version": '"one"'},
        ),
        damaged("a Scala scale that cannot play", fields={"scala-scale": '{"degrees_cents": [700.0, -5.0]}'}),
        damaged("a persisted field that is not JSON", fields={"scala-scale": '{"degrees_cents": [12'}),
        refused("a number no f32 holds (1e300)", good.replace('"f32": 0.0', '"f32": 1e300', 1).encode()),
        refused(
            "NaN and Infinity",
            good.replace('"f32": 1.0', '"f32": NaN', 1).replace('"f32": 0.0', '"f32": Infinity').encode(),
        ),
        refused("a value that is not tagged", good.replace('{"f32": 0.0}', '"loud"', 1).encode()),
        refused("the state cut in half", good.encode()[: len(good) // 2]),
        refused("random bytes", bytes(rng.randrange(256) for _ in range(600))),
        refused("an empty state", b""),
        refused("JSON that is not a state", b"[1, 2, 3]"),
    ]


# How long the plugin's log may take to reach its file, s.
LOG_WAIT_S = 10.0


def short_render(plugin):
    """Half a second with C4 struck at 0.05 s, through the plugin as it
    stands (pedalboard's reset between renders takes seconds: not done)."""
    audio = plugin(
        [(bytes([0x90, 60, 100]), 0.05), (bytes([0x80, 60, 0]), 0.4)],
        duration=0.5,
        sample_rate=SAMPLE_RATE_HZ,
        num_channels=2,
        buffer_size=BLOCK_SIZE,
        reset=False,
    )
    return np.asarray(audio)


def state_failures(name, default, saved, damaged_ids, refused):
    """Failures of the state saved after a damaged one was loaded: every value
    it damaged (all of them, when refused whole) must be back at its default."""
    failures = []
    for pid in damaged_ids if not refused else default["params"]:
        group = "params" if pid in default["params"] else "fields"
        got = saved.get(group, {}).get(pid)
        if got != default[group][pid]:
            failures.append(f"{name}: {pid} is {got!r} after loading it, not its default {default[group][pid]!r}")
    return failures


def log_failures(name, said, damaged_ids):
    """Failures of what the plugin logged loading a damaged state: a line for
    each value it damaged, naming it and its default."""
    lines = [line for line in said.splitlines() if "Struck: the saved" in line]
    return [
        f"{name}: no line in the log for {pid}"
        for pid in damaged_ids
        if not any(f'"{pid}"' in line and "set to its default" in line for line in lines)
    ]


def fuzz_state(path):
    """Load every damaged state into the plugin; return the failures.
    Run in its own process with NICE_LOG naming a file (the plugin's log)."""
    log = os.environ.get("NICE_LOG", "")
    if not log or log in ("stderr", "windbg"):
        return ["--fuzz-state needs NICE_LOG set to a file"]
    plugin = pedalboard.load_plugin(path)
    pristine = plugin.raw_state
    component, xml = component_state(pristine)
    default = json.loads(component)
    failures = []
    for name, data, damaged_ids, refused in damaged_states(default):
        print(f"state: {name} ({len(data)} bytes)", flush=True)
        plugin.raw_state = pristine
        seen = os.path.getsize(log) if os.path.exists(log) else 0
        plugin.raw_state = with_component_state(xml, data)
        # Saving is where an enum out of range panicked and took the host down.
        saved = json.loads(component_state(plugin.raw_state)[0])
        failures += state_failures(name, default, saved, damaged_ids, refused)
        audio = short_render(plugin)
        if not np.isfinite(audio).all():
            failures.append(f"{name}: the note after it is not finite")
        else:
            peak = float(np.max(np.abs(audio)))
            if not AUDIBLE_PEAK < peak < BLOWN_UP_PEAK:
                failures.append(f"{name}: the note after it peaks at {peak:.3g}")
        # (The log reaches its file from a thread of its own: give it time.)
        deadline = time.monotonic() + LOG_WAIT_S
        while True:
            with open(log, encoding="utf-8", errors="replace") as f:
                f.seek(seen)
                said = f.read()
            if not log_failures(name, said, damaged_ids) or time.monotonic() > deadline:
                break
            time.sleep(0.05)
        failures += log_failures(name, said, damaged_ids)
        for line in said.splitlines():
            if "Struck: the saved" in line:
                print(f"  logged: {line.strip()}")
    return failures


def fuzz_state_in_child(path):
    """fuzz_state in a child process logging to a file: its failures, and
    one when the child (the host) died."""
    with tempfile.TemporaryDirectory() as scratch:
        env = dict(os.environ, NICE_LOG=os.path.join(scratch, "plugin.log"))
        child = subprocess.run([sys.executable, os.path.abspath(__file__), path, "--fuzz-state"], env=env)
    if child.returncode == 0:
        return []
    if child.returncode == 1:
        return ["damaged states: see the failures above"]
    return [f"the host died loading a damaged state (exit status {child.returncode}; the last state listed above)"]


# A MIDI feedback loop: 20,000 notes a second, every key in turn at full
# velocity, for a second. It peaked at +23 dBFS before the output's guard;
# the guard holds every plugin at +6 dBFS.
FLOOD_NOTES_PER_S = 20_000
GUARD_CEILING = 10.0 ** (6.0 / 20.0)


def flood_failures(plugin):
    """Failures of a flood of notes through the plugin: a sample that is not
    finite, or a peak over the guard's ceiling."""
    events = [(bytes([0x90, 21 + i % 88, 127]), i / FLOOD_NOTES_PER_S) for i in range(FLOOD_NOTES_PER_S)]
    audio = np.asarray(
        plugin(events, duration=1.5, sample_rate=SAMPLE_RATE_HZ, num_channels=2, buffer_size=BLOCK_SIZE, reset=False)
    )
    if not np.all(np.isfinite(audio)):
        return ["a flood of notes made a sample that is not finite"]
    peak = float(np.max(np.abs(audio)))
    print(f"a flood of {FLOOD_NOTES_PER_S} notes in a second: peak {level_db(peak):+.1f} dBFS")
    if peak > GUARD_CEILING * (1.0 + 1e-6):
        return [f"a flood of notes peaks at {level_db(peak):+.1f} dBFS, over the guard's +6"]
    if peak < 1.0:
        return [f"a flood of notes peaks at {level_db(peak):+.1f} dBFS: did it play?"]
    return []


def level_db(x):
    return 20.0 * np.log10(max(float(x), 1e-12))


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("plugin", nargs="?", help="the .vst3 bundle")
    parser.add_argument("--self-test", action="store_true", help="only check the checks, on made-up audio")
    parser.add_argument("--wav", help="also write the render to this WAV file")
    parser.add_argument(
        "--fuzz-state", action="store_true", help="only load damaged states (NICE_LOG must name the log file)"
    )
    args = parser.parse_args(argv)
    if args.self_test:
        self_test()
        return 0
    if not args.plugin:
        parser.error("the .vst3 bundle is required")
    if args.fuzz_state:
        failures = fuzz_state(args.plugin)
        for failure in failures:
            print(f"FAILED: {failure}", file=sys.stderr)
        print("damaged states: " + ("passed" if not failures else f"{len(failures)} failure(s)"), flush=True)
        return 1 if failures else 0

    failures = []
    plugin = pedalboard.load_plugin(args.plugin)
    print(f"loaded {args.plugin}: '{plugin.name}' by {plugin.manufacturer_name}, version {plugin.version}")
    if plugin.name != EXPECTED_PLUGIN_NAME:
        failures.append(f"the plugin calls itself '{plugin.name}', expected '{EXPECTED_PLUGIN_NAME}'")
    if not plugin.is_instrument:
        failures.append("pedalboard does not see an instrument (is_instrument is false)")

    params = parameters(plugin)
    hidden = len(plugin._parameters) - len(params)
    print(f"{len(params)} parameters ({hidden} hidden MIDI CC/pressure/pitch-bend parameters left out):")
    for p in params:
        label = f" [{p.label}]" if p.label else ""
        print(f"  {p.index:3}  {p.name!r}{label} = {p.string_value!r} (raw {p.raw_value:.4f})")
    absent = missing_names(EXPECTED_PARAMETERS, [p.name for p in params])
    if absent:
        failures.append(f"missing parameters: {', '.join(repr(n) for n in absent)}")

    if plugin.is_instrument:
        plugin.load_smoothing = True
        audio, reported_smoothed = render(plugin)
        finite = np.nan_to_num(audio)
        print(
            f"rendered {audio.shape[-1] / SAMPLE_RATE_HZ:.2f} s at {SAMPLE_RATE_HZ} Hz, shape {audio.shape}: "
            f"peak {level_db(np.max(np.abs(finite))):.1f} dBFS, "
            f"RMS {level_db(np.sqrt(np.mean(finite.astype(np.float64) ** 2))):.1f} dBFS"
        )
        failures += check_audio(audio)
        if args.wav:
            from pedalboard.io import AudioFile

            with AudioFile(args.wav, "w", SAMPLE_RATE_HZ, num_channels=audio.shape[0]) as f:
                f.write(finite.astype(np.float32))
            print(f"wrote {args.wav}")

        plugin.load_smoothing = False
        plain, reported_plain = render(plugin)
        print(
            f"load smoothing: {reported_smoothed} samples of latency reported with it on, {reported_plain} off"
        )
        failures += latency_failures(audio, plain, reported_smoothed, reported_plain)
        # And back on, in the same instance: the host hears of the latency again.
        plugin.load_smoothing = True
        again, reported_again = render(plugin)
        print(f"load smoothing on again: {reported_again} samples of latency reported")
        if reported_again != reported_smoothed:
            failures.append(
                f"with load smoothing switched on again the plugin reports {reported_again} samples of latency, "
                f"expected {reported_smoothed}"
            )
        elif not np.array_equal(again, audio):
            failures.append("with load smoothing switched on again the plugin does not sound as it first did")
        failures += flood_failures(plugin)

    sys.stdout.flush()
    failures += fuzz_state_in_child(args.plugin)

    for failure in failures:
        print(f"FAILED: {failure}", file=sys.stderr)
    sys.stderr.flush()
    print("pedalboard check: " + ("passed" if not failures else f"{len(failures)} failure(s)"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
