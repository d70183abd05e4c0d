#!/usr/bin/env python3
"""Play the standalone `struck -b jack` from a JACK MIDI client, record it, check it.

Usage:
    jack_session.py STRUCK_BIN [--server-name NAME] [--wav OUT.wav] [--keep-logs DIR]
                    [--screenshot OUT.png] [--attempts N] [--start-timeout S]

What it does (all on a private JACK server, so nothing on the machine is disturbed):
  1. starts `jackd --no-realtime -n NAME -d dummy -r 48000 -p 256` and waits for it;
  2. registers its own client ("struck-session": one MIDI output, two audio inputs),
     then starts `STRUCK_BIN -b jack --connect-jack-midi-input struck-session:midi_out`
     (JACK_DEFAULT_SERVER=NAME selects the server; DISPLAY is removed so no window
     opens), waits for struck's ports and connects its audio outputs to ours;
  3. from the process callback, at exact frames counted from the first cycle after
     the connections are made: A4 (69) on, velocity 100, at 0.5 s, off at 1.5 s;
     sustain pedal (CC64 127) at 2.5 s; C4 (60) on at 2.6 s, off at 3.0 s; pedal up
     (CC64 0) at 4.5 s; records both channels until 6.0 s;
  4. checks: the A4 onset comes 0..3 periods + 10 ms after its note-on (one period is
     the round trip through struck); 0-0.5 s silent (rms < 1e-5); 0.55-1.4 s sounds (rms > 1e-3) with its
     strongest partial within 20 cents of 440 Hz; the damper: 1.8-2.4 s at least
     30 dB below 1.0-1.4 s; the pedal: 3.3-4.3 s within 20 dB of 2.7-3.0 s, with a
     spectral peak within 20 cents of 261.63 Hz no more than 20 dB below the
     strongest; pedal up: 4.9-5.9 s at least 30 dB below 3.3-4.3 s; every sample finite;
  5. stops struck with SIGTERM (it must exit within 5 s with status 0 or -SIGTERM),
     then stops jackd. Any failure: a last line "jack_session: FAIL: <reasons>" and
     exit status 1 (2 for bad usage). Processes are cleaned up in every case.

A late cycle (an xrun: the machine too busy) makes JACK skip struck for that cycle, and
the MIDI events of the cycle are lost. So when the audio checks fail while our client
saw xruns during the take, the whole session is played again (--attempts, default 2);
a failure to stop on SIGTERM is never retried.

With --screenshot OUT.png, struck runs with its editor open on an Xvfb display of its
own (1280x900x24) instead of headless, and the editor's window is saved to OUT.png
at 2.9 s, while C4 rings under the pedal (the live view drawn from a real note; the
whole screen goes to OUT-root.png). The same checks apply, so this also shows that
SIGTERM closes the window. With llvmpipe (software OpenGL) the editor costs CPU: on a
2-core machine expect xruns (20-200 a take here), which the retry above absorbs.

Needs: jackd (Debian jackd2), and the Python packages pinned in xtask (PYTHON_REQUIREMENTS in xtask/src/test_cmd.rs); for
--screenshot also Xvfb (xvfb), xdpyinfo and xwininfo (x11-utils), import and
convert (imagemagick).
The dummy driver runs in real time: the session takes about 7 s plus start-up.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import wave
from pathlib import Path

import numpy as np

try:
    import jack
except Exception as exc:  # libjack missing, or cffi cannot load it
    print(f"jack_session: FAIL: cannot import the JACK-Client package: {exc}")
    sys.exit(1)

SAMPLE_RATE = 48000
PERIOD = 256
CLIENT_NAME = "struck-session"
TOTAL_S = 6.0

# (time in s, MIDI bytes); channel 1.
EVENTS = [
    (0.5, bytes([0x90, 69, 100])),  # A4 on
    (1.5, bytes([0x80, 69, 64])),  # A4 off
    (2.5, bytes([0xB0, 64, 127])),  # sustain pedal down
    (2.6, bytes([0x90, 60, 100])),  # C4 on
    (3.0, bytes([0x80, 60, 64])),  # C4 off (pedal still down)
    (4.5, bytes([0xB0, 64, 0])),  # sustain pedal up
]

SILENCE_RMS = 1e-5
SOUND_RMS = 1e-3
CENTS_TOL = 20.0
DAMPED_DB = 30.0
SUSTAIN_DB = 20.0
RELEASED_DB = 30.0


class Failure(Exception):
    """A reason to stop at once, printed as the one-line verdict."""


def log(msg: str) -> None:
    print(f"jack_session: {msg}", flush=True)


def db(x: float) -> float:
    return 20.0 * np.log10(max(x, 1e-20))


def cents(f: float, ref: float) -> float:
    return 1200.0 * np.log2(f / ref) if f > 0 else float("inf")


# --------------------------------------------------------------------------- processes


def terminate(proc: subprocess.Popen | None, name: str, timeout: float) -> int | None:
    """SIGTERM, wait up to `timeout`, then SIGKILL. Returns the status, None if killed."""
    if proc is None or proc.poll() is not None:
        return None if proc is None else proc.returncode
    proc.send_signal(signal.SIGTERM)
    try:
        return proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        log(f"{name} (pid {proc.pid}) did not exit {timeout:g} s after SIGTERM: killing it")
        proc.kill()
        proc.wait()
        return None


def tail(path: Path, lines: int = 15) -> str:
    try:
        text = path.read_text(errors="replace").splitlines()
    except OSError:
        return "(no log)"
    return "\n".join("    " + line for line in text[-lines:]) or "    (empty)"


def wait_for(what: str, predicate, timeout: float, alive=None):
    """Poll `predicate` until it returns a truthy value; fail after `timeout` s."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if alive is not None:
            dead = alive()
            if dead:
                first, _, details = dead.partition("\n")
                raise Failure(f"{first.rstrip(':')} while waiting for {what}"
                              + (f":\n{details}" if details else ""))
        if time.monotonic() > deadline:
            raise Failure(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.05)


