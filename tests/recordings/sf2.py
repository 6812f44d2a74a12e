"""A small SoundFont 2 reader (written for Struck's recording validation).

Reads only what the validation needs: the preset / instrument / sample
hierarchy with key and velocity ranges, sample modes (looping) and the raw
16-bit (optionally 24-bit) sample data of one sample. No synthesis, no
modulators. Spec: SoundFont 2.04, sections 5-8 (RIFF 'sfbk', 'pdta' records).
"""

import struct

import numpy as np

# Generator numbers (SF2.04 section 8.1.2)
GEN_START_OFS = 0
GEN_END_OFS = 1
GEN_STARTLOOP_OFS = 2
GEN_ENDLOOP_OFS = 3
GEN_START_COARSE = 4
GEN_END_COARSE = 12
GEN_STARTLOOP_COARSE = 45
GEN_ENDLOOP_COARSE = 50
GEN_INSTRUMENT = 41
GEN_KEYRANGE = 43
GEN_VELRANGE = 44
GEN_SAMPLEID = 53
GEN_SAMPLEMODES = 54
GEN_ROOTKEY = 58


class Sample:
    def __init__(self, idx, name, start, end, sloop, eloop, rate, pitch, corr, link, stype):
        self.idx = idx
        self.name = name
        self.start, self.end = start, end
        self.sloop, self.eloop = sloop, eloop
        self.rate = rate
        self.pitch, self.corr = pitch, corr
        self.link, self.type = link, stype


class Zone:
    """One instrument zone as reached from a preset: merged generators."""

    def __init__(self, gens):
        self.gens = gens

    def range(self, gen):
        v = self.gens.get(gen)
        if v is None:
            return (0, 127)
        return (v & 0xFF, (v >> 8) & 0xFF)

    def signed(self, gen):
        v = self.gens.get(gen, 0)
        return v - 0x10000 if v >= 0x8000 else v

    @property
    def sample_id(self):
        return self.gens.get(GEN_SAMPLEID)

    @property
    def sample_modes(self):
        return self.gens.get(GEN_SAMPLEMODES, 0) & 3


def _chunks(buf, off, end):
    while off + 8 <= end:
        cid = buf[off:off + 4].decode("latin-1")
        size = struct.unpack_from("<I", buf, off + 4)[0]
        yield cid, off + 8, size
        off += 8 + size + (size & 1)


def _name(b):
    return b.split(b"\0", 1)[0].decode("latin-1").strip()


