//! Linear RGB float images and their files (OpenEXR for data, PNG for looking at).
//!
//! [`Image`] holds scene-linear RGB radiance in `f32`, row 0 at the top, pixels in row-major
//! order. It is what the GPU renderer reads back, what the CPU reference produces and what
//! [`crate::metrics::compare`] measures.
//!
//! Files:
//! * [`Image::write_exr`] / [`Image::read_exr`]: float32 RGB OpenEXR (ZIP, lossless), so a
//!   write followed by a read gives back exactly the same bits. Reading accepts RGB or RGBA
//!   files with `f16`, `f32` or `u32` samples (alpha is dropped).
//! * [`Image::write_png`]: 8-bit sRGB for viewing, after exposure and tone mapping, see
//!   [`Image::to_srgb8`].
//!
//! Every write is atomic ([`crate::fsx`]): the data goes to a temporary file in the destination's
//! directory, is flushed to disk and then renamed over the destination, so an interrupted run
//! never leaves a half-written file behind. `stage_*` stop before the rename, so that a command
//! with several outputs commits them only when all were written. Every error names the file.

use crate::fsx::Staged;
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

/// What went wrong reading or writing an image, or building one from raw data.
///
/// The `Display` text of each file error names the file and the operation.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The file system refused: missing directory, permissions, disk full, ...
    #[error("cannot {op} {}: {source}", path.display())]
    Io {
        /// The operation, e.g. `"read"` or `"write"`.
        op: &'static str,
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    /// The OpenEXR encoder or decoder failed (for reading: not an EXR file, corrupt, or no
    /// R, G and B channels).
    #[error("cannot {op} OpenEXR file {}: {message}", path.display())]
    Exr { op: &'static str, path: PathBuf, message: String },
    /// The PNG encoder failed.
    #[error("cannot {op} PNG file {}: {message}", path.display())]
    Png { op: &'static str, path: PathBuf, message: String },
    /// Raw pixel data whose length does not fit the stated size.
    #[error(
        "pixel data for a {width}x{height} image needs {expected} values \
         ({channels} per pixel), got {actual}"
    )]
    SizeMismatch { width: u32, height: u32, channels: usize, expected: usize, actual: usize },
    /// An image file whose size cannot be held in memory (width or height beyond `u32`).
    #[error("{}: a {width}x{height} image is too large", path.display())]
    TooLarge { path: PathBuf, width: u64, height: u64 },
    /// Writing an image without pixels: neither format can store one.
    #[error("cannot write {}: the image is {width}x{height}, an image file needs at least one pixel", path.display())]
    Empty { path: PathBuf, width: u32, height: u32 },
}