# --------------------------------------------------------------------------- the session


class Session:
    """Our JACK client: sends the events at exact frames and records what comes back."""

    def __init__(self, server: str):
        self.client = jack.Client(CLIENT_NAME, use_exact_name=True, no_start_server=True,
                                  servername=server)
        if self.client.samplerate != SAMPLE_RATE:
            raise Failure(f"JACK runs at {self.client.samplerate} Hz, expected {SAMPLE_RATE}")
        self.sr = self.client.samplerate
        self.total = int(round(TOTAL_S * self.sr))
        self.events = [(int(round(t * self.sr)), data) for t, data in EVENTS]
        self.midi_out = self.client.midi_outports.register("midi_out")
        self.ins = [self.client.inports.register(f"in_{i}") for i in (1, 2)]
        self.rec = np.zeros((2, self.total), dtype=np.float32)
        self.armed = False  # set by the main thread once everything is connected
        self.pos = -1  # frames since the start of the timeline; -1: not started
        self.next_event = 0
        self.sent = []  # (frame, bytes) actually written
        self.xruns = 0  # all xruns seen by our client
        self.xruns_in_take = 0  # those while the timeline ran
        self.done = threading.Event()
        self.shutdown_reason = None
        self.client.set_process_callback(self._process)
        self.client.set_xrun_callback(self._xrun)
        self.client.set_shutdown_callback(self._shutdown)

    def _xrun(self, delay_usecs):
        self.xruns += 1
        if self.pos >= 0 and not self.done.is_set():
            self.xruns_in_take += 1

    def _shutdown(self, status, reason):
        self.shutdown_reason = f"{reason} ({status})"
        self.done.set()

    def _process(self, frames: int) -> None:
        self.midi_out.clear_buffer()
        if not self.armed or self.done.is_set():
            return
        if self.pos < 0:
            self.pos = 0
        start, end = self.pos, self.pos + frames
        while self.next_event < len(self.events) and self.events[self.next_event][0] < end:
            frame, data = self.events[self.next_event]
            offset = max(frame - start, 0)
            self.midi_out.write_midi_event(offset, data)
            self.sent.append((start + offset, data))
            self.next_event += 1
        n = min(frames, self.total - start)
        if n > 0:
            for ch, port in enumerate(self.ins):
                self.rec[ch, start:start + n] = port.get_array()[:n]
        self.pos = end
        if end >= self.total:
            self.done.set()


