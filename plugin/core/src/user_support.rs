//! The *Custom* material's support damping recorded mode by mode (issue 10 part 6) as a
//! persisted field of the parameters: kept with the project, mapped onto the object it was
//! recorded on, and handed to the audio thread without locks whenever it is set (by the
//! editor, the command line or the host loading a state), as the user texture is.

use crate::library::Library;
use crossbeam_queue::ArrayQueue;
use nice_plug::params::persist::PersistentField;
use presets::RecordedModes;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// What the engine plays: the object index and each of its modes' extra c (NaN: none).
type Mapped = Box<(Option<usize>, Vec<f64>)>;

/// The recorded per-mode support, and its handoff to the audio thread.
pub struct UserSupportField {
    library: Arc<Library>,
    /// As saved with the project (`None`: none), and how it maps onto the library. Held
    /// while a set or a restore runs, so the engine always gets the kept source's mapping.
    source: Mutex<(Option<RecordedModes>, SupportMapping)>,
    /// Setter → audio thread: the mapping to play next. At most one waits.
    pending: ArrayQueue<Mapped>,
    /// Audio thread → setter: mappings played, freed at the next set.
    done: ArrayQueue<Mapped>,
    /// Counts the sets (what a residual transfer was made for).
    generation: AtomicU64,
}

/// How a recorded support maps onto the library.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SupportMapping {
    /// The object's index, `None` if no bank of the library has its id.
    pub object: Option<usize>,
    /// Modes mapped.
    pub modes: usize,
    /// Modes left out (index out of range, or the bank's λ⁰ moved).
    pub skipped: usize,
}

impl UserSupportField {
    /// An empty field for the objects of `library`.
    pub fn new(library: Arc<Library>) -> Self {
        UserSupportField {
            library,
            source: Mutex::new((None, SupportMapping::default())),
            pending: ArrayQueue::new(2),
            done: ArrayQueue::new(4),
            generation: AtomicU64::new(0),
        }
    }