/// A linear RGB image, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image { width, height, pixels: vec![[0.0; 3]; width as usize * height as usize] }
    }

    /// An image from tightly packed RGBA `f32` data (4 values per pixel, row 0 first), as read
    /// back from an `Rgba32Float` texture. Alpha is dropped. Fails when `data.len()` is not
    /// `4 * width * height`.
    pub fn from_rgba_f32(width: u32, height: u32, data: &[f32]) -> Result<Image, ImageError> {
        let expected = pixel_count(width, height).and_then(|n| n.checked_mul(4));
        if expected != Some(data.len()) {
            return Err(ImageError::SizeMismatch {
                width,
                height,
                channels: 4,
                expected: expected.unwrap_or(usize::MAX),
                actual: data.len(),
            });
        }
        let pixels = data.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect();
        Ok(Image { width, height, pixels })
    }

    /// An image from RGB pixels, row 0 first. Fails when `pixels.len()` is not
    /// `width * height`.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<[f32; 3]>) -> Result<Image, ImageError> {
        let expected = pixel_count(width, height);
        if expected != Some(pixels.len()) {
            return Err(ImageError::SizeMismatch {
                width,
                height,
                channels: 3,
                expected: expected.unwrap_or(usize::MAX),
                actual: pixels.len(),
            });
        }
        Ok(Image { width, height, pixels })
    }

    /// The pixel at column `x`, row `y` (row 0 at the top).
    ///
    /// # Panics
    /// When `x >= width` or `y >= height`, like slice indexing.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[self.index(x, y)]
    }

    /// Sets the pixel at column `x`, row `y`.
    ///
    /// # Panics
    /// When `x >= width` or `y >= height`, like slice indexing.
    pub fn set(&mut self, x: u32, y: u32, rgb: [f32; 3]) {
        let i = self.index(x, y);
        self.pixels[i] = rgb;
    }

    fn index(&self, x: u32, y: u32) -> usize {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside a {}x{} image", self.width, self.height);
        y as usize * self.width as usize + x as usize
    }

    /// The mean of each channel over all pixels, summed in `f64`. `[0, 0, 0]` for an empty
    /// image. Non-finite values propagate (a NaN pixel gives a NaN mean).
    pub fn mean(&self) -> [f64; 3] {
        if self.pixels.is_empty() {
            return [0.0; 3];
        }
        let mut sum = [0.0f64; 3];
        for p in &self.pixels {
            for c in 0..3 {
                sum[c] += p[c] as f64;
            }
        }
        let n = self.pixels.len() as f64;
        sum.map(|s| s / n)
    }

    /// The number of non-finite values (NaN or ±infinity), counting each channel separately.
    pub fn count_non_finite(&self) -> usize {
        self.pixels.iter().flat_map(|p| p.iter()).filter(|v| !v.is_finite()).count()
    }

    /// Writes the image as a float32 RGB OpenEXR file (ZIP compression, lossless), atomically.
    pub fn write_exr(&self, path: impl AsRef<Path>) -> Result<(), ImageError> {
        let path = path.as_ref();
        self.stage_exr(path)?.commit().map_err(|source| ImageError::Io { op: "write", path: path.into(), source })
    }

    /// [`Image::write_exr`] up to the rename: the complete file waits beside `path` until
    /// [`Staged::commit`], so that a command writes all of its outputs or none.
    pub fn stage_exr(&self, path: impl AsRef<Path>) -> Result<Staged, ImageError> {
        use exr::prelude::*;
        let path = path.as_ref();
        self.check_size(path)?;
        let (w, h) = (self.width as usize, self.height as usize);
        let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
            let p = self.pixels[y * w + x];
            (p[0], p[1], p[2])
        });
        let image = exr::image::Image::from_encoded_channels((w, h), Encoding::SMALL_LOSSLESS, channels);
        stage(path, |file| image.write().to_buffered(file).map_err(|e| exr_error("write", path, e)))
    }

    /// Reads the first RGB(A) layer of an OpenEXR file at its largest resolution level.
    /// Samples may be `f16`, `f32` or `u32`; they are converted to `f32`. Alpha is ignored.
    pub fn read_exr(path: impl AsRef<Path>) -> Result<Image, ImageError> {
        use exr::prelude::*;
        let path = path.as_ref();
        // Open the file ourselves so that a missing file is reported as an I/O error.
        let file = File::open(path).map_err(|source| ImageError::Io { op: "read", path: path.into(), source })?;
        let reader = io::BufReader::new(file);
        let result = read()
            .no_deep_data()
            .largest_resolution_level()
            .rgba_channels(
                |size: Vec2<usize>, _channels: &RgbaChannels| -> Option<(usize, Vec<[f32; 3]>)> {
                    // A size the machine cannot hold becomes a `TooLarge` error, not an abort.
                    let n = size.0.checked_mul(size.1)?;
                    let mut px = Vec::new();
                    px.try_reserve_exact(n).ok()?;
                    px.resize(n, [0.0f32; 3]);
                    Some((size.0, px))
                },
                |pixels: &mut Option<(usize, Vec<[f32; 3]>)>, pos: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
                    if let Some((w, px)) = pixels {
                        px[pos.1 * *w + pos.0] = [r, g, b];
                    }
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(reader)
            .map_err(|e| exr_error("read", path, e))?;
        let layer = result.layer_data;
        let size = layer.size;
        let too_large = || ImageError::TooLarge { path: path.into(), width: size.0 as u64, height: size.1 as u64 };
        let (_, pixels) = layer.channel_data.pixels.ok_or_else(too_large)?;
        let width = u32::try_from(size.0).map_err(|_| too_large())?;
        let height = u32::try_from(size.1).map_err(|_| too_large())?;
        Ok(Self { width, height, pixels })
    }

    /// Converts to 8-bit sRGB RGBA (alpha 255), row 0 first, for display:
    ///
    /// 1. exposure: each channel is multiplied by `2^exposure_stops`;
    /// 2. tone mapping: the ACES filmic curve as fitted by Krzysztof Narkowicz (2015),
    ///    `f(x) = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`, clamped to [0, 1], applied per
    ///    channel (no 0.6 pre-scale: use `exposure_stops` for that). It is close to linear with
    ///    slope ~0.2 near black and reaches white at x ≈ 7.2;
    /// 3. the sRGB transfer function (IEC 61966-2-1), then rounding to 8 bits.
    ///
    /// Negative values and NaN become 0 (black); +infinity becomes 255 (white).
    pub fn to_srgb8(&self, exposure_stops: f32) -> Vec<u8> {
        let scale = exposure_stops.exp2();
        let mut out = Vec::with_capacity(self.pixels.len() * 4);
        for p in &self.pixels {
            for &c in p {
                out.push(encode_srgb8(tone_map_aces(c * scale)));
            }
            out.push(255);
        }
        out
    }

    /// Writes the image as an 8-bit sRGB RGBA PNG (see [`Image::to_srgb8`]), atomically.
    pub fn write_png(&self, path: impl AsRef<Path>, exposure_stops: f32) -> Result<(), ImageError> {
        let path = path.as_ref();
        self.stage_png(path, exposure_stops)?.commit().map_err(|source| ImageError::Io {
            op: "write",
            path: path.into(),
            source,
        })
    }

    /// [`Image::write_png`] up to the rename (see [`Image::stage_exr`]).
    pub fn stage_png(&self, path: impl AsRef<Path>, exposure_stops: f32) -> Result<Staged, ImageError> {
        use image::ImageEncoder;
        let path = path.as_ref();
        self.check_size(path)?;
        let rgba = self.to_srgb8(exposure_stops);
        stage(path, |file| {
            image::codecs::png::PngEncoder::new(file)
                .write_image(&rgba, self.width, self.height, image::ExtendedColorType::Rgba8)
                .map_err(|e| match e {
                    image::ImageError::IoError(source) => ImageError::Io { op: "write", path: path.into(), source },
                    e => ImageError::Png { op: "write", path: path.into(), message: e.to_string() },
                })
        })
    }

    /// Both formats need at least one pixel and a pixel buffer matching the size.
    fn check_size(&self, path: &Path) -> Result<(), ImageError> {
        if self.width == 0 || self.height == 0 {
            return Err(ImageError::Empty { path: path.into(), width: self.width, height: self.height });
        }
        let expected = pixel_count(self.width, self.height);
        if expected != Some(self.pixels.len()) {
            return Err(ImageError::SizeMismatch {
                width: self.width,
                height: self.height,
                channels: 3,
                expected: expected.unwrap_or(usize::MAX),
                actual: self.pixels.len(),
            });
        }
        Ok(())
    }
}

