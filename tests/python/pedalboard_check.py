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
(pedalboard does not make up an instrument's latency).

Usage: pedalboard_check.py PATH/TO/Struck.vst3 [--wav OUT.wav]
       pedalboard_check.py --self-test   (the checks on made-up audio)
(`cargo xtask test` runs it in a venv under target/ with pedalboard pinned.)
"""

import argparse
import re
import sys

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


def level_db(x):
    return 20.0 * np.log10(max(float(x), 1e-12))


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("plugin", nargs="?", help="the .vst3 bundle")
    parser.add_argument("--self-test", action="store_true", help="only check the checks, on made-up audio")
    parser.add_argument("--wav", help="also write the render to this WAV file")
    args = parser.parse_args(argv)
    if args.self_test:
        self_test()
        return 0
    if not args.plugin:
        parser.error("the .vst3 bundle is required")

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

    sys.stdout.flush()
    for failure in failures:
        print(f"FAILED: {failure}", file=sys.stderr)
    sys.stderr.flush()
    print("pedalboard check: " + ("passed" if not failures else f"{len(failures)} failure(s)"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
