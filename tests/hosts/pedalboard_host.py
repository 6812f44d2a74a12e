#!/usr/bin/env python3
"""Struck.vst3 in pedalboard, JUCE's VST3 host for Python (batch rendering, ML pipelines).

Run by `cargo xtask test` after the Rust tests (which leave the CLAP render of the same
phrase in target/host-renders/clap-phrase.wav):

    python tests/hosts/pedalboard_host.py path/to/Struck.vst3 target/host-renders/clap-phrase.wav \
        [path/to/StruckResonator.vst3]

What it asserts, each a measured property:
- load: the plugin loads in at most 2 s (its 2,080 MIDI-CC proxy parameters are named the way
  JUCE-based hosts skip; named otherwise, pedalboard probed each at 1,001 values for minutes);
  it exposes Struck's own parameters and none of the proxies;
- render: the phrase of tests/hosts/phrase.json sent as MIDI renders, sample for sample (max
  |diff| <= 1e-5), what the CLAP binary rendered for it;
- expression: MIDI CC 74 (MPE timbre: strike position) and channel pressure (damping) still
  reach the plugin through VST3, each changing the sound;
- state: a changed parameter survives `raw_state` (and a .vstpreset, `preset_data`) into a
  fresh instance, which then renders like the changed one and unlike a default one, also
  when the state is saved right after setting it, before another render;
- the effect (StruckResonator.vst3, when given): loads as an effect, which is how every host
  reaches *Audio in*; the impulse of target/host-renders/resonator-in.wav played through it
  gives, sample for sample (1e-5), what the CLAP binary gave (resonator-out.wav, written by
  tests/tests/clap_host.rs); silence in gives exact silence out.
Prints one line per check and a closing "pedalboard: N passed, M failed"; exits non-zero on
any failure.
"""

import json
import os
import sys
import time
import traceback
import wave

import numpy as np
import pedalboard

HERE = os.path.dirname(os.path.abspath(__file__))


def load_phrase():
    with open(os.path.join(HERE, "phrase.json")) as f:
        phrase = json.load(f)
    sr = phrase["sample_rate"]
    messages = []
    for n in phrase["notes"]:
        # MIDI channel 1 (status 0x90 / 0x80); times are exact in samples.
        messages.append((bytes([0x90, n["key"], n["velocity"]]), float(n["on"])))
        messages.append((bytes([0x80, n["key"], 0]), float(n["off"])))
    # Stable sort by time: at equal times the file's order, as the CLAP test sends them.
    messages.sort(key=lambda m: m[1])
    return sr, float(phrase["seconds"]), messages


