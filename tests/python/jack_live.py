#!/usr/bin/env python3
"""Play the standalone `struck -b jack` live for a minute at small periods: no xrun, and
its worst audio callback under half its period.

Usage:
    jack_live.py STRUCK_BIN [--seconds S] [--configs 48000/64,96000/128] [--smoothing on,off]
                 [--limit 0.5] [--attempts N] [--alone-s S] [--strict] [--keep-logs DIR]
                 [--start-timeout S]

For each JACK configuration (sample rate / period) and each load-smoothing setting, on a
private JACK server so nothing on the machine is disturbed:
  1. starts `jackd -n NAME -d dummy -r RATE -p PERIOD` (in real time when the system
     allows it) and registers our client ("struck-live": one MIDI output, two audio
     inputs, which record nothing but the output's peak), which first runs alone on it
     for --alone-s seconds (default 10), counting the xruns of the machine itself;
  2. starts `STRUCK_BIN -b jack --connect-jack-midi-input struck-live:midi_out` with
     STRUCK_LOAD_SMOOTHING=on|off (the standalone reads it at start) and
     STRUCK_CALLBACK_STATS=FILE: struck then times each of its process callbacks inside
     it (wall clock at entry and exit, and its thread's CPU time) and writes the worst,
     the count over half and over all of the period, and a histogram to FILE;
  3. plays, from our process callback at exact frames, a dense pedalled piece in a loop
     for S seconds (default 60): both hands, fortissimo chords (velocity 104-127, up to
     ten keys struck together), the sustain pedal changed at every bar (see `piece`);
  4. checks: no xrun reported to our client while the piece played (JACK's xrun
     callback; the server's log lines about late clients are printed too); struck's
     worst callback under LIMIT (default 0.5) of its period; every MIDI event sent;
     struck's output finite and sounding; struck exits on SIGTERM within 5 s.

struck's figures cover every callback from its start to its stop: the first callbacks
and the strikes of the piece alike. The wall time is what must fit in the period; the
thread's CPU time is printed beside it to tell the synth's own work from time spent
waiting for a core (on a busy machine, or without real-time priority, the callback
thread can be preempted, and a core shared with other work runs slower). The worst
callbacks are placed in the piece (bar, beat, what was played in the 30 ms before).
The server's log says which client was late at each xrun (or the dummy driver's own
timer): printed per run. When a run fails and its worst
callback's own CPU time was within the limit (the machine, not the synth, was late),
that configuration is played again, up to --attempts times in all (default 2); every
attempt is printed.

A machine whose server misses its period with our client alone, or whose dummy
driver's own timer wakes late while the piece plays (a virtual machine's scheduler,
other load), cannot tell struck's xruns and late callbacks from its own: there they are
printed as NOT JUDGED and do not fail the run, unless --strict; the other checks hold
everywhere.

Any failure: a last line "jack_live: FAIL: <reasons>", exit status 1 (2 for bad usage).
The output's peak reaches the output guard's ceiling (+6 dBFS, 1.995) in this piece: the
guard limits it, as it should at this density, and that is not checked.
Needs jackd (Debian jackd2) and JACK-Client and numpy (pinned in xtask). Takes about
S + 15 s per run: 4 runs, about 5 minutes with the defaults.
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
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from jack_session import Failure, find_struck_ports, tail, terminate, wait_for  # noqa: E402

import jack  # noqa: E402  (jack_session reports a missing JACK-Client in one line)

CLIENT_NAME = "struck-live"

# --------------------------------------------------------------------------- the piece

TEMPO_BPM = 132.0
BEAT_S = 60.0 / TEMPO_BPM
# One bar per chord (root pitch class, quality): a romantic cadence in C minor, eight bars.
BARS = [(0, "m"), (8, "M"), (5, "m"), (7, "7"), (0, "m"), (3, "M"), (5, "m"), (7, "7")]
THIRDS = {"m": (3, 7), "M": (4, 7), "7": (4, 10)}
# Both hands together at these bars' first beat, everything at 127: the climaxes.
TUTTI = {3, 7}


def piece() -> tuple[list[tuple[float, bytes]], float]:
    """One loop of the piece: (time in s, MIDI bytes) sorted by time, and its length.

    Each bar: the left hand strikes the bass in octaves (C2 C3) on beat 1 and a
    three-key chord in the tenor on beats 2, 3 and 4; the right hand strikes five-key
    chords (C4 to E5, then an octave up) on beats 1 and 3 and four-key chords on the
    half beats after 2 and 4. At bars 4 and 8 both hands strike ten keys at once at 127.
    The pedal is changed at every bar: up 10 ms after the bass, down 110 ms later (legato
    pedalling), so a bar's keys ring under it and the dampers fall at the next bar. Each
    hand lets its keys go 20 ms before its next strike (a key struck again is let go
    first); with the pedal down they ring on.
    """
    events = []
    held: dict[int, float] = {}  # key -> the time it went down (held by either hand)
    last_of_hand: dict[str, list[int]] = {"L": [], "R": []}

    def strike(t: float, hand: str, keys: list[int], velocity: int) -> None:
        keys = sorted(set(keys))
        release = t - 0.020
        for key in set(last_of_hand[hand]) | {k for k in keys if k in held}:
            if key in held:
                events.append((release, bytes([0x80, key, 64])))
                del held[key]
        for key in keys:
            events.append((t, bytes([0x90, key, velocity])))
            held[key] = t
        last_of_hand[hand] = list(keys)

    strikes = []
    for bar, (root, quality) in enumerate(BARS):
        third, fifth = THIRDS[quality]
        t0 = bar * 4 * BEAT_S + 0.05
        tutti = bar in TUTTI
        bass = [36 + root, 48 + root]
        tenor = [48 + root, 48 + root + third, 48 + root + fifth]
        low = [60 + root, 60 + root + third, 60 + root + fifth, 72 + root, 72 + root + third]
        high = [60 + root + fifth, 72 + root, 72 + root + third, 72 + root + fifth, 84 + root]
        answer = [72 + root + third, 72 + root + fifth, 84 + root, 84 + root + third]
        strikes.append((t0, "L", bass + (tenor if tutti else []), 127 if tutti else 118))
        strikes.append((t0, "R", low + ([84 + root] if tutti else []), 127 if tutti else 120))
        events.append((t0 + 0.010, bytes([0xB0, 64, 0])))
        events.append((t0 + 0.120, bytes([0xB0, 64, 127])))
        for beat in (1, 2, 3):
            strikes.append((t0 + beat * BEAT_S, "L", tenor, 104 + 4 * beat))
        strikes.append((t0 + 2 * BEAT_S, "R", high, 124))
        for half in (1.5, 3.5):
            strikes.append((t0 + half * BEAT_S, "R", answer, 110))
    for t, hand, keys, velocity in sorted(strikes, key=lambda s: s[0]):
        strike(t, hand, keys, velocity)
    length = len(BARS) * 4 * BEAT_S + 0.05
    for key in list(held):
        events.append((length - 0.020, bytes([0x80, key, 64])))
    events.append((length - 0.010, bytes([0xB0, 64, 0])))
    events.sort(key=lambda e: (e[0], e[1][0] != 0x80))  # at one time: offs before ons
    return events, length


def describe_moment(t: float, length: float) -> str:
    """Where in one loop of the piece a time falls: bar and beat, and the time after
    the bar's first strike."""
    within = t % length - 0.05
    bar, beat = divmod(max(within, 0.0) / BEAT_S, 4.0)
    return f"bar {int(bar) + 1}, beat {beat + 1:.2f} ({within - bar * 4 * BEAT_S:+.3f} s into the bar)"


