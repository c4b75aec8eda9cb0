//! Error of a test image against a reference image (usually: GPU render against the exact
//! CPU reference).
//!
//! All statistics are over every pixel and all three channels together, computed in `f64`;
//! see [`compare`] for the definitions.

use std::fmt;

use crate::image::Image;

/// Why two images could not be compared.
#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    #[error(
        "image sizes differ: test image is {test_width}x{test_height}, \
         reference is {ref_width}x{ref_height}"
    )]
    SizeMismatch { test_width: u32, test_height: u32, ref_width: u32, ref_height: u32 },
    #[error("cannot compare empty ({width}x{height}) images")]
    Empty { width: u32, height: u32 },
    /// A reference with NaN or infinite values is broken; no error measure against it means
    /// anything.
    #[error("the reference image has {count} non-finite values (NaN or infinity)")]
    NonFiniteReference { count: usize },
    /// A pixel buffer whose length does not match the image's stated size.
    #[error("the {which} image claims {width}x{height} pixels but holds {actual}")]
    BadPixelCount { which: &'static str, width: u32, height: u32, actual: usize },
}

/// Error statistics of a test image against a reference; see [`compare`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorStats {
    /// RMSE divided by the mean reference value (a fraction: 0.01 is 1 %).
    pub rel_rmse: f64,
    /// Root mean square error over all values.
    pub rmse: f64,
    /// Largest absolute difference of any single value.
    pub max_abs: f64,
    /// HDR peak signal-to-noise ratio in dB, peak = largest reference value.
    pub psnr: f64,
    /// Mean of all reference values.
    pub mean_ref: f64,
    /// Number of non-finite values (NaN, ±inf) in the test image, channels counted separately.
    pub non_finite: usize,
    /// Number of pixels compared.
    pub pixels: usize,
}

/// Compares `test` against `reference`.
///
/// With `a` the test values and `b` the reference values, over all pixels and all three
/// channels (N = 3 · pixels values, each channel counts as one value):
///
/// * `rmse = sqrt( Σ (a − b)² / N )`
/// * `mean_ref = Σ b / N`
/// * `rel_rmse = rmse / mean_ref`; when `mean_ref` is 0, `rel_rmse` is 0 if `rmse` is 0 and
///   `+inf` otherwise
/// * `max_abs = max |a − b|`
/// * `psnr = 20 · log10(peak / rmse)` dB with `peak = max b` (HDR PSNR: the peak is the
///   brightest reference value, not 1); `+inf` when `rmse` is 0, `-inf` when the peak is 0
///   and `rmse` is not.
///
/// Non-finite test values (NaN, ±inf) are never ignored: they are counted in `non_finite`, and
/// when there is any, `rmse`, `rel_rmse` and `max_abs` are `+inf` and `psnr` is `-inf`.
///
/// Errors: different sizes (naming both), empty images, a pixel buffer that does not match
/// its image's size, or a reference containing non-finite values.
/// `SizeMismatch` (naming both sizes) unless `test` and `reference` have the same size.
fn same_size(test: &Image, reference: &Image) -> Result<(), MetricsError> {
    if (test.width, test.height) == (reference.width, reference.height) {
        return Ok(());
    }
    Err(MetricsError::SizeMismatch {
        test_width: test.width,
        test_height: test.height,
        ref_width: reference.width,
        ref_height: reference.height,
    })
}

pub fn compare(test: &Image, reference: &Image) -> Result<ErrorStats, MetricsError> {
    same_size(test, reference)?;
    for (which, img) in [("test", test), ("reference", reference)] {
        let expected = (img.width as usize).checked_mul(img.height as usize);
        if expected != Some(img.pixels.len()) {
            return Err(MetricsError::BadPixelCount {
                which,
                width: img.width,
                height: img.height,
                actual: img.pixels.len(),
            });
        }
    }
    let pixels = test.pixels.len();
    if pixels == 0 {
        return Err(MetricsError::Empty { width: test.width, height: test.height });
    }
    let ref_non_finite = reference.count_non_finite();
    if ref_non_finite > 0 {
        return Err(MetricsError::NonFiniteReference { count: ref_non_finite });
    }

    let mut sum_sq = 0.0f64;
    let mut sum_ref = 0.0f64;
    let mut max_abs = 0.0f64;
    let mut peak = f64::NEG_INFINITY;
    let mut non_finite = 0usize;
    for (a, b) in test.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (a, b) = (a[c] as f64, b[c] as f64);
            sum_ref += b;
            peak = peak.max(b);
            if !a.is_finite() {
                non_finite += 1;
                continue;
            }
            let d = a - b;
            sum_sq += d * d;
            max_abs = max_abs.max(d.abs());
        }
    }
    let n = (3 * pixels) as f64;
    let mean_ref = sum_ref / n;

    let (rmse, rel_rmse, max_abs, psnr) = if non_finite > 0 {
        (f64::INFINITY, f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY)
    } else {
        let rmse = (sum_sq / n).sqrt();
        let rel_rmse = if rmse == 0.0 {
            0.0
        } else if mean_ref == 0.0 {
            f64::INFINITY
        } else {
            rmse / mean_ref
        };
        let psnr = if rmse == 0.0 {
            f64::INFINITY
        } else if peak <= 0.0 {
            f64::NEG_INFINITY
        } else {
            20.0 * (peak / rmse).log10()
        };
        (rmse, rel_rmse, max_abs, psnr)
    };
    Ok(ErrorStats { rel_rmse, rmse, max_abs, psnr, mean_ref, non_finite, pixels })
}

