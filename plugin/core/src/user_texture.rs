//! The user's texture (issue 16) as a persisted field of the parameters: kept with the
//! project, and handed to the audio thread without locks whenever it is set, by the editor, by
//! the command line or by the host loading a state (nice-plug calls [`PersistentField::set`]
//! then, on a non-audio thread).

use crossbeam_queue::ArrayQueue;
use dsp::contact::Texture;
use nice_plug::params::persist::PersistentField;
use presets::texture::TextureFile;
use std::path::Path;
use std::sync::Mutex;

/// Largest WAV file read as a texture, bytes: [`presets::texture::MAX_TEXELS`] frames of 8
/// channels of 64-bit floats (read no further: the reader holds every sample).
const MAX_TEXTURE_WAV_BYTES: u64 = presets::texture::MAX_TEXELS as u64 * 64;

/// Reads a texture file as the editor and `struck render --texture` do: a WAV through the
/// estimator's reader (its first channel), which takes the WAVs users have — chunks of odd
/// length or before `fmt `, a data size left at 0xFFFFFFFF by a streaming writer, RF64,
/// 64-bit float, extensible formats — where `hound` refuses them (a black-box tester's
/// finding); a rate outside the estimator's 8–192 kHz (a texture has no rate) falls back to
/// `hound`. Other formats as [`TextureFile::load_with`].
///
/// # Errors
/// A one-line reason naming the file.
pub fn load_texture_file(path: &Path, image_path: presets::texture::ImagePath) -> Result<TextureFile, String> {
    let wav = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("wav"));
    if !wav {
        return TextureFile::load_with(path, image_path);
    }
    if let Ok(meta) = std::fs::metadata(path) {
        if meta.is_file() && meta.len() > MAX_TEXTURE_WAV_BYTES {
            return Err(format!("{}: {} bytes, too large for a texture", path.display(), meta.len()));
        }
    }
    match estimator::wav::load_wav_exact(path, Some(0)) {
        Ok(rec) => {
            let samples: Vec<f64> = rec.samples.iter().map(|&v| f64::from(v)).collect();
            TextureFile::from_wav_samples(path, &samples)
        }
        Err(estimator::EstimateError::SampleRate { .. }) => TextureFile::load_with(path, image_path),
        Err(e) => Err(e.to_string()),
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use presets::texture::ImagePath;

    /// A WAV as some writers leave them: a 3-byte `JUNK` chunk (odd: padded) before `fmt `,
    /// stereo 64-bit float, the data size left at 0xFFFFFFFF by a streaming writer.
    fn odd_wav(samples: &[f64]) -> Vec<u8> {
        let mut f = b"RIFF\xff\xff\xff\xffWAVEJUNK\x03\x00\x00\x00abc\x00fmt \x10\x00\x00\x00".to_vec();
        f.extend(3u16.to_le_bytes()); // IEEE float
        f.extend(2u16.to_le_bytes());
        f.extend(48_000u32.to_le_bytes());
        f.extend((48_000u32 * 16).to_le_bytes());
        f.extend(16u16.to_le_bytes());
        f.extend(64u16.to_le_bytes());
        f.extend(b"data\xff\xff\xff\xff");
        for &s in samples {
            f.extend(s.to_le_bytes());
            f.extend((-s).to_le_bytes());
        }
        f
    }

    /// The odd WAV reads as a texture (hound refuses it), with the same heights as the same
    /// samples in a plain 32-bit float WAV read by `hound` (presets' reader), first channel.
    #[test]
    fn a_texture_wav_as_users_have_them_reads() {
        let dir = std::env::temp_dir().join(format!("struck-texture-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let samples: Vec<f64> =
            (0..5000).map(|i| 0.5 * (f64::from(i) * 0.37).sin() * (f64::from(i) * 0.011).cos()).collect();
        let odd = dir.join("odd.wav");
        std::fs::write(&odd, odd_wav(&samples)).unwrap();
        assert!(TextureFile::load_with(&odd, ImagePath::Row).is_err(), "hound reads it: the test shows nothing");
        let plain = dir.join("plain.wav");
        let spec = hound::WavSpec {
            channels: 1,
            sample_rate: 48_000,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let mut w = hound::WavWriter::create(&plain, spec).unwrap();
        for &s in &samples {
            w.write_sample(s as f32).unwrap();
        }
        w.finalize().unwrap();
        let a = load_texture_file(&odd, ImagePath::Row).unwrap();
        let b = TextureFile::load_with(&plain, ImagePath::Row).unwrap();
        assert_eq!(a.heights_m, b.heights_m);
        assert_eq!(a.texel_m, b.texel_m);
        assert_eq!(a.name, "odd");
        // A file that is not a WAV at all is a one-line error naming it.
        std::fs::write(&odd, b"not a wav").unwrap();
        let e = load_texture_file(&odd, ImagePath::Row).unwrap_err();
        assert!(e.contains("odd.wav") && !e.contains('\n'), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