def find_struck_ports(client: jack.Client):
    """struck's MIDI input and audio outputs, or None while they are not all there."""
    midi_in = [p.name for p in client.get_ports(is_midi=True, is_input=True)
               if not p.name.startswith(CLIENT_NAME + ":")]
    audio_out = [p.name for p in client.get_ports(is_audio=True, is_output=True)
                 if not p.name.startswith(("system:", CLIENT_NAME + ":"))]
    if not midi_in or len(audio_out) < 2:
        return None
    # Prefer a client called "struck" (P::NAME lower-cased) if there are several.
    clients = sorted({p.split(":")[0] for p in midi_in + audio_out},
                     key=lambda c: (c != "struck", c))
    owner = clients[0]
    midi_in = [p for p in midi_in if p.startswith(owner + ":")]
    audio_out = [p for p in audio_out if p.startswith(owner + ":")]
    if not midi_in or len(audio_out) < 2:
        return None
    return midi_in[0], audio_out[:2]


# --------------------------------------------------------------------------- analysis


def seg(x: np.ndarray, sr: int, t0: float, t1: float) -> np.ndarray:
    return x[:, int(round(t0 * sr)):int(round(t1 * sr))]


def rms(x: np.ndarray) -> float:
    """RMS over both channels (so a mono or a wide stereo image both count)."""
    return float(np.sqrt(np.mean(np.square(x.astype(np.float64))))) if x.size else 0.0


