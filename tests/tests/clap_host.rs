//! The built CLAP binary, loaded by a real CLAP host (`clack-host`), plays exactly what the
//! in-process offline host plays, and its state survives a save/load round trip.
//!
//! What this proves, beyond the in-process tests:
//! - the shipped binary exports a working `clap_entry` with a plugin factory that lists
//!   `org.struck.struck`, and the plugin instantiates, activates (48 kHz, blocks of ≤ 512) and
//!   processes through the plain C ABI: 0 audio inputs, one stereo output port;
//! - a CLAP note-on event (key 60, velocity 100/127) renders sample for sample (within 1e-5) the
//!   same 1 s as `struck_cli::cli::configured_host` with `SoundOptions::default()`, i.e. the CLAP
//!   parameter defaults are the CLI's defaults (bar, glass-ren2013) and the wrapper's event
//!   translation loses nothing;
//! - a parameter changed through the CLAP params extension (`flush`) is carried by the CLAP state
//!   extension: a second instance loading the saved state plays identically to the first, and
//!   differently from a fresh instance;
//! - the effect's binary (*Struck Resonator*, `org.struck.resonator`) has one stereo input and
//!   one stereo output port and plays an input impulse as the offline host does (1e-5);
//! - the editor, through the CLAP `gui` extension, embeds in a real X11 window (Xvfb when there
//!   is no `$DISPLAY`) at its default size, paints, follows a host resize, reopens at the size
//!   it was left at and scales with the host's `set_scale` (the host serves
//!   `request_callback`, as hosts do).
//!
//! Which binary: `$STRUCK_CLAP` if set (`cargo xtask test` bundles the debug plugin and sets
//! it to `target/test-bundled/Struck.clap`), else `target/debug/libstruck.so` (built by `cargo test`
//! as the tests' dependency), else `target/bundled/Struck.clap` (the test does not build it: run `cargo xtask bundle -p struck -p struck-resonator` or
//! `cargo build -p struck` first, or the test may exercise a stale binary).

use std::ffi::CStr;
use std::path::{Path, PathBuf};

use clack_extensions::audio_ports::{AudioPortInfoBuffer, PluginAudioPorts};
use clack_extensions::params::PluginParams;
use clack_extensions::state::PluginState;
use clack_host::events::event_types::{NoteOffEvent, NoteOnEvent, ParamValueEvent};
use clack_host::events::Match;
use clack_host::prelude::*;
use struck::offline::{note_off, note_on, TimedEvent};
use struck_cli::cli::{configured_host, note_events, NoteSpec, SoundOptions};

const PLUGIN_ID: &CStr = c"org.struck.struck";
const RESONATOR_ID: &CStr = c"org.struck.resonator";
const SAMPLE_RATE: u32 = 48_000;
const BLOCK: usize = 512;
const KEY: u8 = 60;
const VELOCITY: u8 = 100;

/// A minimal host: it offers no host extensions and ignores the plugin's requests (everything
/// runs synchronously on the test thread, so there is nothing to schedule).
struct TestHost;

struct TestHostShared {
    /// The plugin asked for `on_main_thread` (the GUI test serves it from its wait loop).
    callback_requested: std::sync::atomic::AtomicBool,
}

impl<'a> SharedHandler<'a> for TestHostShared {
    fn request_restart(&self) {}
    fn request_process(&self) {}
    fn request_callback(&self) {
        self.callback_requested.store(true, std::sync::atomic::Ordering::Release);
    }
}

impl HostHandlers for TestHost {
    type Shared<'a> = TestHostShared;
    type MainThread<'a> = ();
    type AudioProcessor<'a> = ();

    fn declare_extensions(builder: &mut HostExtensions<Self>, _shared: &Self::Shared<'_>) {
        // Hosts that show plugin GUIs offer `clap_host_gui` (nice-plug requires it).
        builder.register::<clack_extensions::gui::HostGui>();
    }
}

