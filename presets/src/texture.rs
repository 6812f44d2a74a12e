//! User textures for lasting contact (issue 16): a surface's height profile along the
//! contact's path, read from a file.
//!
//! Formats (the file's extension chooses):
//! - **CSV / text** (`.csv`, `.txt`): heights in millimetres, one per texel, separated by commas,
//!   semicolons, spaces or new lines; `#` starts a comment. An optional line `texel_mm = L`
//!   sets the texel length (default [`DEFAULT_TEXEL_MM`]).
//! - **WAV** (`.wav`): the first channel's samples are the heights, full scale =
//!   [`WAV_FULL_SCALE_MM`], one per [`DEFAULT_TEXEL_MM`].
//! - **Image** (`.png`): a grayscale (or colour, taken as luma) picture, black = 0 and white =
//!   [`IMAGE_DEPTH_MM`], one pixel per [`DEFAULT_TEXEL_MM`]. [`ImagePath`] says which path
//!   through it is the profile: its middle row (the default), or a spiral from the centre out
//!   to the inscribed circle, as a record's groove or a tool circling a plate.
//!
//! The profile repeats along the path. *Texture scale* stretches it as it does the factory
//! textures.

use serde::{Deserialize, Serialize};
use std::path::Path;

/// Texel length when the file does not give one, mm.
pub const DEFAULT_TEXEL_MM: f64 = 0.1;
/// Height of a full-scale WAV sample, mm.
pub const WAV_FULL_SCALE_MM: f64 = 1.0;
/// Height of a white pixel, mm.
pub const IMAGE_DEPTH_MM: f64 = 0.5;
/// Most texels a texture may hold (a 1 M-texel profile takes 8 MiB).
pub const MAX_TEXELS: usize = 1 << 20;
/// Most texels a spiral through an image gives (6.5 m of path at 0.1 mm; the texture is kept
/// with the project, so a photo must not make every saved state tens of MB).
pub const SPIRAL_MAX_TEXELS: usize = 1 << 16;
/// Largest height (mm, either sign) a texture may have: more is taken as a wrong unit.
pub const MAX_HEIGHT_MM: f64 = 10.0;
/// Texel lengths accepted, mm.
pub const TEXEL_MM_RANGE: (f64, f64) = (1e-4, 100.0);

/// The path through an image that is read as the profile.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ImagePath {
    /// The middle row, left to right.
    #[default]
    Row,
    /// An Archimedean spiral from the centre out to the inscribed circle, counter-clockwise,
    /// its turns one pixel apart (further apart when the spiral would exceed
    /// [`SPIRAL_MAX_TEXELS`]),
    /// read every pixel of arc length with bilinear interpolation.
    Spiral,
}

impl ImagePath {
    /// Parses `row` or `spiral` (the command line's `--image-path`).
    ///
    /// # Errors
    /// Anything else, in one line.
    pub fn parse(s: &str) -> Result<ImagePath, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "row" => Ok(ImagePath::Row),
            "spiral" => Ok(ImagePath::Spiral),
            other => Err(format!("image path '{other}': expected row or spiral")),
        }
    }
}