def read_float_wav(path):
    """A 32-bit float WAV (what the CLAP test writes), as a (channels, samples) array."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"RIFF" or data[8:12] != b"WAVE":
        raise ValueError(f"{path} is not a RIFF/WAVE file")
    pos, fmt, samples = 12, None, None
    while pos + 8 <= len(data):
        cid, size = data[pos : pos + 4], int.from_bytes(data[pos + 4 : pos + 8], "little")
        body = data[pos + 8 : pos + 8 + size]
        if cid == b"fmt ":
            fmt = (int.from_bytes(body[0:2], "little"), int.from_bytes(body[2:4], "little"))
        elif cid == b"data":
            samples = np.frombuffer(body, dtype="<f4")
        pos += 8 + size + (size & 1)
    # Format 3 (IEEE float) or WAVE_FORMAT_EXTENSIBLE, as hound writes float files.
    if fmt is None or samples is None or fmt[0] not in (3, 0xFFFE):
        raise ValueError(f"{path}: expected 32-bit float PCM")
    channels = fmt[1]
    return samples.reshape(-1, channels).T


def render(plugin, sr, seconds, messages):
    return plugin(messages, duration=seconds, sample_rate=sr, num_channels=2, buffer_size=512, reset=True)


def main():
    vst3, clap_wav = sys.argv[1], sys.argv[2]
    fx_vst3 = sys.argv[3] if len(sys.argv) > 3 else None
    sr, seconds, messages = load_phrase()
    results = []

    def check(name, fn):
        try:
            detail = fn()
            results.append(True)
            print(f"ok   {name}: {detail}")
        except Exception as e:  # a failed check is reported, the others still run
            results.append(False)
            print(f"FAIL {name}: {e}")
            traceback.print_exc(limit=2)

    state = {}

    def load():
        t0 = time.perf_counter()
        plugin = pedalboard.load_plugin(vst3)
        took = time.perf_counter() - t0
        state["plugin"] = plugin
        names = list(plugin.parameters.keys())
        assert plugin.is_instrument, "Struck does not load as an instrument"
        assert took <= 2.0, f"loading took {took:.2f} s (> 2 s)"
        assert "size" in names and "mallet_hardness" in names, f"parameters: {names}"
        assert not any(n.startswith("midi_") for n in names), f"MIDI proxies exposed: {names}"
        return f"{took:.3f} s, {len(names)} parameters"

    def phrase_matches_clap():
        plugin = state["plugin"]
        out = render(plugin, sr, seconds, messages)
        ref = read_float_wav(clap_wav)
        assert out.shape == ref.shape, f"VST3 render {out.shape}, CLAP render {ref.shape}"
        rms = float(np.sqrt(np.mean(out.astype(np.float64) ** 2)))
        assert rms > 1e-3, f"the VST3 render is silent (RMS {rms:.2e})"
        diff = float(np.max(np.abs(out.astype(np.float64) - ref.astype(np.float64))))
        i = int(np.argmax(np.max(np.abs(out - ref), axis=0)))
        # 1e-5 (−100 dBFS), the tolerance of the CLAP-vs-offline comparison in clap_host.rs.
        # Measured 9.2e-7 before issue 11's force-pulse strike and 2.8e-6 after; the source
        # is not isolated (the offline host renders this phrase bit-identically at any block
        # size and with either rounding of velocity/127).
        assert diff <= 1e-5, f"VST3 and CLAP renders differ by {diff:.3e} (at sample {i})"
        state["phrase"] = out
        return f"max |VST3 - CLAP| = {diff:.2e}, RMS {rms:.3e}"

    def expression_reaches_the_plugin():
        plugin = state["plugin"]
        note = [(bytes([0x91, 60, 100]), 0.0)]
        plain = render(plugin, sr, 1.0, note)
        # MPE timbre on the note's member channel (2): strike position 0.9 instead of 0.3.
        timbre = render(plugin, sr, 1.0, note + [(bytes([0xB1, 74, 115]), 0.0)])
        # Channel pressure on channel 2 from 0.1 s: pressure damping (40 1/s at full).
        pressure = render(plugin, sr, 1.0, note + [(bytes([0xD1, 127]), 0.1)])
        d_timbre = float(np.max(np.abs(timbre - plain)))
        late = slice(int(0.5 * sr), int(1.0 * sr))
        e_plain = float(np.sum(plain[0, late].astype(np.float64) ** 2))
        e_pressed = float(np.sum(pressure[0, late].astype(np.float64) ** 2))
        assert d_timbre > 1e-3, f"CC 74 changed nothing (max diff {d_timbre:.2e})"
        # 40 1/s of extra decay over >= 0.4 s: at least 20 dB less energy late in the note.
        assert e_pressed < 0.01 * e_plain, f"pressure left {e_pressed / e_plain:.3f} of the late energy"
        return f"CC 74 moves the sound by {d_timbre:.2e}; pressure: late energy x{e_pressed / e_plain:.1e}"

    def parameters_take_numbers():
        # A pipeline sets parameters by value (`p.size = 2.0`). pedalboard reads a parameter's
        # texts over its range and takes it as a number only if each text parses as one
        # after a known unit suffix is stripped ("x", "%", "dB", "Hz", ...); "×1.000" and
        # "×1.000 (+0.0 st)" made Size, Stiffness and Decay scale lists of texts, and
        # `p.size = 2.0` raised ValueError (a black-box tester, stop 42).
        plugin = pedalboard.load_plugin(vst3)
        listed = {"object", "material", "damping_model", "support", "key_mode", "mallet", "pitch_reference",
                  "excitation", "texture", "contact_direction", "path_ends"}
        texts = [k for k, v in plugin.parameters.items() if v.type is str and k not in listed]
        assert not texts, f"taken as lists of texts: {texts}"
        # pedalboard sets the nearest of the values it sampled over the range (1,000 steps),
        # so a value lands within a step (0.4 % of 0.5 on Decay scale's skewed range).
        for name, value in (("size", 2.0), ("stiffness", 4.0), ("decay_scale", 0.5)):
            setattr(plugin, name, value)
            got = float(getattr(plugin, name))
            assert abs(got / value - 1.0) < 0.01, f"{name} set to {value} reads back {got}"
        big = render(plugin, sr, 0.5, [(bytes([0x90, 60, 100]), 0.0)])
        assert float(np.max(np.abs(big))) > 1e-3, "silent after setting size, stiffness and decay scale"
        return f"{len(plugin.parameters)} parameters; size 2.0, stiffness 4.0, decay scale 0.5 set by value"

    def carries_state(a, save, restore, what):
        """Changes two parameters of `a` (normalised values, as a host stores them: a larger
        object, a softer mallet), saves its state with `save`, restores it into a new
        instance with `restore`: the parameters and the render must follow."""
        a.parameters["size"].raw_value = 0.6
        a.parameters["mallet_hardness"].raw_value = 0.1
        changed = render(a, sr, seconds, messages)
        saved = save(a)
        b = pedalboard.load_plugin(vst3)
        default = render(b, sr, seconds, messages)
        restore(b, saved)
        size, hard = b.parameters["size"].raw_value, b.parameters["mallet_hardness"].raw_value
        assert abs(size - 0.6) < 1e-4, f"size is {size} (normalised) after restoring the {what}"
        assert abs(hard - 0.1) < 1e-4, f"hardness is {hard} (normalised) after restoring the {what}"
        restored = render(b, sr, seconds, messages)
        d_same = float(np.max(np.abs(restored - changed)))
        d_default = float(np.max(np.abs(default - changed)))
        assert d_same <= 1e-6, f"the restored instance differs from the changed one by {d_same:.2e}"
        assert d_default > 1e-3, f"the change made no difference ({d_default:.2e})"
        return f"{len(saved)} bytes; restored vs changed {d_same:.1e}, default vs changed {d_default:.2e}"

    def state_round_trip():
        return carries_state(state["plugin"], lambda p: p.raw_state, lambda p, s: setattr(p, "raw_state", s), "state")

    def preset_round_trip():
        # A .vstpreset as pedalboard writes and reads it (`preset_data`: JUCE's VST3 preset
        # file, restored through the component's setState alone). JUCE kept its cached
        # parameter values and sent them back at the next block, so the instance played its
        # defaults until the plugin asked the host to re-read its parameters (stop 41).
        def save(p):
            preset = p.preset_data
            assert bytes(preset[:4]) == b"VST3", f"not a .vstpreset: {bytes(preset[:4])!r}"
            return preset

        return carries_state(pedalboard.load_plugin(vst3), save, lambda p, s: setattr(p, "preset_data", s), "preset")

    def state_right_after_a_change():
        # A parameter set after a render, saved before the next one: the wrapper ignored the
        # controller's value while the plugin was processing and waited for the next process
        # call, so the state held the old value (a black-box tester, stop 53).
        a = pedalboard.load_plugin(vst3)
        render(a, sr, 0.2, messages)
        a.parameters["size"].raw_value = 0.6
        saved = a.raw_state
        b = pedalboard.load_plugin(vst3)
        b.raw_state = saved
        size = b.parameters["size"].raw_value
        assert abs(size - 0.6) < 1e-4, f"size is {size} (normalised) after restoring a state saved right after setting it"
        again = render(a, sr, seconds, messages)
        restored = render(b, sr, seconds, messages)
        d = float(np.max(np.abs(again - restored)))
        assert d <= 1e-6, f"the restored instance differs from the changed one by {d:.2e}"
        return f"size {size:.4f} restored; renders differ by {d:.1e}"

    def effect_loads():
        t0 = time.perf_counter()
        fx = pedalboard.load_plugin(fx_vst3)
        took = time.perf_counter() - t0
        state["fx"] = fx
        assert fx.is_effect and not fx.is_instrument, "Struck Resonator does not load as an effect"
        assert took <= 2.0, f"loading took {took:.2f} s (> 2 s)"
        names = list(fx.parameters.keys())
        assert "audio_in" in names and "dry_wet" in names, f"parameters: {names}"
        return f"{took:.3f} s, {len(names)} parameters"

    def effect_matches_clap():
        fx = state["fx"]
        renders = os.path.dirname(os.path.abspath(clap_wav))
        x = read_float_wav(os.path.join(renders, "resonator-in.wav"))
        ref = read_float_wav(os.path.join(renders, "resonator-out.wav"))
        out = fx.process(x, sample_rate=sr, buffer_size=512, reset=True)
        assert out.shape == ref.shape, f"VST3 render {out.shape}, CLAP render {ref.shape}"
        rms = float(np.sqrt(np.mean(out.astype(np.float64) ** 2)))
        assert rms > 1e-4, f"the effect's render is silent (RMS {rms:.2e})"
        diff = float(np.max(np.abs(out.astype(np.float64) - ref.astype(np.float64))))
        assert diff <= 1e-5, f"VST3 and CLAP renders of the impulse differ by {diff:.3e}"
        quiet = fx.process(np.zeros_like(x), sample_rate=sr, buffer_size=512, reset=True)
        assert not np.any(quiet), "silence in gave sound out"
        return f"max |VST3 - CLAP| = {diff:.2e}, RMS {rms:.3e}; silence in, silence out"

    check("loads in <= 2 s with Struck's parameters only", load)
    if "plugin" in state:
        check("the MIDI phrase renders as the CLAP binary renders it", phrase_matches_clap)
        check("MPE CC 74 and channel pressure reach the plugin", expression_reaches_the_plugin)
        check("continuous parameters are numbers to pedalboard and take values", parameters_take_numbers)
        check("raw_state carries a changed parameter into a new instance", state_round_trip)
        check("a .vstpreset (preset_data) carries a changed parameter into a new instance", preset_round_trip)
        check("a parameter set after a render is in the state saved before the next", state_right_after_a_change)
    if fx_vst3:
        check("Struck Resonator loads as an effect", effect_loads)
        if "fx" in state:
            check("an impulse through the effect plays as in the CLAP host", effect_matches_clap)
    passed, failed = sum(results), len(results) - sum(results)
    if "plugin" not in state:
        failed += 3
    if fx_vst3 and "fx" not in state:
        failed += 1
    print(f"pedalboard: {passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