# --------------------------------------------------------------------------- the session


def log(msg: str) -> None:
    print(f"jack_live: {msg}", flush=True)


class Player:
    """Our JACK client: plays the piece in a loop at exact frames, watches the output."""

    def __init__(self, server: str, rate: int, period: int, seconds: float):
        self.client = jack.Client(CLIENT_NAME, use_exact_name=True, no_start_server=True,
                                  servername=server)
        if self.client.samplerate != rate or self.client.blocksize != period:
            raise Failure(f"JACK runs at {self.client.samplerate} Hz in periods of "
                          f"{self.client.blocksize}, expected {rate} and {period}")
        self.sr = rate
        self.period = period
        events, self.length_s = piece()
        self.loop = int(round(self.length_s * rate))
        self.frames = [int(round(t * rate)) for t, _ in events]
        self.data = [d for _, d in events]
        self.total = int(round(seconds * rate))
        self.expected = sum(1 for k in range(0, self.total, self.loop)
                            for f in self.frames if k + f < self.total)
        self.midi_out = self.client.midi_outports.register("midi_out")
        self.ins = [self.client.inports.register(f"in_{i}") for i in (1, 2)]
        self.armed = False
        self.pos = -1
        self.next = 0
        self.loop_start = 0
        self.sent = 0
        self.peak = 0.0
        self.nonfinite = 0
        self.xruns = 0
        self.xruns_in_take = 0
        self.started_at = None  # time.monotonic() at the piece's frame 0 (our first cycle)
        # Each cycle's wall clock and frame: struck's worst callbacks are placed in the piece
        # by their wall clock (the dummy driver's cycles come late on a busy machine, so the
        # frames drift from the wall clock).
        cycles = self.total // period + 16
        self.cycle_t = np.full(cycles, np.inf)
        self.cycle_pos = np.zeros(cycles, dtype=np.int64)
        self.cycle = 0
        self.done = threading.Event()
        self.shutdown_reason = None
        self.client.set_process_callback(self._process)
        self.client.set_xrun_callback(self._xrun)
        self.client.set_shutdown_callback(self._shutdown)

    def place(self, at_s: float, latency_s: float) -> str:
        """Where a callback that started at `at_s` (CLOCK_MONOTONIC) fell in the piece, and
        what was played in it and in the 30 ms (and load smoothing's latency) before it."""
        k = int(np.searchsorted(self.cycle_t[:self.cycle], at_s, side="right")) - 1
        if k < 0:
            return f"{self.cycle_t[0] - at_s:.2f} s before the piece started"
        pos = int(self.cycle_pos[k]) % self.loop
        period = self.period
        # (A strike's and a damper's work goes on for milliseconds after its event.)
        lo, hi = pos - int((latency_s + 0.030) * self.sr), pos + period
        what: dict[str, list[int]] = {}
        for f, d in zip(self.frames, self.data):
            if lo <= f < hi or lo <= f - self.loop < hi:
                kind = {0x90: "struck", 0x80: "let go", 0xB0: "pedal"}[d[0] & 0xF0]
                if kind == "pedal":
                    kind = "pedal down" if d[2] >= 64 else "pedal up"
                what.setdefault(kind, []).append(d[2] if kind == "struck" else 0)
        said = ", ".join(f"{len(v)} keys {k} (velocity {min(v)}-{max(v)})" if k == "struck"
                         else (f"{len(v)} keys {k}" if k == "let go" else k) for k, v in what.items())
        return f"{describe_moment(pos / self.sr, self.length_s)} ({said or 'no event'})"

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
            self.started_at = time.monotonic()
        start, end = self.pos, min(self.pos + frames, self.total)
        if self.cycle < len(self.cycle_t):
            self.cycle_t[self.cycle] = time.monotonic()
            self.cycle_pos[self.cycle] = start
            self.cycle += 1
        while True:
            if self.next == len(self.frames):
                self.next = 0
                self.loop_start += self.loop
            frame = self.loop_start + self.frames[self.next]
            if frame >= end:
                break
            self.midi_out.write_midi_event(max(frame - start, 0), self.data[self.next])
            self.sent += 1
            self.next += 1
        for port in self.ins:
            x = port.get_array()
            m = float(np.max(np.abs(x)))
            if not np.isfinite(m):
                self.nonfinite += 1
            elif m > self.peak:
                self.peak = m
        self.pos = start + frames
        if self.pos >= self.total:
            self.done.set()