/// Luma (0..=1) along an Archimedean spiral r = p·θ/2π about the image's centre, from r = p/2
/// out to the inscribed circle, one sample per pixel of arc length, bilinear between pixels;
/// the pitch p is 1 pixel, or more when the spiral would be longer than `max_len` (its length
/// is about π·R²/p).
pub fn spiral_profile(img: &image::GrayImage, max_len: usize) -> Vec<f64> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let outer = cx.min(cy);
    if outer < 1.0 {
        return Vec::new();
    }
    let pitch = (std::f64::consts::PI * outer * outer / max_len as f64).max(1.0);
    let b = pitch / (2.0 * std::f64::consts::PI);
    let luma = |x: f64, y: f64| {
        let (x0, y0) = (x.floor().clamp(0.0, (w - 1) as f64), y.floor().clamp(0.0, (h - 1) as f64));
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (x0 as u32, y0 as u32);
        let (i1, j1) = ((i + 1).min(w as u32 - 1), (j + 1).min(h as u32 - 1));
        let p = |a: u32, c: u32| f64::from(img.get_pixel(a, c).0[0]) / 255.0;
        (1.0 - fy) * ((1.0 - fx) * p(i, j) + fx * p(i1, j)) + fy * ((1.0 - fx) * p(i, j1) + fx * p(i1, j1))
    };
    let mut out = Vec::new();
    let mut theta = std::f64::consts::PI; // r = p/2
    while b * theta <= outer && out.len() < max_len {
        let r = b * theta;
        // Image rows grow downwards: counter-clockwise on screen is −sin.
        out.push(luma(cx + r * theta.cos(), cy - r * theta.sin()));
        // One pixel of arc: ds = sqrt(r² + b²)·dθ.
        theta += 1.0 / (r * r + b * b).sqrt();
    }
    out
}

/// A texture read from a file: its name (the file's stem), texel length and heights (m).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextureFile {
    /// The file's name without its extension.
    pub name: String,
    /// Length of one texel, m.
    pub texel_m: f64,
    /// Heights along the path, m (at least 2).
    pub heights_m: Vec<f64>,
}

impl TextureFile {
    /// Checks a profile (any source): 2..=[`MAX_TEXELS`] finite heights within
    /// ±[`MAX_HEIGHT_MM`], a texel in [`TEXEL_MM_RANGE`].
    ///
    /// # Errors
    /// A one-line reason.
    pub fn new(name: &str, texel_mm: f64, heights_mm: &[f64]) -> Result<TextureFile, String> {
        let t = TextureFile {
            name: name.to_string(),
            texel_m: texel_mm * 1e-3,
            heights_m: heights_mm.iter().map(|h| h * 1e-3).collect(),
        };
        t.check()?;
        Ok(t)
    }

    /// Checks the limits of [`TextureFile::new`] (also for one read back from a saved state).
    ///
    /// # Errors
    /// A one-line reason.
    pub fn check(&self) -> Result<(), String> {
        let name = &self.name;
        let n = self.heights_m.len();
        if n < 2 {
            return Err(format!("texture {name}: {n} heights; a texture needs at least 2"));
        }
        if n > MAX_TEXELS {
            return Err(format!("texture {name}: {n} heights, over the {MAX_TEXELS} a texture may hold"));
        }
        if let Some(i) = self.heights_m.iter().position(|h| !h.is_finite()) {
            return Err(format!("texture {name}: height {} is not a number", i + 1));
        }
        let top = self.heights_m.iter().fold(0.0f64, |m, h| m.max(h.abs())) * 1e3;
        if top > MAX_HEIGHT_MM {
            return Err(format!(
                "texture {name}: heights reach {top} mm, over {MAX_HEIGHT_MM} mm (heights are in millimetres: a file in µm needs dividing by 1000)"
            ));
        }
        let texel_mm = self.texel_m * 1e3;
        if !(texel_mm.is_finite() && (TEXEL_MM_RANGE.0..=TEXEL_MM_RANGE.1).contains(&texel_mm)) {
            return Err(format!(
                "texture {name}: texel_mm {texel_mm} is outside {}..={} mm",
                TEXEL_MM_RANGE.0, TEXEL_MM_RANGE.1
            ));
        }
        Ok(())
    }