/// The host side of the GUI extension: the test host's window is larger than any size the
/// test uses, so every request is granted (the test shows the editor itself).
impl clack_extensions::gui::HostGuiImpl for TestHostShared {
    fn resize_hints_changed(&self) {}
    fn request_resize(&self, _new_size: clack_extensions::gui::GuiSize) -> Result<(), HostError> {
        Ok(())
    }
    fn request_show(&self) -> Result<(), HostError> {
        Ok(())
    }
    fn request_hide(&self) -> Result<(), HostError> {
        Ok(())
    }
    fn closed(&self, _was_destroyed: bool) {}
}

/// nice-plug's CLAP parameter id for a string parameter id.
fn hash_param_id(id: &str) -> u32 {
    let mut h: u32 = 0;
    for c in id.bytes() {
        h = h.wrapping_mul(31).wrapping_add(u32::from(c));
    }
    h & !(1 << 31)
}

/// `$STRUCK_CLAP`, else the debug cdylib that `cargo test` just built, else the bundle.
fn plugin_binary() -> PathBuf {
    if let Some(p) = std::env::var_os("STRUCK_CLAP") {
        let p = PathBuf::from(p);
        assert!(p.exists(), "STRUCK_CLAP={} does not exist", p.display());
        return p;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root");
    // `cargo test` builds the plugin (cdylib included) into deps/ as this crate's dependency;
    // only a direct `cargo build -p struck` updates the uplifted copy.
    let candidates = [
        root.join("target/debug/deps/libstruck.so"),
        root.join("target/debug/libstruck.so"),
        root.join("target/bundled/Struck.clap"),
    ];
    candidates.iter().find(|p| p.exists()).cloned().unwrap_or_else(|| {
        panic!(
            "no Struck CLAP binary found (looked for $STRUCK_CLAP, {}): \
             build it with `cargo xtask bundle struck` or `cargo build -p struck`",
            candidates.map(|p| p.display().to_string()).join(", ")
        )
    })
}

fn load_entry() -> PluginEntry {
    load_entry_from(&plugin_binary(), PLUGIN_ID)
}

/// The effect's binary: `$STRUCK_RESONATOR_CLAP` if set (`cargo xtask test` sets it to
/// `target/test-bundled/StruckResonator.clap`, built fresh), else the newer of the debug
/// cdylibs (`cargo build -p struck-resonator` makes them; `cargo test` alone does not, since
/// no test links the effect's crate).
fn resonator_binary() -> PathBuf {
    if let Some(p) = std::env::var_os("STRUCK_RESONATOR_CLAP") {
        let p = PathBuf::from(p);
        assert!(p.exists(), "STRUCK_RESONATOR_CLAP={} does not exist", p.display());
        return p;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root");
    let candidates =
        [root.join("target/debug/libstruck_resonator.so"), root.join("target/debug/deps/libstruck_resonator.so")];
    let modified = |p: &PathBuf| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    candidates.iter().filter(|p| p.exists()).max_by_key(|p| modified(p)).cloned().unwrap_or_else(|| {
        panic!(
            "no Struck Resonator CLAP binary found (looked for $STRUCK_RESONATOR_CLAP, {}): \
             build it with `cargo build -p struck-resonator`",
            candidates.map(|p| p.display().to_string()).join(", ")
        )
    })
}

fn load_entry_from(path: &Path, id: &CStr) -> PluginEntry {
    println!("loading CLAP plugin binary {}", path.display());
    // SAFETY: the file is Struck's own build output, a CLAP binary made by nice-plug, whose
    // `clap_entry` follows the CLAP ABI that clack relies on.
    let entry = unsafe { PluginEntry::load(path) }.unwrap_or_else(|e| panic!("cannot load {}: {e}", path.display()));
    let factory = entry.get_plugin_factory().expect("the entry has no plugin factory");
    let ids: Vec<String> =
        factory.plugin_descriptors().filter_map(|d| d.id()).map(|id| id.to_string_lossy().into_owned()).collect();
    assert!(ids.iter().any(|i| i.as_bytes() == id.to_bytes()), "plugin factory lists {ids:?}, not {id:?}");
    entry
}

fn instantiate(entry: &PluginEntry) -> PluginInstance<TestHost> {
    instantiate_id(entry, PLUGIN_ID)
}

fn instantiate_id(entry: &PluginEntry, id: &CStr) -> PluginInstance<TestHost> {
    let info = HostInfo::new("struck-tests", "Struck developers", "https://example.invalid/struck", "0.1.0").unwrap();
    PluginInstance::<TestHost>::new(|_| TestHostShared { callback_requested: false.into() }, |_| (), entry, id, &info)
        .unwrap_or_else(|e| panic!("instantiate {id:?}: {e}"))
}

/// A note event of a test phrase: note-on (key, velocity 1..=127) or note-off (key).
#[derive(Clone, Copy, Debug)]
enum Note {
    On(u8, u8),
    Off(u8),
}

/// Activates `instance` (48 kHz, blocks of at most 512), renders `num_samples` of stereo output
/// with one note-on (key 60, velocity 100/127) at sample 0, and deactivates it again.
fn render_note(instance: &mut PluginInstance<TestHost>, num_samples: usize) -> [Vec<f32>; 2] {
    render_events(instance, num_samples, &[(0, Note::On(KEY, VELOCITY))])
}

/// Activates `instance` (48 kHz, blocks of at most 512), renders `num_samples` of stereo output
/// with `notes` (sorted by sample; MIDI channel 1, no note ids, as a MIDI host sends them) at
/// their exact samples, and deactivates it again.
fn render_events(
    instance: &mut PluginInstance<TestHost>,
    num_samples: usize,
    notes: &[(usize, Note)],
) -> [Vec<f32>; 2] {
    render_blocks(instance, num_samples, notes, None)
}

/// Activates `instance` (48 kHz, blocks of at most 512), plays `input` (stereo) through its
/// stereo input port with no events, and deactivates it again; the output.
fn render_through(instance: &mut PluginInstance<TestHost>, input: &[Vec<f32>; 2]) -> [Vec<f32>; 2] {
    render_blocks(instance, input[0].len(), &[], Some(input))
}

/// [`render_events`] with `input` (stereo) on the input port, if given, else none. Output
/// buffers are filled with NaN before each call: the plugin must write every sample.
fn render_blocks(
    instance: &mut PluginInstance<TestHost>,
    num_samples: usize,
    notes: &[(usize, Note)],
    input: Option<&[Vec<f32>; 2]>,
) -> [Vec<f32>; 2] {
    let config = PluginAudioConfiguration {
        sample_rate: f64::from(SAMPLE_RATE),
        min_frames_count: 1,
        max_frames_count: BLOCK as u32,
    };
    let stopped = instance.activate(|_, _| (), config).expect("activate");
    let mut processor = stopped.start_processing().expect("start processing");

    let mut in_events = EventBuffer::with_capacity(notes.len());
    // The plugin reports NOTE_END (and possibly other events) back: collect and drop them.
    let mut out_events = EventBuffer::with_capacity(256);
    let mut block = [vec![0.0f32; BLOCK], vec![0.0f32; BLOCK]];
    let mut block_in = [vec![0.0f32; BLOCK], vec![0.0f32; BLOCK]];
    let mut input_ports = AudioPorts::with_capacity(2, 1);
    let mut output_ports = AudioPorts::with_capacity(2, 1);
    let mut out = [Vec::with_capacity(num_samples), Vec::with_capacity(num_samples)];

    let mut pos = 0;
    let mut next = 0;
    while pos < num_samples {
        let n = BLOCK.min(num_samples - pos);
        in_events.clear();
        while next < notes.len() && notes[next].0 < pos + n {
            let (at, note) = notes[next];
            let time = (at - pos) as u32;
            match note {
                Note::On(key, velocity) => {
                    // What the offline host sends: velocity / 127 in f32.
                    let v = f64::from(f32::from(velocity) / 127.0);
                    in_events.push(&NoteOnEvent::new(time, Pckn::new(0u16, 0u16, u16::from(key), Match::All), v));
                }
                Note::Off(key) => {
                    in_events.push(&NoteOffEvent::new(time, Pckn::new(0u16, 0u16, u16::from(key), Match::All), 0.0));
                }
            }
            next += 1;
        }
        out_events.clear();
        for ch in &mut block {
            ch.fill(f32::NAN);
        }
        let audio_in = match input {
            Some(x) => {
                for (b, x) in block_in.iter_mut().zip(x) {
                    b[..n].copy_from_slice(&x[pos..pos + n]);
                }
                input_ports.with_input_buffers([AudioPortBuffer {
                    latency: 0,
                    channels: AudioPortBufferType::f32_input_only(
                        block_in.iter_mut().map(|ch| InputChannel::variable(&mut ch[..n])),
                    ),
                }])
            }
            None => InputAudioBuffers::empty(),
        };
        let mut audio_out = output_ports.with_output_buffers([AudioPortBuffer {
            latency: 0,
            channels: AudioPortBufferType::f32_output_only(block.iter_mut().map(|ch| &mut ch[..n])),
        }]);
        processor
            .process(
                &audio_in,
                &mut audio_out,
                &in_events.as_input(),
                &mut out_events.as_output(),
                Some(pos as u64),
                None,
            )
            .expect("process");
        for (o, b) in out.iter_mut().zip(&block) {
            o.extend_from_slice(&b[..n]);
        }
        pos += n;
    }

    instance.deactivate(processor.stop_processing());
    out
}

fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|&s| f64::from(s) * f64::from(s)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Largest |a - b| over both channels, with the index and channel where it occurs.
fn max_diff(a: &[Vec<f32>; 2], b: &[Vec<f32>; 2]) -> (f32, usize, usize) {
    let mut worst = (0.0f32, 0, 0);
    for ch in 0..2 {
        assert_eq!(a[ch].len(), b[ch].len(), "channel {ch} lengths differ");
        for (i, (x, y)) in a[ch].iter().zip(&b[ch]).enumerate() {
            let d = (x - y).abs();
            if d > worst.0 || d.is_nan() {
                worst = (d, i, ch);
            }
        }
    }
    worst
}

/// The tests of this file one at a time: the GUI test's X11/OpenGL start-up and another
/// test loading the same plugin binary at once crashed the process once (SIGSEGV, a loaded
/// machine); each test holds this lock.
fn serial() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

#[test]
fn clap_binary_matches_offline_host_and_round_trips_state() {
    let _one_at_a_time = serial();
    let started = std::time::Instant::now();
    let entry = load_entry();
    let num_samples = SAMPLE_RATE as usize; // 1.0 s

    // --- Ports: an instrument with no audio input and one stereo output. ---
    let mut a = instantiate(&entry);
    {
        let ports: PluginAudioPorts = a.plugin_shared_handle().get_extension().expect("no audio-ports extension");
        let handle = a.plugin_handle();
        assert_eq!(ports.count(&handle, true), 0, "audio input ports");
        assert_eq!(ports.count(&handle, false), 1, "audio output ports");
        let mut port_buf = AudioPortInfoBuffer::new();
        let port = ports.get(&handle, 0, false, &mut port_buf).expect("output port 0 info");
        assert_eq!(port.channel_count, 2, "output port channels");
    }

    // --- 1. The CLAP binary plays what the offline host plays. ---
    let clap_default = render_note(&mut a, num_samples);
    let mut offline = configured_host(&SoundOptions::default(), BLOCK).unwrap();
    let events = note_events(
        &[NoteSpec { key: KEY, velocity: VELOCITY, position: None, start_s: 0.0, duration_s: None }],
        f64::from(SAMPLE_RATE),
    );
    let (reference, _sent) = offline.render(&events, num_samples, BLOCK);

    let (r0, r1) = (rms(&clap_default[0]), rms(&clap_default[1]));
    println!("CLAP render RMS: L {r0:.3e}, R {r1:.3e}; offline RMS: L {:.3e}", rms(&reference[0]));
    assert!(r0 > 1e-4 && r1 > 1e-4, "the CLAP render is silent (RMS L {r0:e}, R {r1:e})");
    let (d, i, ch) = max_diff(&clap_default, &reference);
    println!("CLAP vs offline: max |diff| {d:.3e}");
    assert!(
        d <= 1e-5,
        "CLAP and offline renders differ by {d:e} at channel {ch}, sample {i} (CLAP {}, offline {})",
        clap_default[ch][i],
        reference[ch][i]
    );

    // --- 2. State round trip through the state extension. ---
    // Move the strike position (plain value, 0..1, default 0.3) with a param-value event, flushed
    // through the params extension while the instance is inactive.
    let pos_id = ClapId::new(hash_param_id("pos"));
    let params: PluginParams = a.plugin_shared_handle().get_extension().expect("no params extension");
    let change = ParamValueEvent::new(0, pos_id, Pckn::match_all(), 0.8);
    let mut in_events = EventBuffer::new();
    in_events.push(&change);
    let mut out_events = EventBuffer::new();
    let mut inactive = a.inactive_plugin_handle().expect("instance A is inactive");
    params.flush(&mut inactive, &in_events.as_input(), &mut out_events.as_output());
    let now = params.get_value(&a.plugin_handle(), pos_id).expect("value of \"pos\"");
    assert!((now - 0.8).abs() < 1e-6, "\"pos\" is {now} after the flush, expected 0.8");

    let state: PluginState = a.plugin_shared_handle().get_extension().expect("no state extension");
    let mut saved = Vec::new();
    state.save(&a.plugin_handle(), &mut saved).expect("save state of A");
    assert!(!saved.is_empty(), "empty saved state");

    let mut b = instantiate(&entry);
    let state_b: PluginState = b.plugin_shared_handle().get_extension().expect("no state extension");
    state_b.load(&b.plugin_handle(), &mut saved.as_slice()).expect("load state into B");
    let params_b: PluginParams = b.plugin_shared_handle().get_extension().expect("no params extension");
    let loaded = params_b.get_value(&b.plugin_handle(), pos_id).expect("value of \"pos\" in B");
    assert!((loaded - 0.8).abs() < 1e-6, "\"pos\" is {loaded} in B after loading A's state, expected 0.8");

    let from_a = render_note(&mut a, num_samples);
    let from_b = render_note(&mut b, num_samples);
    assert!(rms(&from_b[0]) > 1e-4, "instance B's render is silent");
    let (d, i, ch) = max_diff(&from_a, &from_b);
    println!("A vs B (A's state): max |diff| {d:.3e}");
    assert!(d <= 1e-6, "A and B (A's state) differ by {d:e} at channel {ch}, sample {i}");
    let (d, _, _) = max_diff(&from_b, &clap_default);
    println!("state carried a change: B differs from the default render by up to {d:.3e}");
    assert!(
        d > 1e-3,
        "B (strike position 0.8) plays like a default instance (max diff {d:e}): the state carried nothing"
    );

    println!("clap_host test body took {:.2?}", started.elapsed());
}

/// The phrase every host renders (tests/hosts/phrase.json): (sample, note) pairs, sorted,
/// and its length in samples.
fn host_phrase() -> (Vec<(usize, Note)>, usize) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("hosts/phrase.json")).expect("tests/hosts/phrase.json");
    let v: serde_json::Value = serde_json::from_str(&text).expect("phrase.json is JSON");
    assert_eq!(v["sample_rate"].as_u64(), Some(u64::from(SAMPLE_RATE)), "phrase sample rate");
    let sr = f64::from(SAMPLE_RATE);
    let at = |x: &serde_json::Value| (x.as_f64().expect("a time in seconds") * sr).round() as usize;
    let mut notes = Vec::new();
    for n in v["notes"].as_array().expect("notes") {
        let key = n["key"].as_u64().expect("key") as u8;
        notes.push((at(&n["on"]), Note::On(key, n["velocity"].as_u64().expect("velocity") as u8)));
        notes.push((at(&n["off"]), Note::Off(key)));
    }
    // Stable: at equal times, the phrase file's order.
    notes.sort_by_key(|(t, _)| *t);
    (notes, at(&v["seconds"]))
}