def read_stats(path: Path) -> dict:
    """struck's callback report: `key value` lines, several `worst` lines."""
    stats = {"worst": []}
    for line in path.read_text().splitlines():
        key, _, value = line.partition(" ")
        if key == "worst":
            f = value.split()
            stats["worst"].append({f[i]: float(f[i + 1]) for i in range(0, len(f), 2)})
        elif key == "histogram_5pct":
            stats[key] = [int(v) for v in value.split()]
        elif key:
            stats[key] = float(value)
    return stats


def jackd_log_says(path: Path) -> dict:
    """What the server's log says: whether it runs in real time, and its late cycles by
    whom (JACK2: "JackEngine::XRun: client = NAME was not finished" for a client still
    running at the next cycle; "JackTimedDriver::Process XRun = N usec" for the dummy
    driver's own timer waking late)."""
    try:
        text = path.read_text(errors="replace").splitlines()
    except OSError:
        text = []
    late: dict[str, int] = {}
    for line in text:
        m = re.search(r"client = (\S+) was not finished", line)
        if m:
            late[m.group(1)] = late.get(m.group(1), 0) + 1
        elif re.search(r"JackTimedDriver::Process XRun", line):
            late["the driver's timer"] = late.get("the driver's timer", 0) + 1
    realtime = any("realtime mode" in line for line in text) and not any(
        re.search(r"cannot use real-time|AcquireSelfRealTime error|AcquireRealTime error", line, re.I)
        for line in text)
    return {"late": late, "realtime": realtime}