    /// A texture from the samples of WAV file `path` (one channel, full scale ±1): its heights
    /// at [`WAV_FULL_SCALE_MM`] per full scale, [`DEFAULT_TEXEL_MM`] apart, named after the
    /// file. (The reading itself is the caller's: this crate's `hound` reader, or the
    /// estimator's, which takes more of the WAVs users have.)
    ///
    /// # Errors
    /// More than [`MAX_TEXELS`] samples, a silent file, or a profile [`TextureFile::new`]
    /// refuses, in a line naming the file.
    pub fn from_wav_samples(path: &Path, samples: &[f64]) -> Result<TextureFile, String> {
        let shown = path.display();
        let name = path.file_stem().map_or_else(|| "texture".to_string(), |s| s.to_string_lossy().into_owned());
        if samples.len() > MAX_TEXELS {
            return Err(format!("{shown}: {} samples, over the {MAX_TEXELS} a texture may hold", samples.len()));
        }
        // A silent recording has no relief: it would play as the factory *Smooth* without a
        // word; most likely the wrong file. (A flat row of an image can be meant, as against
        // its spiral.)
        if samples.len() >= 2 && samples.iter().all(|&h| h == samples[0]) {
            return Err(format!(
                "{shown}: silent (every sample the same): a texture WAV's samples are its heights, and a surface without relief plays as the factory texture Smooth"
            ));
        }
        let heights: Vec<f64> = samples.iter().map(|&v| v * WAV_FULL_SCALE_MM).collect();
        TextureFile::new(&name, DEFAULT_TEXEL_MM, &heights).map_err(|e| format!("{shown}: {e}"))
    }

    /// Reads a texture file (see the module documentation for the formats).
    ///
    /// # Errors
    /// A one-line reason naming the file: unreadable, an unknown extension, malformed, or a
    /// profile [`TextureFile::new`] refuses.
    pub fn load(path: &Path) -> Result<TextureFile, String> {
        TextureFile::load_with(path, ImagePath::Row)
    }

    /// As [`TextureFile::load`], an image read along `image_path` (other formats ignore it).
    ///
    /// # Errors
    /// As [`TextureFile::load`].
    pub fn load_with(path: &Path, image_path: ImagePath) -> Result<TextureFile, String> {
        let name = path.file_stem().map_or_else(|| "texture".to_string(), |s| s.to_string_lossy().into_owned());
        let shown = path.display();
        let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default();
        match ext.as_str() {
            "csv" | "txt" => {
                let meta = std::fs::metadata(path).map_err(|e| format!("cannot read {shown}: {e}"))?;
                // At most ~40 bytes per height.
                if meta.len() > 40 * MAX_TEXELS as u64 {
                    return Err(format!("{shown}: {} bytes, too large for a texture", meta.len()));
                }
                // (Read no further than that: a device's length is 0, `/dev/zero` never ends.)
                let bytes = crate::read_capped(path, 40 * MAX_TEXELS as u64)
                    .map_err(|e| format!("cannot read {shown}: {e}"))?
                    .ok_or_else(|| format!("{shown}: too large for a texture"))?;
                let text =
                    String::from_utf8(bytes).map_err(|_| format!("cannot read {shown}: it is not UTF-8 text"))?;
                let (texel, heights) = parse_text(&text).map_err(|e| format!("{shown}: {e}"))?;
                TextureFile::new(&name, texel, &heights).map_err(|e| format!("{shown}: {e}"))
            }
            "wav" => {
                let mut r = hound::WavReader::open(path).map_err(|e| wav_error(&shown, &e))?;
                let spec = r.spec();
                let channels = usize::from(spec.channels.max(1));
                let frames = r.duration() as usize;
                if frames > MAX_TEXELS {
                    return Err(format!("{shown}: {frames} samples, over the {MAX_TEXELS} a texture may hold"));
                }
                let samples: Result<Vec<f64>, String> = match spec.sample_format {
                    hound::SampleFormat::Float => r
                        .samples::<f32>()
                        .step_by(channels)
                        .map(|s| s.map(f64::from).map_err(|e| wav_error(&shown, &e)))
                        .collect(),
                    hound::SampleFormat::Int => {
                        let full = f64::from(1u32 << (spec.bits_per_sample.clamp(1, 32) - 1));
                        r.samples::<i32>()
                            .step_by(channels)
                            .map(|s| s.map(|v| f64::from(v) / full).map_err(|e| wav_error(&shown, &e)))
                            .collect()
                    }
                };
                TextureFile::from_wav_samples(path, &samples?)
            }
            "png" => {
                let open = || {
                    image::ImageReader::open(path)
                        .map_err(|e| format!("cannot read {shown}: {e}"))?
                        .with_guessed_format()
                        .map_err(|e| format!("cannot read {shown}: {e}"))
                };
                let (w, h) = open()?.into_dimensions().map_err(|e| format!("{shown}: not a readable PNG ({e})"))?;
                if w as usize > MAX_TEXELS || u64::from(w) * u64::from(h) > 16 << 20 {
                    return Err(format!("{shown}: {w} × {h} pixels, too large for a texture (at most 16 M pixels)"));
                }
                let mut reader = open()?;
                let mut limits = image::Limits::default();
                limits.max_alloc = Some(256 << 20);
                reader.limits(limits);
                let img = reader.decode().map_err(|e| format!("{shown}: not a readable PNG ({e})"))?.to_luma8();
                let heights: Vec<f64> = match image_path {
                    ImagePath::Row => {
                        let row = img.height() / 2;
                        (0..img.width())
                            .map(|x| f64::from(img.get_pixel(x, row).0[0]) / 255.0 * IMAGE_DEPTH_MM)
                            .collect()
                    }
                    ImagePath::Spiral => {
                        let p = spiral_profile(&img, SPIRAL_MAX_TEXELS);
                        if p.len() < 2 {
                            return Err(format!("{shown}: {w} × {h} pixels, too small for a spiral (at least 3 × 3)"));
                        }
                        p.into_iter().map(|l| l * IMAGE_DEPTH_MM).collect()
                    }
                };
                TextureFile::new(&name, DEFAULT_TEXEL_MM, &heights).map_err(|e| format!("{shown}: {e}"))
            }
            _ => Err(format!("{shown}: a texture is a .csv, .txt, .wav or .png file")),
        }
    }
}