/// The CLAP binary renders the host phrase as the offline host does, and leaves it in
/// `target/host-renders/clap-phrase.wav` (32-bit float, stereo) for the VST3 host test
/// (tests/hosts/pedalboard_host.py), which must render the same through VST3.
#[test]
fn clap_binary_renders_the_host_phrase() {
    let _one_at_a_time = serial();
    let entry = load_entry();
    let (notes, num_samples) = host_phrase();
    let mut a = instantiate(&entry);
    let clap = render_events(&mut a, num_samples, &notes);

    let mut offline = configured_host(&SoundOptions::default(), BLOCK).unwrap();
    let events: Vec<TimedEvent> = notes
        .iter()
        .map(|&(at, note)| TimedEvent {
            sample: at as u64,
            event: match note {
                Note::On(key, velocity) => note_on(key, f32::from(velocity) / 127.0),
                Note::Off(key) => note_off(key),
            },
        })
        .collect();
    let (reference, _) = offline.render(&events, num_samples, BLOCK);
    assert!(rms(&clap[0]) > 1e-3, "the CLAP render of the phrase is silent");
    let (d, i, ch) = max_diff(&clap, &reference);
    println!("phrase: CLAP vs offline max |diff| {d:.3e}");
    assert!(d <= 1e-5, "phrase: CLAP and offline differ by {d:e} at channel {ch}, sample {i}");

    write_host_render("clap-phrase.wav", &clap);
}