def run_one(args, rate: int, period: int, smoothing: str, workdir: Path, attempt: int) -> dict:
    """One configuration played once; returns what was measured and the failures."""
    struck_bin = Path(args.struck).resolve()
    jackd = shutil.which("jackd")
    if jackd is None:
        raise Failure("jackd not found (Debian package jackd2)")
    server = f"struck-live-{os.getpid()}-{rate}-{period}-{smoothing}-{attempt}"
    env = dict(os.environ)
    env["JACK_DEFAULT_SERVER"] = server
    env["JACK_NO_AUDIO_RESERVATION"] = "1"
    env.pop("JACK_START_SERVER", None)
    for var in ("DISPLAY", "WAYLAND_DISPLAY"):
        env.pop(var, None)
    stats_file = workdir / "callbacks.txt"
    env["STRUCK_CALLBACK_STATS"] = str(stats_file)
    env["STRUCK_LOAD_SMOOTHING"] = smoothing
    os.environ["JACK_DEFAULT_SERVER"] = server
    os.environ["JACK_NO_AUDIO_RESERVATION"] = "1"
    jackd_log = workdir / "jackd.log"
    struck_log = workdir / "struck.log"
    procs = {}
    player = None
    result = {"failures": []}
    failures = result["failures"]
    try:
        # Real-time scheduling when the system grants it (as root, or with rtprio in the
        # limits): JACK's clients' threads then take it too, as on a musician's machine. When
        # it is refused, jackd and its clients run with the normal scheduler (said below).
        cmd = [jackd, "-n", server, "-d", "dummy", "-r", str(rate), "-p", str(period)]
        log("starting " + " ".join(cmd))
        with open(jackd_log, "wb") as out:
            procs["jackd"] = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out,
                                              stderr=subprocess.STDOUT, env=env, start_new_session=True)

        def jackd_dead():
            p = procs["jackd"]
            return f"jackd exited with status {p.returncode}:\n{tail(jackd_log)}" if p.poll() is not None else None

        def try_client():
            try:
                return Player(server, rate, period, args.seconds)
            except jack.JackOpenError:
                return None

        jack.set_error_function(lambda msg: None)
        try:
            player = wait_for(f"the JACK server '{server}'", try_client, 10.0, jackd_dead)
        finally:
            jack.set_error_function(None)
        client = player.client
        client.activate()
        # The machine first, with no plugin: our client alone on the server. A
        # machine whose server misses its period even so (a virtual machine's
        # scheduler, other load) cannot judge struck's xruns or callbacks.
        time.sleep(0.5)
        alone = player.xruns
        time.sleep(args.alone_s)
        result["xruns_alone"] = player.xruns - alone
        log(f"{rate}/{period}: the server with our client alone: {result['xruns_alone']} xruns "
            f"in {args.alone_s:g} s")

        our_midi = f"{CLIENT_NAME}:midi_out"
        cmd = [str(struck_bin), "-b", "jack", "--connect-jack-midi-input", our_midi]
        log(f"starting STRUCK_LOAD_SMOOTHING={smoothing} STRUCK_CALLBACK_STATS={stats_file.name} "
            + " ".join(cmd))
        with open(struck_log, "wb") as out:
            procs["struck"] = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out,
                                               stderr=subprocess.STDOUT, env=env, start_new_session=True)

        def struck_dead():
            p = procs["struck"]
            if p.poll() is not None:
                return f"struck exited early with status {p.returncode}:\n{tail(struck_log)}"
            return jackd_dead()

        midi_in, audio_out = wait_for("struck's JACK ports", lambda: find_struck_ports(client),
                                      args.start_timeout, struck_dead)

        def midi_linked():
            return midi_in in [p.name for p in client.get_all_connections(player.midi_out)]

        try:
            wait_for("--connect-jack-midi-input to take effect", midi_linked, 10.0, struck_dead)
        except Failure:
            if struck_dead():
                raise
            try:
                client.connect(player.midi_out, midi_in)
            except jack.JackError:
                pass  # (made meanwhile by struck: checked below)
            if not midi_linked():
                raise Failure(f"cannot connect {CLIENT_NAME}:midi_out to {midi_in}")
        for src, dst in zip(audio_out, player.ins):
            client.connect(src, dst)

        time.sleep(0.5)  # a few hundred cycles for the graph to settle
        before = player.xruns
        player.armed = True
        if not player.done.wait(args.seconds + 15.0):
            raise Failure(f"the take did not finish (played {max(player.pos, 0) / rate:.1f} s)")
        if player.shutdown_reason:
            raise Failure(f"the JACK server shut our client down: {player.shutdown_reason}")
        if procs["struck"].poll() is not None:
            raise Failure(f"struck exited during the take with status {procs['struck'].returncode}:\n"
                          f"{tail(struck_log)}")
        result.update(xruns=player.xruns_in_take, xruns_before=before, sent=player.sent,
                      expected=player.expected, peak=player.peak, nonfinite=player.nonfinite)

        p = procs["struck"]
        p.send_signal(signal.SIGTERM)
        try:
            status = p.wait(timeout=5.0)
            if status not in (0, -signal.SIGTERM):
                failures.append(f"struck exited with status {status} after SIGTERM")
        except subprocess.TimeoutExpired:
            failures.append("struck did not exit within 5 s of SIGTERM")
        if not stats_file.exists():
            raise Failure(f"struck wrote no callback report ({stats_file.name}):\n{tail(struck_log)}")
        stats = read_stats(stats_file)
        result["stats"] = stats
        result["place"] = player.place
    finally:
        terminate(procs.get("struck"), "struck", 5.0)
        if player is not None:
            try:
                player.client.deactivate()
                player.client.close()
            except Exception:
                pass
        terminate(procs.get("jackd"), "jackd", 5.0)
    result.update(jackd_log_says(jackd_log))
    return result