/// Parses the text format: (texel length mm, heights mm).
fn parse_text(text: &str) -> Result<(f64, Vec<f64>), String> {
    let mut texel = None;
    let mut heights = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        if let Some((key, value)) = line.split_once('=') {
            if key.trim() != "texel_mm" {
                return Err(format!("line {}: unknown setting '{}' (only texel_mm)", n + 1, key.trim()));
            }
            if texel.is_some() {
                return Err(format!("line {}: texel_mm is given twice", n + 1));
            }
            texel = Some(
                value
                    .trim()
                    .parse()
                    .map_err(|_| format!("line {}: texel_mm '{}' is not a number", n + 1, value.trim()))?,
            );
            continue;
        }
        if line.contains(';') && line.contains(',') {
            return Err(format!("line {}: commas with semicolons: decimal commas are not read (use points)", n + 1));
        }
        for item in line.split([',', ';', ' ', '\t']).map(str::trim).filter(|s| !s.is_empty()) {
            let h: f64 = item.parse().map_err(|_| format!("line {}: '{item}' is not a height in mm", n + 1))?;
            heights.push(h);
            if heights.len() > MAX_TEXELS {
                return Err(format!("over the {MAX_TEXELS} heights a texture may hold"));
            }
        }
    }
    Ok((texel.unwrap_or(DEFAULT_TEXEL_MM), heights))
}