def spectrum(x: np.ndarray, sr: int):
    """Power spectrum of both channels summed, Hann window, zero-padded 8x."""
    n = x.shape[1]
    nfft = 1 << int(np.ceil(np.log2(n * 8)))
    w = np.hanning(n)
    p = np.zeros(nfft // 2 + 1)
    for ch in x.astype(np.float64):
        p += np.abs(np.fft.rfft((ch - ch.mean()) * w, nfft)) ** 2
    return np.fft.rfftfreq(nfft, 1.0 / sr), p


def peak_in(freqs, power, lo, hi):
    """(frequency, power) of the largest bin in [lo, hi], refined by a parabola in dB."""
    idx = np.nonzero((freqs >= lo) & (freqs <= hi))[0]
    if idx.size == 0:
        return 0.0, 0.0
    k = int(idx[np.argmax(power[idx])])
    f = freqs[k]
    if 0 < k < len(power) - 1 and power[k] > 0:
        a, b, c = (10 * np.log10(max(power[j], 1e-300)) for j in (k - 1, k, k + 1))
        den = a - 2 * b + c
        if den != 0:
            f = freqs[k] + 0.5 * (a - c) / den * (freqs[1] - freqs[0])
    return float(f), float(power[k])


def analyse(rec: np.ndarray, sr: int) -> list[str]:
    """Print the measurements; return the list of failed checks."""
    failures = []

    def check(ok: bool, line: str, reason: str):
        log(("ok   " if ok else "FAIL ") + line)
        if not ok:
            failures.append(reason)

    if not np.all(np.isfinite(rec)):
        bad = int(np.count_nonzero(~np.isfinite(rec)))
        failures.append(f"{bad} non-finite samples in the recording")
        log(f"FAIL {bad} non-finite samples")
        rec = np.nan_to_num(rec, nan=0.0, posinf=0.0, neginf=0.0)
    peak = float(np.max(np.abs(rec)))
    log(f"     peak {peak:.4f} ({db(peak):+.1f} dBFS); rms L {rms(rec[:1]):.3e}, "
        f"R {rms(rec[1:]):.3e} over the whole take")
    if peak > 1.0:
        log("     note: the output exceeds full scale")

    # The first note's onset: the first sample above -80 dBFS, counted from 0.5 s. A round
    # trip through struck costs one JACK period (our client both feeds and records it);
    # allow three periods and 10 ms of attack.
    above = np.nonzero(np.max(np.abs(rec), axis=0) > 1e-4)[0]
    note_on = int(round(0.5 * sr))
    if above.size:
        late = int(above[0]) - note_on
        limit = 3 * PERIOD + int(0.010 * sr)
        check(0 <= late <= limit, f"A4 onset {late} frames after its note-on ({late / sr * 1e3:.1f} ms; "
              f"allowed 0..{limit})", f"A4's onset is {late} frames from its note-on (allowed 0..{limit})")

    silent = rms(seg(rec, sr, 0.0, 0.5))
    check(silent < SILENCE_RMS, f"0.00-0.50 s before any note: rms {silent:.2e} (< {SILENCE_RMS:g})",
          f"not silent before the first note (rms {silent:.2e})")

    a4 = seg(rec, sr, 0.55, 1.4)
    a4_rms = rms(a4)
    check(a4_rms > SOUND_RMS, f"0.55-1.40 s A4 held: rms {a4_rms:.3e} ({db(a4_rms):+.1f} dBFS, "
          f"> {SOUND_RMS:g})", f"A4 does not sound (rms {a4_rms:.2e})")
    freqs, p = spectrum(a4, sr)
    f_a4, _ = peak_in(freqs, p, 20.0, sr / 2)
    c_a4 = cents(f_a4, 440.0)
    check(abs(c_a4) <= CENTS_TOL, f"A4 strongest partial {f_a4:.2f} Hz ({c_a4:+.1f} cents from 440 Hz)",
          f"A4's strongest partial is {f_a4:.1f} Hz, {c_a4:+.0f} cents from 440 Hz")

    held = rms(seg(rec, sr, 1.0, 1.4))
    damped = rms(seg(rec, sr, 1.8, 2.4))
    drop = db(held) - db(damped)
    check(drop >= DAMPED_DB, f"damper: 1.8-2.4 s is {drop:.1f} dB below 1.0-1.4 s "
          f"({db(damped):+.1f} vs {db(held):+.1f} dBFS; need >= {DAMPED_DB:g} dB)",
          f"A4 not damped after key-up ({drop:.1f} dB down, need {DAMPED_DB:g})")

    c4_on = rms(seg(rec, sr, 2.7, 3.0))
    c4_ped = seg(rec, sr, 3.3, 4.3)
    c4_ped_rms = rms(c4_ped)
    fall = db(c4_on) - db(c4_ped_rms)
    check(c4_on > SOUND_RMS and fall <= SUSTAIN_DB,
          f"pedal: 3.3-4.3 s (after C4's key-up) is {fall:.1f} dB below 2.7-3.0 s "
          f"({db(c4_ped_rms):+.1f} vs {db(c4_on):+.1f} dBFS; need <= {SUSTAIN_DB:g} dB)",
          f"C4 does not ring on with the pedal down ({fall:.1f} dB down, "
          f"C4 held at {db(c4_on):+.1f} dBFS)")
    freqs, p = spectrum(c4_ped, sr)
    c4_ref = 440.0 * 2 ** ((60 - 69) / 12)
    f_strong, p_strong = peak_in(freqs, p, 20.0, sr / 2)
    f_c4, p_c4 = peak_in(freqs, p, c4_ref * 2 ** (-1 / 12), c4_ref * 2 ** (1 / 12))
    c_c4 = cents(f_c4, c4_ref)
    rel = 10 * np.log10(max(p_c4, 1e-300) / max(p_strong, 1e-300))
    check(c4_ped_rms > SILENCE_RMS and abs(c_c4) <= CENTS_TOL and rel >= -20.0,
          f"C4 pitch {f_c4:.2f} Hz ({c_c4:+.1f} cents from {c4_ref:.2f} Hz), "
          f"{rel:+.1f} dB vs the strongest partial ({f_strong:.2f} Hz)",
          f"C4 under the pedal: peak near {c4_ref:.1f} Hz is {f_c4:.1f} Hz ({c_c4:+.0f} cents, "
          f"{rel:+.0f} dB vs strongest at {f_strong:.1f} Hz)")

    released = rms(seg(rec, sr, 4.9, 5.9))
    drop2 = db(c4_ped_rms) - db(released)
    if c4_ped_rms <= SILENCE_RMS:
        log("skip pedal up: nothing rang under the pedal (see above)")
        return failures
    check(drop2 >= RELEASED_DB, f"pedal up: 4.9-5.9 s is {drop2:.1f} dB below 3.3-4.3 s "
          f"({db(released):+.1f} dBFS; need >= {RELEASED_DB:g} dB)",
          f"C4 not damped after pedal up ({drop2:.1f} dB down, need {RELEASED_DB:g})")
    return failures


def write_wav(path: Path, rec: np.ndarray, sr: int) -> None:
    pcm = (np.clip(rec.T, -1.0, 1.0) * 32767.0).astype("<i2")
    with wave.open(str(path), "wb") as w:
        w.setnchannels(2)
        w.setsampwidth(2)
        w.setframerate(sr)
        w.writeframes(pcm.tobytes())


# --------------------------------------------------------------------------- main


SHOT_AT_S = 2.9


def start_xvfb(workdir: Path):
    """An Xvfb on the first free display from :98 up; returns (process, ":N")."""
    for tool in ("Xvfb", "xdpyinfo", "xwininfo", "import", "convert"):
        if shutil.which(tool) is None:
            raise Failure(f"--screenshot needs {tool} (Debian: xvfb, x11-utils, imagemagick)")
    n = 98
    while Path(f"/tmp/.X{n}-lock").exists() or Path(f"/tmp/.X11-unix/X{n}").exists():
        n += 1
    display = f":{n}"
    out = open(workdir / "xvfb.log", "wb")
    proc = subprocess.Popen(["Xvfb", display, "-screen", "0", "1280x900x24", "-nolisten", "tcp"],
                            stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                            start_new_session=True)
    up = lambda: subprocess.run(["xdpyinfo", "-display", display], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL).returncode == 0
    dead = lambda: f"Xvfb exited with status {proc.returncode}" if proc.poll() is not None else None
    try:
        wait_for(f"Xvfb {display}", up, 10.0, dead)
    except Failure:
        terminate(proc, "Xvfb", 5.0)
        raise
    return proc, display


def window_geometry(display: str, name: str = "Struck"):
    """(width, height, x, y) of the window called `name`, or None."""
    r = subprocess.run(["xwininfo", "-display", display, "-name", name],
                       capture_output=True, text=True)
    if r.returncode != 0:
        return None
    field = lambda key: int(re.search(rf"{key}:\s+(-?\d+)", r.stdout).group(1))
    return field("Width"), field("Height"), field("Absolute upper-left X"), \
        field("Absolute upper-left Y")


def take_screenshot(display: str, out: Path) -> str:
    """Save the editor's window to `out` (the screen to OUT-root.png); a line to print."""
    root = out.with_name(out.stem + "-root.png")
    subprocess.run(["import", "-display", display, "-window", "root", str(root)], check=True,
                   capture_output=True)
    geometry = window_geometry(display)
    if geometry is None:
        raise Failure(f"no window called 'Struck' on {display} for the screenshot")
    w, h, x, y = geometry
    subprocess.run(["convert", str(root), "-crop", f"{w}x{h}+{x}+{y}", "+repage", str(out)],
                   check=True, capture_output=True)
    colours = subprocess.run(["identify", "-format", "%k", str(out)], capture_output=True,
                             text=True).stdout.strip()
    return f"screenshot of the {w}x{h} editor at {SHOT_AT_S} s: {out} ({colours} colours)"


def run(args, workdir: Path) -> tuple[list[str], bool]:
    """One session. Returns the failures, and whether they may come from a busy machine
    (audio checks failed while JACK reported xruns: a late cycle drops struck's MIDI)."""
    struck_bin = Path(args.struck).resolve()
    if not os.access(struck_bin, os.X_OK):
        raise Failure(f"{struck_bin} is not an executable")
    jackd = shutil.which("jackd")
    if jackd is None:
        raise Failure("jackd not found (Debian package jackd2)")
    server = args.server_name or f"struck-test-{os.getpid()}-{args.attempt}"

    env = dict(os.environ)
    env["JACK_DEFAULT_SERVER"] = server
    env["JACK_NO_AUDIO_RESERVATION"] = "1"  # no D-Bus device reservation
    env.pop("JACK_START_SERVER", None)
    for var in ("DISPLAY", "WAYLAND_DISPLAY"):  # no window, unless on our own Xvfb
        env.pop(var, None)
    os.environ["JACK_DEFAULT_SERVER"] = server
    os.environ["JACK_NO_AUDIO_RESERVATION"] = "1"

    procs = {}
    session = None
    shot_line = None
    jackd_log = workdir / "jackd.log"
    struck_log = workdir / "struck.log"
    try:
        if args.screenshot:
            procs["Xvfb"], env["DISPLAY"] = start_xvfb(workdir)
            log(f"Xvfb up on {env['DISPLAY']}: struck opens its editor there")

        # 1. the JACK server
        cmd = [jackd, "--no-realtime", "-n", server, "-d", "dummy",
               "-r", str(SAMPLE_RATE), "-p", str(PERIOD)]
        log("starting " + " ".join(cmd))
        with open(jackd_log, "wb") as out:
            procs["jackd"] = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out,
                                              stderr=subprocess.STDOUT, env=env,
                                              start_new_session=True)

        def jackd_dead():
            p = procs["jackd"]
            if p.poll() is not None:
                return f"jackd exited with status {p.returncode}:\n{tail(jackd_log)}"
            return None

        def try_client():
            try:
                return Session(server)
            except jack.JackOpenError:
                return None

        jack.set_error_function(lambda msg: None)  # libjack's "cannot connect" while polling
        try:
            session = wait_for(f"the JACK server '{server}'", try_client, 10.0, jackd_dead)
        finally:
            jack.set_error_function(None)
        client = session.client
        client.activate()
        log(f"JACK server '{server}' up: {client.samplerate} Hz, period {client.blocksize}")

        # 2. the standalone
        our_midi = f"{CLIENT_NAME}:midi_out"
        cmd = [str(struck_bin), "-b", "jack", "--connect-jack-midi-input", our_midi]
        log("starting JACK_DEFAULT_SERVER=" + server + " " + " ".join(cmd))
        with open(struck_log, "wb") as out:
            procs["struck"] = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out,
                                               stderr=subprocess.STDOUT, env=env,
                                               start_new_session=True)

        def struck_dead():
            p = procs["struck"]
            if p.poll() is not None:
                return f"struck exited early with status {p.returncode}:\n{tail(struck_log)}"
            return jackd_dead()

        midi_in, audio_out = wait_for("struck's JACK ports", lambda: find_struck_ports(client),
                                      args.start_timeout, struck_dead)
        log(f"struck's ports: {midi_in}, {', '.join(audio_out)}")

        # The standalone connects our MIDI output itself (--connect-jack-midi-input) right
        # after activating; give it a moment, and connect it ourselves if it did not.
        def midi_linked():
            return midi_in in [p.name for p in client.get_all_connections(session.midi_out)]

        try:
            wait_for("--connect-jack-midi-input to take effect", midi_linked, 3.0, struck_dead)
            log(f"--connect-jack-midi-input connected {our_midi} -> {midi_in}")
        except Failure as exc:
            if struck_dead():
                raise
            log(f"warning: {exc}; connecting {our_midi} -> {midi_in} here")
            client.connect(session.midi_out, midi_in)
        for src, dst in zip(audio_out, session.ins):
            client.connect(src, dst)
        auto = [p.name for p in client.get_all_connections(audio_out[0])]
        log(f"{audio_out[0]} -> {', '.join(auto)}")

        # 3. play and record (JACK's dummy driver runs in real time)
        time.sleep(0.2)  # a few cycles for the graph to settle
        session.armed = True
        if args.screenshot:
            wait_for("the screenshot's moment", lambda: session.pos >= SHOT_AT_S * session.sr,
                     TOTAL_S + 10.0, struck_dead)
            shot_line = take_screenshot(env["DISPLAY"], Path(args.screenshot))
        if not session.done.wait(TOTAL_S + 10.0):
            raise Failure(f"the take did not finish (recorded {max(session.pos, 0) / session.sr:.2f} s)")
        if session.shutdown_reason:
            raise Failure(f"the JACK server shut our client down: {session.shutdown_reason}")
        if procs["struck"].poll() is not None:
            raise Failure(f"struck exited during the take with status "
                          f"{procs['struck'].returncode}:\n{tail(struck_log)}")
        log(f"sent {len(session.sent)} events at frames "
            + ", ".join(str(f) for f, _ in session.sent)
            + f"; xruns: {session.xruns_in_take} during the take, {session.xruns} in all")
        if len(session.sent) != len(EVENTS):
            raise Failure(f"only {len(session.sent)} of {len(EVENTS)} MIDI events were sent")
        if shot_line:
            log(shot_line)
        if args.wav:
            write_wav(Path(args.wav), session.rec, session.sr)
            log(f"recording written to {args.wav}")

        # 4. the checks
        failures = analyse(session.rec, session.sr)
        busy = bool(failures) and session.xruns_in_take > 0
        if busy:
            failures = [f + f" [{session.xruns_in_take} xruns during the take]" for f in failures]

        # 5. stop struck: SIGTERM, must exit within 5 s with 0 or the signal's status
        p = procs["struck"]
        p.send_signal(signal.SIGTERM)
        t0 = time.monotonic()
        try:
            status = p.wait(timeout=5.0)
            took = time.monotonic() - t0
            ok = status in (0, -signal.SIGTERM)
            log(("ok   " if ok else "FAIL ") + f"struck exited {took:.2f} s after SIGTERM "
                f"with status {status}")
            if not ok:
                failures.append(f"struck exited with status {status} after SIGTERM")
                busy = False
        except subprocess.TimeoutExpired:
            log("FAIL struck still running 5 s after SIGTERM: killing it")
            p.kill()
            p.wait()
            failures.append("struck did not exit within 5 s of SIGTERM")
            busy = False
        errors = [line for line in struck_log.read_text(errors="replace").splitlines()
                  if re.search(r"error|panic|could not", line, re.I)]
        for line in errors[:10]:
            log(f"struck said: {line}")
        return failures, busy
    finally:
        terminate(procs.get("struck"), "struck", 5.0)
        if session is not None:
            try:
                session.client.deactivate()
                session.client.close()
            except Exception:
                pass
        terminate(procs.get("jackd"), "jackd", 5.0)
        terminate(procs.get("Xvfb"), "Xvfb", 5.0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("struck", help="path to the struck binary (e.g. target/debug/struck)")
    ap.add_argument("--server-name", help="JACK server name (default: struck-test-<pid>-<attempt>)")
    ap.add_argument("--wav", help="also write the recording here (16-bit stereo WAV)")
    ap.add_argument("--keep-logs", metavar="DIR", help="keep jackd.log and struck.log in DIR")
    ap.add_argument("--screenshot", metavar="PNG",
                    help="open the editor on an Xvfb and save it here during the C4 note")
    ap.add_argument("--start-timeout", type=float, default=30.0,
                    help="seconds to wait for struck's ports (default 30)")
    ap.add_argument("--attempts", type=int, default=2,
                    help="play the take again (up to this many times in all) when its audio "
                         "checks failed while JACK reported xruns (default 2)")
    args = ap.parse_args()

    for attempt in range(1, max(args.attempts, 1) + 1):
        workdir = Path(tempfile.mkdtemp(prefix="struck-jack-"))
        busy = False
        try:
            args.attempt = attempt
            failures, busy = run(args, workdir)
        except Failure as exc:
            lines = str(exc).splitlines()
            if len(lines) > 1:
                print("\n".join(lines[1:]))
            failures = [lines[0].rstrip(":")]
        except KeyboardInterrupt:
            failures = ["interrupted"]
        finally:
            if args.keep_logs:
                dest = Path(args.keep_logs)
                dest.mkdir(parents=True, exist_ok=True)
                for f in workdir.iterdir():
                    shutil.copy(f, dest / f.name)
            shutil.rmtree(workdir, ignore_errors=True)
        if not (failures and busy and attempt < args.attempts):
            break
        log(f"attempt {attempt} failed with xruns during the take (a busy machine drops "
            f"MIDI): playing it again")

    if failures:
        print("jack_session: FAIL: " + "; ".join(failures), flush=True)
        return 1
    print("jack_session: PASS", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