/// Writes `audio` as `target/host-renders/NAME` (32-bit float, stereo) for the VST3 host test.
fn write_host_render(name: &str, audio: &[Vec<f32>; 2]) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").join("target/host-renders");
    std::fs::create_dir_all(&dir).expect("create target/host-renders");
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate: SAMPLE_RATE,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let tmp = dir.join(format!("{name}.tmp"));
    let mut w = hound::WavWriter::create(&tmp, spec).expect("create the WAV");
    for (l, r) in audio[0].iter().zip(&audio[1]) {
        w.write_sample(*l).and_then(|()| w.write_sample(*r)).expect("write the WAV");
    }
    w.finalize().expect("finish the WAV");
    std::fs::rename(&tmp, dir.join(name)).expect("rename the WAV");
}

/// The effect's binary, *Struck Resonator*, in a real CLAP host: one stereo input and one
/// stereo output port; an input impulse plays, sample for sample (1e-5), what the offline host
/// plays through the plugin's `process()` (which `audio_in.rs` checks against the closed-form
/// sum of the modes), in the impulse's own sample; silence in gives exact silence out. Leaves
/// the input and the output in `target/host-renders/resonator-{in,out}.wav` for the VST3 host
/// test, which must play the same.
#[test]
fn the_resonator_binary_rings_the_object_from_its_input() {
    let _one_at_a_time = serial();
    let entry = load_entry_from(&resonator_binary(), RESONATOR_ID);
    let mut fx = instantiate_id(&entry, RESONATOR_ID);
    {
        let ports: PluginAudioPorts = fx.plugin_shared_handle().get_extension().expect("no audio-ports extension");
        let handle = fx.plugin_handle();
        assert_eq!(ports.count(&handle, true), 1, "audio input ports");
        assert_eq!(ports.count(&handle, false), 1, "audio output ports");
        let mut port_buf = AudioPortInfoBuffer::new();
        for is_input in [true, false] {
            let port = ports.get(&handle, 0, is_input, &mut port_buf).expect("port 0 info");
            assert_eq!(port.channel_count, 2, "port channels (input: {is_input})");
        }
    }
    let n = SAMPLE_RATE as usize / 2;
    let at = 1_000;
    let mut impulse = vec![0.0f32; n];
    impulse[at] = 0.5;
    let input = [impulse.clone(), impulse.iter().map(|x| 0.5 * x).collect()];
    let clap = render_through(&mut fx, &input);
    let mut offline =
        struck::offline::OfflineHost::with_plugin(struck::StruckResonator::default(), SAMPLE_RATE as f32, BLOCK)
            .expect("offline host");
    offline.set_input(input[0].clone(), input[1].clone());
    let (reference, _) = offline.render(&[], n, BLOCK);
    assert!(clap.iter().all(|ch| ch[..at].iter().all(|&y| y == 0.0)), "output before the impulse");
    assert!(clap[0][at] != 0.0, "no output in the impulse's sample (latency)");
    assert!(rms(&clap[0]) > 1e-4, "the resonator's render is silent");
    let (d, i, ch) = max_diff(&clap, &reference);
    println!("resonator: CLAP vs offline max |diff| {d:.3e}, RMS {:.3e}", rms(&clap[0]));
    assert!(d <= 1e-5, "resonator: CLAP and offline differ by {d:e} at channel {ch}, sample {i}");
    write_host_render("resonator-in.wav", &input);
    write_host_render("resonator-out.wav", &clap);

    let silence = [vec![0.0f32; n], vec![0.0f32; n]];
    let quiet = render_through(&mut fx, &silence);
    assert!(quiet.iter().all(|ch| ch.iter().all(|&y| y == 0.0)), "silence in, sound out");
}

