"""Whether two WAV exports (PCM or float) hold the same bytes of sound, and
that sound is not silence. usage: same_sound.py FIRST.wav SECOND.wav NAME [WHAT [UNTIL]]
(WHAT: what the second is, "the reopened session" unless given; UNTIL: compare
only the frames before this one)"""
import math
import struct
import sys


def sound(path):
    """The format and the sample bytes of a WAV file."""
    data = open(path, "rb").read()
    if data[:4] != b"RIFF" or data[8:12] != b"WAVE":
        sys.exit(f"ardour: {path}: not a WAV file")
    pos, fmt, samples = 12, None, None
    while pos + 8 <= len(data):
        kind, size = data[pos:pos + 4], struct.unpack("<I", data[pos + 4:pos + 8])[0]
        body = data[pos + 8:pos + 8 + size]
        if kind == b"fmt ":
            tag, channels, rate, _, _, bits = struct.unpack("<HHIIHH", body[:16])
            fmt = (tag, channels, rate, bits)
        elif kind == b"data":
            samples = body
        pos += 8 + size + (size & 1)
    if fmt is None or samples is None:
        sys.exit(f"ardour: {path}: no format or no samples")
    return fmt, samples


def peak_dbfs(fmt, samples):
    tag, _, _, bits = fmt
    if (tag in (3, 0xFFFE)) and bits == 32:
        values = struct.unpack(f"<{len(samples) // 4}f", samples)
    else:
        return 0.0
    peak = max(abs(v) for v in values)
    return -math.inf if peak == 0 else 20 * math.log10(peak)


first, second, name = sys.argv[1], sys.argv[2], sys.argv[3]
what = sys.argv[4] if len(sys.argv) > 4 else "the reopened session"
until = int(sys.argv[5]) if len(sys.argv) > 5 else None
(fmt_a, a), (fmt_b, b) = sound(first), sound(second)
if until is not None:
    frame_bytes = fmt_a[1] * fmt_a[3] // 8
    a, b = a[:until * frame_bytes], b[:until * frame_bytes]
if fmt_a != fmt_b or len(a) != len(b):
    sys.exit(f"ardour: {name}: the exports differ in format or length ({fmt_a}, {len(a)} against {fmt_b}, {len(b)} bytes)")
peak = peak_dbfs(fmt_a, a)
if peak < -60:
    sys.exit(f"ardour: {name}: the export is silent (peak {peak:.1f} dBFS)")
if a != b:
    frame = next(i for i in range(len(a)) if a[i] != b[i]) // (fmt_a[1] * fmt_a[3] // 8)
    sys.exit(f"ardour: {name}: {what} sounds different from frame {frame} ({frame / fmt_a[2]:.4f} s)")
print(f"ardour: {name}: {what}, the same {len(a) // (fmt_a[1] * fmt_a[3] // 8)} frames (peak {peak:.1f} dBFS)")