class SoundFont:
    def __init__(self, path):
        with open(path, "rb") as f:
            self.buf = buf = f.read()
        if buf[0:4] != b"RIFF" or buf[8:12] != b"sfbk":
            raise ValueError(f"{path}: not a SoundFont 2 file")
        self.smpl = None
        self.sm24 = None
        pdta = {}
        for cid, off, size in _chunks(buf, 12, len(buf)):
            if cid != "LIST":
                continue
            kind = buf[off:off + 4]
            for sid, soff, ssize in _chunks(buf, off + 4, off + size):
                if kind == b"sdta" and sid == "smpl":
                    self.smpl = (soff, ssize)
                elif kind == b"sdta" and sid == "sm24":
                    self.sm24 = (soff, ssize)
                elif kind == b"pdta":
                    pdta[sid] = (soff, ssize)
        if self.smpl is None:
            raise ValueError(f"{path}: no sample data")
        self._parse_pdta(pdta)

    def _records(self, pdta, cid, fmt):
        off, size = pdta[cid]
        n = struct.calcsize(fmt)
        return [struct.unpack_from(fmt, self.buf, off + i * n) for i in range(size // n)]

    def _parse_pdta(self, pdta):
        phdr = self._records(pdta, "phdr", "<20sHHHIII")
        pbag = self._records(pdta, "pbag", "<HH")
        pgen = self._records(pdta, "pgen", "<HH")
        inst = self._records(pdta, "inst", "<20sH")
        ibag = self._records(pdta, "ibag", "<HH")
        igen = self._records(pdta, "igen", "<HH")
        shdr = self._records(pdta, "shdr", "<20sIIIIIBbHH")
        self.samples = [Sample(i, _name(r[0]), *r[1:]) for i, r in enumerate(shdr[:-1])]

        def zones(hdrs, bags, gens, i, col):
            b0, b1 = hdrs[i][col], hdrs[i + 1][col]
            out = []
            for b in range(b0, b1):
                g0, g1 = bags[b][0], bags[b + 1][0]
                out.append({op: amt for op, amt in gens[g0:g1]})
            return out

        self.instruments = []
        for i in range(len(inst) - 1):
            zs = zones(inst, ibag, igen, i, 1)
            glob = {}
            if zs and GEN_SAMPLEID not in zs[0]:
                glob = zs.pop(0)
            merged = []
            for z in zs:
                m = dict(glob)
                m.update(z)
                merged.append(m)
            self.instruments.append((_name(inst[i][0]), merged))

        self.presets = {}
        for i in range(len(phdr) - 1):
            name, prog, bank = _name(phdr[i][0]), phdr[i][1], phdr[i][2]
            zs = zones(phdr, pbag, pgen, i, 3)
            glob = {}
            if zs and GEN_INSTRUMENT not in zs[0]:
                glob = zs.pop(0)
            self.presets[(bank, prog)] = (name, [_merge(glob, z) for z in zs])

    def preset_zones(self, bank, prog):
        """Instrument zones reachable from a preset, each as a Zone with the
        key/velocity ranges intersected with the preset zone's and the
        instrument zone's own sample generators."""
        name, pzones = self.presets[(bank, prog)]
        out = []
        for pz in pzones:
            ii = pz.get(GEN_INSTRUMENT)
            if ii is None:
                continue
            iname, izones = self.instruments[ii]
            pk = _rng(pz.get(GEN_KEYRANGE))
            pv = _rng(pz.get(GEN_VELRANGE))
            for iz in izones:
                ik = _rng(iz.get(GEN_KEYRANGE))
                iv = _rng(iz.get(GEN_VELRANGE))
                k = (max(pk[0], ik[0]), min(pk[1], ik[1]))
                v = (max(pv[0], iv[0]), min(pv[1], iv[1]))
                if k[0] > k[1] or v[0] > v[1]:
                    continue
                z = Zone(dict(iz))
                z.key, z.vel, z.instrument = k, v, iname
                out.append(z)
        return name, out

    def sample_data(self, sample, zone=None):
        """Float samples in [-1, 1) of one sample, from its start (plus the
        zone's start offset) to its end. Returns (x, loop_start_index or None)."""
        start, end = sample.start, sample.end
        sloop = sample.sloop
        if zone is not None:
            start += zone.signed(GEN_START_OFS) + 32768 * zone.signed(GEN_START_COARSE)
            end += zone.signed(GEN_END_OFS) + 32768 * zone.signed(GEN_END_COARSE)
            sloop += zone.signed(GEN_STARTLOOP_OFS) + 32768 * zone.signed(GEN_STARTLOOP_COARSE)
        off, size = self.smpl
        start = max(0, min(start, size // 2))
        end = max(start, min(end, size // 2))
        x = np.frombuffer(self.buf, dtype="<i2", count=end - start, offset=off + 2 * start).astype(np.int32) << 8
        if self.sm24 is not None:
            o24, s24 = self.sm24
            if end <= s24:
                lo = np.frombuffer(self.buf, dtype=np.uint8, count=end - start, offset=o24 + start)
                x = x | lo.astype(np.int32)
        x = x.astype(np.float64) / float(1 << 23)
        looping = zone is not None and zone.sample_modes in (1, 3)
        loop = sloop - start if looping and start < sloop < end else None
        return x, loop


def _rng(v):
    if v is None:
        return (0, 127)
    return (v & 0xFF, (v >> 8) & 0xFF)


def _merge(glob, z):
    m = dict(glob)
    m.update(z)
    return m