def judge(args, rate: int, period: int, smoothing: str, r: dict) -> tuple[list[str], bool]:
    """Print one run's figures; return its failures and whether the machine is to blame."""
    failures = list(r["failures"])
    s = r["stats"]
    label = f"{rate}/{period} smoothing {smoothing}"
    hist = s.get("histogram_5pct", [])
    top = max((i for i, n in enumerate(hist) if n), default=0)
    log(f"{label}: {int(s['callbacks'])} callbacks of {s['period_s'] * 1e3:.3f} ms; mean "
        f"{s['mean_share']:.1%}, worst {s['worst_share']:.1%} of the period (its thread's CPU "
        f"time at most {s['worst_cpu_share']:.1%}); {int(s['over_half'])} over half, "
        f"{int(s['over_period'])} over the whole period")
    log(f"{label}: callbacks by share of the period, 5 % bins: "
        + " ".join(f"{5 * i}-{5 * i + 5}%:{n}" for i, n in enumerate(hist[:top + 1]) if n))
    latency_s = 128 / 48000 if smoothing == "on" else 0.0
    for w in s["worst"][:5]:
        log(f"{label}:   {w['share']:.1%} (CPU {w['cpu_share']:.1%}) at callback {int(w['callback'])}: "
            f"{r['place'](w['at_s'], latency_s)}")
    late = ", ".join(f"{who} {n}" for who, n in sorted(r["late"].items())) or "none"
    log(f"{label}: xruns while the piece played: {r['xruns']} (before it: {r['xruns_before']}); "
        f"late in the server's log (whole run): {late}; JACK in real time: "
        f"{'yes' if r['realtime'] else 'no'}; {r['sent']} MIDI events sent; output peak {r['peak']:.3f}")
    timing = []
    if r["xruns"]:
        timing.append(f"{label}: {r['xruns']} xruns while the piece played")
    if s["worst_share"] >= args.limit:
        timing.append(f"{label}: the worst callback took {s['worst_share']:.1%} of its period "
                      f"(limit {args.limit:.0%}; {int(s['over_half'])} callbacks over half)")
    timer_late = r["late"].get("the driver's timer", 0)
    if timing and (r["xruns_alone"] or timer_late) and not args.strict:
        # Not struck's to answer for: the same server missed its period with
        # no plugin at all, or the dummy driver's own timer woke late while
        # the piece played (no client can make up for that). Said, and not
        # judged (--strict judges it anyway).
        log(f"{label}: NOT JUDGED on this machine (its server missed its period "
            f"{r['xruns_alone']} times in {args.alone_s:g} s with no plugin, and the driver's "
            f"own timer woke late {timer_late} times while the piece played): " + "; ".join(timing))
    else:
        failures += timing
    if r["sent"] != r["expected"]:
        failures.append(f"{label}: {r['sent']} of {r['expected']} MIDI events sent")
    if r["nonfinite"]:
        failures.append(f"{label}: {r['nonfinite']} cycles with non-finite output")
    if not 1e-3 < r["peak"]:
        failures.append(f"{label}: struck's output did not sound (peak {r['peak']:.2e})")
    machine = bool(failures) and not r["failures"] and s["worst_cpu_share"] < args.limit \
        and r["sent"] == r["expected"] and not r["nonfinite"] and r["peak"] > 1e-3
    return failures, machine


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("struck", help="path to the struck binary (e.g. target/release/struck)")
    ap.add_argument("--seconds", type=float, default=60.0, help="how long each run plays (default 60)")
    ap.add_argument("--configs", default="48000/64,96000/128",
                    help="JACK sample rate/period pairs (default 48000/64,96000/128)")
    ap.add_argument("--smoothing", default="on,off", help="load smoothing settings to play (default on,off)")
    ap.add_argument("--limit", type=float, default=0.5,
                    help="the worst callback's share of its period must stay below this (default 0.5)")
    ap.add_argument("--attempts", type=int, default=2,
                    help="play a failing run again (up to this many times in all) when its worst "
                         "callback's own CPU time was within the limit (default 2)")
    ap.add_argument("--alone-s", type=float, default=10.0,
                    help="seconds the server first runs with our client alone (default 10)")
    ap.add_argument("--strict", action="store_true",
                    help="judge xruns and callbacks even where the server misses its period with no plugin")
    ap.add_argument("--keep-logs", metavar="DIR", help="keep each run's logs and callback report in DIR")
    ap.add_argument("--start-timeout", type=float, default=30.0,
                    help="seconds to wait for struck's ports (default 30)")
    args = ap.parse_args()
    try:
        configs = [tuple(int(v) for v in c.split("/")) for c in args.configs.split(",")]
        assert all(len(c) == 2 and c[0] > 0 and c[1] > 0 for c in configs)
    except (ValueError, AssertionError):
        print(f"jack_live: --configs {args.configs!r}: must be RATE/PERIOD pairs separated by commas")
        return 2
    settings = args.smoothing.split(",")
    if not settings or any(s not in ("on", "off") for s in settings):
        print(f"jack_live: --smoothing {args.smoothing!r}: must be on, off or both separated by a comma")
        return 2
    if not os.access(Path(args.struck).resolve(), os.X_OK):
        print(f"jack_live: {args.struck}: not an executable")
        return 2

    events, length = piece()
    ons = sum(1 for _, d in events if d[0] == 0x90)
    log(f"the piece: {length:.2f} s a loop, {ons} strikes, played {args.seconds:g} s per run")
    all_failures = []
    summary = []
    t_start = time.monotonic()
    for rate, period in configs:
        for smoothing in settings:
            for attempt in range(1, max(args.attempts, 1) + 1):
                workdir = Path(tempfile.mkdtemp(prefix="struck-live-"))
                machine = False
                try:
                    r = run_one(args, rate, period, smoothing, workdir, attempt)
                    failures, machine = judge(args, rate, period, smoothing, r)
                    s = r["stats"]
                    summary.append(f"{rate}/{period} smoothing {smoothing:<3} attempt {attempt}: worst "
                                   f"{s['worst_share']:6.1%} (CPU {s['worst_cpu_share']:6.1%}), mean "
                                   f"{s['mean_share']:5.1%}, {int(s['over_half'])} over half, "
                                   f"{r['xruns']} xruns ({r['xruns_alone']} alone in {args.alone_s:g} s; late: "
                                   + (", ".join(f"{w} {n}" for w, n in sorted(r["late"].items())) or "none")
                                   + f"; real time: {'yes' if r['realtime'] else 'no'})")
                except Failure as exc:
                    lines = str(exc).splitlines()
                    if len(lines) > 1:
                        print("\n".join(lines[1:]))
                    failures = [f"{rate}/{period} smoothing {smoothing}: {lines[0].rstrip(':')}"]
                finally:
                    if args.keep_logs:
                        dest = Path(args.keep_logs) / f"{rate}-{period}-{smoothing}-{attempt}"
                        dest.mkdir(parents=True, exist_ok=True)
                        for f in workdir.iterdir():
                            shutil.copy(f, dest / f.name)
                    shutil.rmtree(workdir, ignore_errors=True)
                if not (failures and machine and attempt < args.attempts):
                    break
                log(f"{rate}/{period} smoothing {smoothing}: failed while the worst callback's own "
                    f"CPU time was within the limit (the machine was busy): playing it again")
            all_failures += failures
    log(f"all runs took {time.monotonic() - t_start:.0f} s")
    for line in summary:
        log(line)
    if all_failures:
        print("jack_live: FAIL: " + "; ".join(all_failures), flush=True)
        return 1
    print("jack_live: PASS", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