/// A WAV reading error in words a user can act on (hound says "Failed to read enough
/// bytes." for a cut file, "bits per sample is not 32" for 64-bit float).
fn wav_error(shown: &dyn std::fmt::Display, e: &hound::Error) -> String {
    match e {
        hound::Error::IoError(io)
            if io.kind() == std::io::ErrorKind::UnexpectedEof || io.to_string().contains("enough bytes") =>
        {
            format!("cannot read {shown} as WAV: it ends before its header or data says (a truncated or empty file)")
        }
        hound::Error::FormatError(m) if m.contains("bits per sample is not 32") => format!(
            "cannot read {shown} as a texture: 64-bit float WAV is not read here; save it as 32-bit float or 16/24-bit PCM"
        ),
        hound::Error::Unsupported => {
            format!("cannot read {shown} as a texture: an unsupported WAV encoding (use PCM or 32-bit float)")
        }
        other => format!("cannot read {shown} as WAV: {other}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("struck-texture-{}-{name}", std::process::id()))
    }

    #[test]
    fn reads_text_with_a_texel_length_and_comments() {
        let p = tmp("a.csv");
        std::fs::write(&p, "# grooves\ntexel_mm = 0.25\n0, 0, 0,0\n-0.15;-0.3 -0.15\n").unwrap();
        let t = TextureFile::load(&p).unwrap();
        assert_eq!(t.name, "struck-texture-".to_string() + &std::process::id().to_string() + "-a");
        assert_eq!(t.texel_m, 0.25e-3);
        assert_eq!(t.heights_m, vec![0.0, 0.0, 0.0, 0.0, -0.15e-3, -0.3e-3, -0.15e-3]);
        for (text, why) in [
            ("0.1\n", "at least 2"),
            ("0, x\n", "'x' is not a height"),
            ("speed = 3\n0 1\n", "unknown setting"),
            ("0, 2000\n", "in µm needs dividing"),
            ("texel_mm = 0\n0 1\n", "outside"),
            ("texel_mm = 1\ntexel_mm = 2\n0 1\n", "given twice"),
            ("0,5;0,3\n", "decimal commas"),
        ] {
            std::fs::write(&p, text).unwrap();
            let e = TextureFile::load(&p).unwrap_err();
            assert!(e.contains(why) && !e.contains('\n'), "{text:?}: {e}");
        }
        let _ = std::fs::remove_file(p);
    }

    #[test]
    fn reads_wav_and_png_and_refuses_other_files() {
        let p = tmp("b.wav");
        let spec = hound::WavSpec {
            channels: 2,
            sample_rate: 48_000,
            bits_per_sample: 16,
            sample_format: hound::SampleFormat::Int,
        };
        let mut w = hound::WavWriter::create(&p, spec).unwrap();
        for v in [0i16, 16384, -16384, 0] {
            w.write_sample(v).unwrap();
            w.write_sample(1000).unwrap(); // the second channel is not read
        }
        w.finalize().unwrap();
        let t = TextureFile::load(&p).unwrap();
        assert_eq!(t.heights_m, vec![0.0, 0.5e-3, -0.5e-3, 0.0]);
        assert_eq!(t.texel_m, DEFAULT_TEXEL_MM * 1e-3);
        let q = tmp("c.png");
        let img =
            image::GrayImage::from_fn(4, 3, |x, y| image::Luma([if y == 1 { [0, 255, 51, 0][x as usize] } else { 9 }]));
        img.save(&q).unwrap();
        let t = TextureFile::load(&q).unwrap();
        assert_eq!(t.heights_m, vec![0.0, IMAGE_DEPTH_MM * 1e-3, 0.2 * IMAGE_DEPTH_MM * 1e-3, 0.0]);
        let r = tmp("d.jpg");
        std::fs::write(&r, b"x").unwrap();
        assert!(TextureFile::load(&r).unwrap_err().contains(".csv, .txt, .wav or .png"));
        assert!(TextureFile::load(&tmp("missing.csv")).unwrap_err().contains("cannot read"));
        // Cut short (the data chunk says more than the file holds) and empty: the same words.
        let bytes = std::fs::read(&p).unwrap();
        let cut = tmp("cut.wav");
        std::fs::write(&cut, &bytes[..bytes.len() - 6]).unwrap();
        assert!(TextureFile::load(&cut).unwrap_err().contains("ends before its header or data says"));
        std::fs::write(&cut, b"").unwrap();
        assert!(TextureFile::load(&cut).unwrap_err().contains("ends before its header or data says"));
        // 64-bit float: said, with what to save instead.
        let mut f64wav = bytes[..12].to_vec();
        f64wav.extend(b"fmt \x10\0\0\0\x03\0\x01\0\x80\xbb\0\0\0\xdc\x05\0\x08\0\x40\0");
        f64wav.extend(b"data\x08\0\0\0");
        f64wav.extend(0.5f64.to_le_bytes());
        std::fs::write(&cut, &f64wav).unwrap();
        let e = TextureFile::load(&cut).unwrap_err();
        assert!(e.contains("64-bit float WAV is not read here"), "{e}");
        for f in [p, q, r, cut] {
            let _ = std::fs::remove_file(f);
        }
    }

    /// The spiral reads the whole disc: an image whose grey level rises with the radius gives
    /// heights rising as the closed form of an Archimedean spiral says (arc length s ≈ π·r²/p,
    /// so r ≈ √(s·p/π)); its length is π·R²/p (1 %); an image of N black and white sectors is
    /// crossed N times per turn, R/p turns in all (1 %).
    #[test]
    fn a_spiral_reads_the_image_from_the_centre_out() {
        let (w, outer) = (401u32, 200.0f64);
        let c = f64::from(w - 1) / 2.0;
        let radial = image::GrayImage::from_fn(w, w, |x, y| {
            let r = (f64::from(x) - c).hypot(f64::from(y) - c);
            image::Luma([(255.0 * (r / outer).min(1.0)).round() as u8])
        });
        let p = spiral_profile(&radial, MAX_TEXELS);
        let expected_len = std::f64::consts::PI * outer * outer;
        assert!((p.len() as f64 / expected_len - 1.0).abs() < 0.01, "{} samples, expected {expected_len:.0}", p.len());
        for i in [2_000usize, 20_000, 60_000, 120_000] {
            let r = (i as f64 / std::f64::consts::PI).sqrt();
            assert!((p[i] - r / outer).abs() < 0.01, "sample {i}: {} vs {}", p[i], r / outer);
        }
        let sectors = 12u32;
        let spokes = image::GrayImage::from_fn(w, w, |x, y| {
            let a = (c - f64::from(y)).atan2(f64::from(x) - c).rem_euclid(std::f64::consts::TAU);
            image::Luma([if (a / std::f64::consts::TAU * f64::from(sectors)) as u32 % 2 == 0 { 255 } else { 0 }])
        });
        let q = spiral_profile(&spokes, MAX_TEXELS);
        let crossings = q.windows(2).filter(|v| (v[0] - 0.5) * (v[1] - 0.5) < 0.0).count();
        let expected = f64::from(sectors) * (outer - 0.5);
        assert!((crossings as f64 / expected - 1.0).abs() < 0.02, "{crossings} crossings, expected {expected:.0}");
        // A spiral longer than the limit opens its turns instead.
        let short = spiral_profile(&radial, 10_000);
        assert!(short.len() <= 10_000 && short.len() > 9_000, "{}", short.len());
        assert!(short.last().is_some_and(|&l| l > 0.95));
        let tiny = tmp("tiny.png");
        image::GrayImage::from_pixel(2, 2, image::Luma([128])).save(&tiny).unwrap();
        let e = TextureFile::load_with(&tiny, ImagePath::Spiral).unwrap_err();
        assert!(e.contains("too small for a spiral") && !e.contains('\n'), "{e}");
        let _ = std::fs::remove_file(tiny);
        assert_eq!(ImagePath::parse("Spiral"), Ok(ImagePath::Spiral));
        assert!(ImagePath::parse("circle").unwrap_err().contains("row or spiral"));
    }
}
