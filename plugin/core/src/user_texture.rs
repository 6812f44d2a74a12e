//! The user's texture (issue 16) as a persisted field of the parameters: kept with the
//! project, and handed to the audio thread without locks whenever it is set, by the editor, by
//! the command line or by the host loading a state (nice-plug calls [`PersistentField::set`]
//! then, on a non-audio thread).

use crossbeam_queue::ArrayQueue;
use dsp::contact::Texture;
use nice_plug::params::persist::PersistentField;
use presets::texture::TextureFile;
use std::sync::Mutex;

/// The user's texture file, and its handoff to the audio thread.
pub struct UserTextureField {
    /// The file as saved with the project (`None`: no user texture).
    file: Mutex<Option<TextureFile>>,
    /// Setter → audio thread: the texture to play next (`None`: none). At most one waits:
    /// each set replaces what is still waiting.
    pending: ArrayQueue<Option<Box<Texture>>>,
    /// Audio thread → setter: textures the engine no longer plays, freed at the next set.
    done: ArrayQueue<Box<Texture>>,
}

impl Default for UserTextureField {
    fn default() -> Self {
        UserTextureField { file: Mutex::new(None), pending: ArrayQueue::new(2), done: ArrayQueue::new(4) }
    }
}

impl UserTextureField {
    /// The saved file, if any (a copy).
    pub fn file(&self) -> Option<TextureFile> {
        self.file.lock().ok().and_then(|f| f.clone())
    }

    /// The saved file's name, if any.
    pub fn name(&self) -> Option<String> {
        self.file.lock().ok().and_then(|f| f.as_ref().map(|f| f.name.clone()))
    }

    /// Whether a user texture is set.
    pub fn is_set(&self) -> bool {
        self.file.lock().is_ok_and(|f| f.is_some())
    }

    /// Keeps `file` with the project and queues it for the audio thread (replacing a texture
    /// still waiting); frees the textures the audio thread handed back. Not for the audio
    /// thread (allocates, locks).
    ///
    /// # Errors
    /// A profile outside the texture limits (nothing changes).
    pub fn set_file(&self, file: Option<TextureFile>) -> Result<(), String> {
        let texture = match &file {
            Some(f) => {
                f.check()?;
                Some(Box::new(Texture::new(f.heights_m.clone(), f.texel_m)?))
            }
            None => None,
        };
        while self.done.pop().is_some() {}
        while self.pending.pop().is_some() {}
        // Emptied just above; another setter racing here would only leave its own texture.
        let _ = self.pending.push(texture);
        if let Ok(mut slot) = self.file.lock() {
            *slot = file;
        }
        Ok(())
    }

    /// Gives the engine the texture waiting, if any, handing the one it replaces back.
    ///
    /// # Realtime safety
    /// Lock-free queue operations; nothing is allocated or freed (a texture is taken only
    /// while the return queue has room).
    pub fn apply(&self, engine: &mut dsp::Engine) {
        if self.done.is_full() {
            return;
        }
        if let Some(next) = self.pending.pop() {
            if let Some(old) = engine.set_user_texture(next) {
                // Room was checked above and only the audio thread pushes.
                if let Err(old) = self.done.push(old) {
                    std::mem::forget(old); // unreachable: never free on the audio thread
                }
            }
        }
    }

    /// Plays the saved file in `engine` now (a new engine at activation). Allocates.
    pub fn restore(&self, engine: &mut dsp::Engine) {
        while self.pending.pop().is_some() {}
        let texture = self.file().and_then(|f| Texture::new(f.heights_m, f.texel_m).ok()).map(Box::new);
        engine.set_user_texture(texture);
    }
}

impl<'a> PersistentField<'a, Option<TextureFile>> for UserTextureField {
    fn set(&self, new_value: Option<TextureFile>) {
        // A saved state with a profile outside the limits loads without a user texture.
        if self.set_file(new_value).is_err() {
            let _ = self.set_file(None);
        }
    }

    fn map<F, R>(&self, f: F) -> R
    where
        F: Fn(&Option<TextureFile>) -> R,
    {
        match self.file.lock() {
            Ok(g) => f(&g),
            Err(p) => f(&p.into_inner()),
        }
    }
}
