"""A small reader for Gravis UltraSound patch files (.pat, as in Debian's freepats).

Layout ("GF1PATCH110"): a 129-byte file header, a 63-byte instrument header,
a 47-byte layer header, then for each sample a 96-byte header followed by its
data. Only what the validation needs is read: sample rate, root frequency,
loop points, looping flag and the data as floats.
"""

import struct

import numpy as np


class PatSample:
    def __init__(self, name, data, rate, root_hz, low_hz, high_hz, loop_start, looping):
        self.name = name
        self.data = data
        self.rate = rate
        self.root_hz = root_hz
        self.low_hz, self.high_hz = low_hz, high_hz
        self.loop_start = loop_start
        self.looping = looping


def read_pat(path):
    with open(path, "rb") as f:
        buf = f.read()
    if not buf.startswith(b"GF1PATCH1"):
        raise ValueError(f"{path}: not a GUS patch")
    n_samples = buf[129 + 63 + 6]
    off = 129 + 63 + 47
    out = []
    for _ in range(n_samples):
        h = buf[off:off + 96]
        name = h[0:7].split(b"\0", 1)[0].decode("latin-1")
        size, lstart, lend = struct.unpack_from("<III", h, 8)
        rate = struct.unpack_from("<H", h, 20)[0]
        low, high, root = struct.unpack_from("<III", h, 22)
        modes = h[55]
        data = buf[off + 96:off + 96 + size]
        off += 96 + size
        wide = modes & 1
        unsigned = modes & 2
        looping = bool(modes & 4)
        if wide:
            x = np.frombuffer(data[:len(data) // 2 * 2], "<u2" if unsigned else "<i2").astype(np.float64)
            if unsigned:
                x -= 32768
            x /= 32768.0
            ls = lstart // 2
        else:
            x = np.frombuffer(data, np.uint8 if unsigned else np.int8).astype(np.float64)
            if unsigned:
                x -= 128
            x /= 128.0
            ls = lstart
        out.append(PatSample(name, x, rate, root / 1000.0, low / 1000.0, high / 1000.0, ls, looping))
    return out