    /// How many times a recorded support was set (a residual transferred for the modes as
    /// they decay is made again when it changes). Realtime-safe (an atomic load).
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::Acquire)
    }

    /// The recorded support kept (a copy).
    pub fn source(&self) -> Option<RecordedModes> {
        self.lock().0.clone()
    }

    /// The object the kept record names and how it maps onto the library (`None`: no
    /// record).
    pub fn status(&self) -> Option<(String, SupportMapping)> {
        let g = self.lock();
        g.0.as_ref().map(|r| (r.object.clone(), g.1.clone()))
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, (Option<RecordedModes>, SupportMapping)> {
        self.source.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The engine's form of `source` on this library, and how it mapped. Allocates.
    fn map_source(&self, source: Option<&RecordedModes>) -> (Mapped, SupportMapping) {
        let Some(r) = source else {
            return (Box::new((None, Vec::new())), SupportMapping { object: None, modes: 0, skipped: 0 });
        };
        let Some(object) = self.library.bank_index(&r.object) else {
            return (Box::new((None, Vec::new())), SupportMapping { object: None, modes: 0, skipped: r.modes.len() });
        };
        let (extra, skipped) = r.map_onto(&self.library.banks[object].lambdas);
        let modes = extra.iter().filter(|x| x.is_finite()).count();
        (Box::new((Some(object), extra)), SupportMapping { object: Some(object), modes, skipped })
    }

    /// Keeps `source` with the project and queues its mapping for the audio thread
    /// (replacing one still waiting); frees the mappings the audio thread handed back. Not
    /// for the audio thread (allocates, locks).
    ///
    /// # Errors
    /// A source that does not validate (nothing changes).
    pub fn set_source(&self, source: Option<RecordedModes>) -> Result<SupportMapping, String> {
        if let Some(r) = &source {
            r.validate().map_err(|e| e.to_string())?;
        }
        let mut slot = self.lock();
        while self.done.pop().is_some() {}
        if slot.0 == source {
            // The same record (a state loaded again): nothing to hand over or transfer.
            return Ok(slot.1.clone());
        }
        let (mapped, report) = self.map_source(source.as_ref());
        while self.pending.pop().is_some() {}
        let _ = self.pending.push(mapped);
        *slot = (source, report.clone());
        self.generation.fetch_add(1, Ordering::AcqRel);
        Ok(report)
    }

    /// Gives the engine the mapping waiting, if any.
    ///
    /// # Realtime safety
    /// Lock-free queue operations and a copy into the engine's buffers; nothing is allocated
    /// or freed (a mapping is taken only while the return queue has room).
    pub fn apply(&self, engine: &mut dsp::Engine) {
        if self.done.is_full() {
            return;
        }
        if let Some(next) = self.pending.pop() {
            engine.set_recorded_support(next.0, &next.1);
            if let Err(old) = self.done.push(next) {
                std::mem::forget(old); // unreachable (room was checked): never free here
            }
        }
    }

    /// Plays the kept source in `engine` now (a new engine at activation). Allocates.
    pub fn restore(&self, engine: &mut dsp::Engine) {
        let slot = self.lock();
        while self.pending.pop().is_some() {}
        let (mapped, _) = self.map_source(slot.0.as_ref());
        engine.set_recorded_support(mapped.0, &mapped.1);
    }

    /// Sets the kept source in `engine` without touching what waits for the audio thread
    /// (another engine on the same objects: the residual worker's). Allocates.
    pub fn install(&self, engine: &mut dsp::Engine) {
        let source = self.source();
        let (mapped, _) = self.map_source(source.as_ref());
        engine.set_recorded_support(mapped.0, &mapped.1);
    }
}

impl<'a> PersistentField<'a, Option<RecordedModes>> for UserSupportField {
    fn set(&self, new_value: Option<RecordedModes>) {
        // A saved state whose recorded support does not validate loads without it.
        if self.set_source(new_value).is_err() {
            let _ = self.set_source(None);
        }
    }

    fn map<F, R>(&self, f: F) -> R
    where
        F: Fn(&Option<RecordedModes>) -> R,
    {
        f(&self.lock().0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use presets::RecordedMode;

    /// The mapping onto the library, a record naming an object the library lacks, and a
    /// state loaded again with the same record (no new generation, so no new residual
    /// transfer).
    #[test]
    fn records_map_onto_the_library_and_an_unchanged_one_is_not_handed_over_again() {
        let lib = Library::factory();
        let bar = lib.bank_index("bar").expect("factory bar");
        let l = &lib.banks[bar].lambdas;
        let field = UserSupportField::new(lib.clone());
        assert_eq!(field.generation(), 0);
        let record = |object: &str, lambda1: f64| RecordedModes {
            object: object.into(),
            modes: vec![
                RecordedMode { mode: 0, lambda: l[0], extra_c_per_s: 5.0, partials: 1 },
                RecordedMode { mode: 1, lambda: lambda1, extra_c_per_s: 9.0, partials: 2 },
            ],
        };
        let m = field.set_source(Some(record("bar", l[1]))).unwrap();
        assert_eq!(m, SupportMapping { object: Some(bar), modes: 2, skipped: 0 });
        assert_eq!(field.generation(), 1);
        assert_eq!(field.set_source(Some(record("bar", l[1]))).unwrap(), m);
        assert_eq!(field.generation(), 1, "the same record again must not be a new one");
        // A moved eigenvalue (a rebuilt bank) is left out.
        let m = field.set_source(Some(record("bar", l[1] * 1.01))).unwrap();
        assert_eq!(m, SupportMapping { object: Some(bar), modes: 1, skipped: 1 });
        assert_eq!(field.generation(), 2);
        let m = field.set_source(Some(record("teapot", l[1]))).unwrap();
        assert_eq!(m, SupportMapping { object: None, modes: 0, skipped: 2 });
        assert_eq!(field.status(), Some(("teapot".to_string(), m)));
        // An invalid record changes nothing.
        let mut bad = record("bar", l[1]);
        bad.modes[1].extra_c_per_s = -1.0;
        assert!(field.set_source(Some(bad)).is_err());
        assert_eq!(field.source().map(|r| r.object), Some("teapot".to_string()));
        field.set_source(None).unwrap();
        assert_eq!(field.status(), None);
    }
}