/// An X server for the GUI test: `$DISPLAY` if set, else a private Xvfb that ends itself when
/// its last client disconnects (`-terminate`), not killed by the test: a connection the
/// plugin's editor stack still holds after the editor closed (Xlib's, whose I/O error handler
/// exits the process when the server goes away) would otherwise end this test binary while
/// another test runs. At the latest it ends when this process exits.
struct XServer(#[allow(dead_code)] Option<std::process::Child>);

fn x_server() -> XServer {
    if std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) {
        return XServer(None);
    }
    // `-displayfd 1`: Xvfb picks a free display number and writes it to stdout when ready.
    let mut child = std::process::Command::new("Xvfb")
        .args(["-displayfd", "1", "-screen", "0", "2400x1600x24", "-nolisten", "tcp", "-terminate"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap_or_else(|e| {
            panic!("no $DISPLAY and Xvfb cannot start ({e}): install the `xvfb` package (.ci/run does), or run with a display")
        });
    let mut line = String::new();
    {
        use std::io::BufRead;
        let out = child.stdout.take().expect("Xvfb stdout");
        std::io::BufReader::new(out).read_line(&mut line).expect("read Xvfb's display number");
    }
    let n: u32 = line.trim().parse().unwrap_or_else(|_| panic!("Xvfb did not report a display number (got {line:?})"));
    // Only this test in this binary talks to X, and it sets DISPLAY before any connection.
    std::env::set_var("DISPLAY", format!(":{n}"));
    XServer(Some(child))
}

/// Polls `f` every 50 ms for up to 15 s, serving the plugin's main-thread callback requests
/// in between, as a host's event loop does.
fn wait_for<T>(plugin: &mut PluginInstance<TestHost>, what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let t0 = std::time::Instant::now();
    loop {
        if plugin.access_shared_handler(|h| h.callback_requested.swap(false, std::sync::atomic::Ordering::AcqRel)) {
            plugin.call_on_main_thread_callback();
        }
        if let Some(v) = f() {
            return v;
        }
        assert!(t0.elapsed().as_secs() < 15, "timed out waiting for {what}");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

/// The editor in a real X11 window, as a CLAP host embeds it: the built binary's `gui`
/// extension creates the editor at its default size, embeds it in the host's window and
/// paints it (OpenGL through Mesa); the host resizes it; it reopens at the size it was left
/// at; the host's scale factor scales it. A screenshot of the host window is saved to
/// `target/tmp/editor-screenshots/clap-host-window.png`.
#[test]
fn the_editor_opens_in_a_host_window_resizes_and_reopens_at_its_size() {
    let _one_at_a_time = serial();
    use clack_extensions::gui::{GuiApiType, GuiConfiguration, GuiSize, PluginGui, Window as ClapWindow};
    use x11rb::connection::Connection;
    use x11rb::protocol::xproto::{ConnectionExt, CreateWindowAux, ImageFormat, WindowClass};

    let _x = x_server();
    let (conn, screen_num) = x11rb::connect(None).expect("connect to the X server");
    let screen = &conn.setup().roots[screen_num];
    let (depth, root, black) = (screen.root_depth, screen.root, screen.black_pixel);
    let host_window = conn.generate_id().expect("x id");
    conn.create_window(
        depth,
        host_window,
        root,
        0,
        0,
        2000,
        1400,
        0,
        WindowClass::INPUT_OUTPUT,
        0,
        &CreateWindowAux::new().background_pixel(black),
    )
    .expect("create the host window");
    conn.map_window(host_window).expect("map");
    conn.flush().expect("flush");

    let entry = load_entry();
    let mut plugin = instantiate(&entry);
    let gui: PluginGui = plugin.plugin_shared_handle().get_extension().expect("no gui extension");
    let cfg = GuiConfiguration { api_type: GuiApiType::X11, is_floating: false };
    assert!(gui.is_api_supported(&plugin.plugin_handle(), cfg), "X11 embedding is not supported");
    let children = |conn: &x11rb::rust_connection::RustConnection| {
        conn.query_tree(host_window).expect("query").reply().expect("tree").children
    };
    let geometry = |conn: &x11rb::rust_connection::RustConnection, w: u32| {
        let g = conn.get_geometry(w).expect("geometry").reply().expect("geometry reply");
        (u32::from(g.width), u32::from(g.height))
    };

    // Open: the default size, embedded in the host window, painted.
    gui.create(&plugin.plugin_handle(), cfg).expect("create the editor");
    let size = gui.get_size(&plugin.plugin_handle()).expect("editor size");
    assert_eq!((size.width, size.height), (1040, 720), "default editor size");
    assert!(gui.can_resize(&plugin.plugin_handle()));
    // SAFETY: `host_window` stays alive until after `destroy`.
    unsafe { gui.set_parent(&plugin.plugin_handle(), ClapWindow::from_x11_handle(host_window.into())) }
        .expect("embed the editor");
    gui.show(&plugin.plugin_handle()).expect("show");
    let editor =
        wait_for(&mut plugin, "the editor's window inside the host window", || children(&conn).first().copied());
    assert_eq!(geometry(&conn, editor), (1040, 720), "the embedded window has the size the plugin reported");
    // Painted: the egui frame has text, panels and plots, i.e. many distinct colours.
    let (pixels, colours) = wait_for(&mut plugin, "the editor to paint", || {
        let img = conn.get_image(ImageFormat::Z_PIXMAP, host_window, 0, 0, 1040, 720, !0).ok()?.reply().ok()?;
        let data = img.data;
        let mut seen = std::collections::HashSet::new();
        for px in data.chunks_exact(4) {
            seen.insert((px[0], px[1], px[2]));
        }
        (seen.len() > 50).then_some((data, seen.len()))
    });
    println!("editor painted with {colours} distinct colours");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/tmp/editor-screenshots");
    std::fs::create_dir_all(&dir).expect("screenshot folder");
    let rgb: Vec<u8> = pixels.chunks_exact(4).flat_map(|p| [p[2], p[1], p[0]]).collect();
    image::save_buffer(dir.join("clap-host-window.png"), &rgb, 1040, 720, image::ExtendedColorType::Rgb8)
        .expect("save screenshot");

    // The host resizes the editor.
    gui.set_size(&plugin.plugin_handle(), GuiSize { width: 1200, height: 800 }).expect("set_size");
    wait_for(&mut plugin, "the editor window to take the new size", || {
        (geometry(&conn, editor) == (1200, 800)).then_some(())
    });
    gui.destroy(&plugin.plugin_handle());
    wait_for(&mut plugin, "the editor window to close", || children(&conn).is_empty().then_some(()));

    // Reopened: at the size it was left at.
    gui.create(&plugin.plugin_handle(), cfg).expect("create again");
    let size = gui.get_size(&plugin.plugin_handle()).expect("editor size");
    assert_eq!((size.width, size.height), (1200, 800), "the editor reopens at its last size");

    // Scaled by the host (X11 has no system scale: hosts call set_scale): the window and the
    // reported size grow by the factor, the logical size stays.
    // SAFETY: as above.
    unsafe { gui.set_parent(&plugin.plugin_handle(), ClapWindow::from_x11_handle(host_window.into())) }
        .expect("embed again");
    gui.show(&plugin.plugin_handle()).expect("show again");
    let editor = wait_for(&mut plugin, "the reopened editor's window", || children(&conn).first().copied());
    assert_eq!(geometry(&conn, editor), (1200, 800));
    assert!(gui.set_scale(&plugin.plugin_handle(), 1.5).is_ok(), "set_scale refused");
    wait_for(&mut plugin, "the editor window to scale by 1.5", || {
        (geometry(&conn, editor) == (1800, 1200)).then_some(())
    });
    let size = gui.get_size(&plugin.plugin_handle()).expect("editor size");
    assert_eq!((size.width, size.height), (1800, 1200), "get_size after set_scale(1.5)");
    gui.destroy(&plugin.plugin_handle());
    drop(plugin);
    conn.destroy_window(host_window).expect("destroy");
    conn.flush().expect("flush");
}