impl ErrorStats {
    /// The statistics as a JSON object with the field names as keys. Finite numbers are JSON
    /// numbers; infinities and NaN (which JSON cannot hold) are the strings `"inf"`, `"-inf"`
    /// and `"nan"`, e.g. `"psnr": "inf"` for identical images.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "rel_rmse": json_f64(self.rel_rmse),
            "rmse": json_f64(self.rmse),
            "max_abs": json_f64(self.max_abs),
            "psnr": json_f64(self.psnr),
            "mean_ref": json_f64(self.mean_ref),
            "non_finite": self.non_finite,
            "pixels": self.pixels,
        })
    }
}

fn json_f64(v: f64) -> serde_json::Value {
    if v.is_finite() {
        serde_json::Value::from(v)
    } else if v.is_nan() {
        "nan".into()
    } else if v > 0.0 {
        "inf".into()
    } else {
        "-inf".into()
    }
}

/// One line: `rel RMSE 1.23% | max abs 4.5e-3 | PSNR 38.2 dB`, followed by
/// `| N non-finite values` when the test image has any.
impl fmt::Display for ErrorStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rel RMSE {:.2}% | max abs {:.1e} | PSNR {:.1} dB", self.rel_rmse * 100.0, self.max_abs, self.psnr)?;
        if self.non_finite > 0 {
            write!(f, " | {} non-finite values", self.non_finite)?;
        }
        Ok(())
    }
}

/// How concentrated the error of `test` against `reference` is: for each fraction `f` of
/// `fractions` (of the pixels, in (0, 1]), the share of the squared error (summed over the
/// channels) that the worst `ceil(f * pixels)` pixels hold. A share near `f` means error spread
/// evenly over the image; near 1, a few pixels hold it (a shadow edge, a seam, one hot pixel), and
/// finer sampling of the whole image is not what lowers it. `None` when the images do not differ
/// or the test image has non-finite values (the RMSE is then infinite: [`compare`] says so).
pub fn worst_pixels_share(
    test: &Image,
    reference: &Image,
    fractions: &[f64],
) -> Result<Option<Vec<f64>>, MetricsError> {
    same_size(test, reference)?;
    let mut sq: Vec<f64> = test
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(a, b)| (0..3).map(|c| (a[c] as f64 - b[c] as f64).powi(2)).sum())
        .collect();
    let total: f64 = sq.iter().sum();
    if !(total.is_finite() && total > 0.0) {
        return Ok(None);
    }
    sq.sort_by(|x, y| y.total_cmp(x));
    let shares = fractions
        .iter()
        .map(|&f| {
            let n = ((f.clamp(0.0, 1.0) * sq.len() as f64).ceil() as usize).min(sq.len());
            sq[..n].iter().sum::<f64>() / total
        })
        .collect();
    Ok(Some(shares))
}

/// A picture of `a` against the reference `b`, side by side: the reference, the image and their
/// difference, as 8-bit sRGB RGB of `3 width x height`. All three share one scale: the
/// reference's 99.5th percentile of luminance maps to white, so the two images can be compared by
/// eye; the difference panel shows `|a - b|` times `gain` on a black-blue-magenta-yellow ramp
/// (yellow: a difference of 1 / gain of that white or more).
pub fn comparison_picture(a: &Image, b: &Image, gain: f32) -> Result<(u32, u32, Vec<u8>), MetricsError> {
    same_size(a, b)?;
    let lum = |p: &[f32; 3]| (p[0] + p[1] + p[2]) / 3.0;
    let mut l: Vec<f32> = b.pixels.iter().map(lum).filter(|v| v.is_finite()).collect();
    l.sort_by(|x, y| x.total_cmp(y));
    let white = l.get((l.len().saturating_sub(1) as f64 * 0.995) as usize).copied().unwrap_or(1.0);
    let scale = if white > 0.0 { 1.0 / white } else { 1.0 };
    let grey = |v: f32| {
        let x = (v * scale).clamp(0.0, 1.0).powf(1.0 / 2.2);
        let c = (x * 255.0 + 0.5) as u8;
        [c, c, c]
    };
    let ramp = |d: f32| {
        let t = (d * scale * gain).clamp(0.0, 1.0);
        // black -> blue -> magenta -> yellow
        let (r, g, bl) = if t < 1.0 / 3.0 {
            (0.0, 0.0, 3.0 * t)
        } else if t < 2.0 / 3.0 {
            (3.0 * t - 1.0, 0.0, 1.0)
        } else {
            (1.0, 3.0 * t - 2.0, 3.0 - 3.0 * t)
        };
        [(r * 255.0) as u8, (g * 255.0) as u8, (bl * 255.0) as u8]
    };
    let (w, h) = (a.width as usize, a.height as usize);
    if w == 0 || h == 0 {
        return Err(MetricsError::Empty { width: a.width, height: a.height });
    }
    let mut out = vec![0u8; 3 * w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let (pa, pb) = (&a.pixels[y * w + x], &b.pixels[y * w + x]);
            let diff = (0..3).map(|c| (pa[c] - pb[c]).abs()).sum::<f32>() / 3.0;
            let diff = if diff.is_finite() { diff } else { f32::INFINITY };
            for (panel, rgb) in [grey(lum(pb)), grey(lum(pa)), ramp(diff)].into_iter().enumerate() {
                let i = 3 * (y * 3 * w + panel * w + x);
                out[i..i + 3].copy_from_slice(&rgb);
            }
        }
    }
    Ok((3 * a.width, a.height, out))
}