fn pixel_count(width: u32, height: u32) -> Option<usize> {
    (width as usize).checked_mul(height as usize)
}

fn exr_error(op: &'static str, path: &Path, e: exr::error::Error) -> ImageError {
    match e {
        exr::error::Error::Io(source) => ImageError::Io { op, path: path.into(), source },
        other => ImageError::Exr { op, path: path.into(), message: other.to_string() },
    }
}

/// ACES filmic tone curve (Narkowicz 2015 fit), output clamped to [0, 1]. NaN and
/// non-positive input give 0; inputs beyond ~7.2 (including +inf) give 1.
pub fn tone_map_aces(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        return 0.0; // negative, zero or NaN
    }
    // The curve is 1 from x ≈ 7.25 on; clamping the input keeps x*x finite.
    let x = x.min(1.0e4);
    let y = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
    y.clamp(0.0, 1.0)
}

/// The sRGB transfer function (linear [0, 1] to encoded [0, 1]) followed by rounding to 8 bits.
pub fn encode_srgb8(linear: f32) -> u8 {
    let l = if linear > 0.0 { linear.min(1.0) } else { 0.0 };
    let e = if l <= 0.003_130_8 { 12.92 * l } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    (e * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// Stages `path` through [`Staged::write`] with an encoder that fails with an [`ImageError`]; every
/// error names `path`, never the temporary file.
fn stage(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), ImageError>,
) -> Result<Staged, ImageError> {
    let mut encoder_error = None;
    let staged = Staged::write(path, |w| {
        write(w).map_err(|e| {
            encoder_error = Some(e);
            io::Error::other("encoding failed")
        })
    });
    staged.map_err(|source| encoder_error.unwrap_or(ImageError::Io { op: "write", path: path.into(), source }))
}
