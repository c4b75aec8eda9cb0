//! Images (construction, EXR/PNG files, errors) and error metrics on hand-computed cases.

use epivox::image::{encode_srgb8, tone_map_aces, ImageError};
use epivox::metrics::{compare, worst_pixels_share, MetricsError};
use epivox::Image;

fn img(width: u32, height: u32, pixels: &[[f32; 3]]) -> Image {
    Image::from_pixels(width, height, pixels.to_vec()).expect("pixel count matches")
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1.0)
}

// ---------------------------------------------------------------- metrics

#[test]
fn metrics_uniform_difference_2x1() {
    let a = img(2, 1, &[[1.0, 1.0, 1.0], [3.0, 3.0, 3.0]]);
    let b = img(2, 1, &[[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]);
    let s = compare(&a, &b).unwrap();
    // N = 3 channels * 2 pixels = 6 values.
    // differences: 0 0 0 2 2 2; squared: 0 0 0 4 4 4; sum 12; mean 12/6 = 2.
    // RMSE = sqrt(2) = 1.41421356...
    // mean(b) = 6/6 = 1  =>  rel RMSE = sqrt(2).
    // max |a-b| = 2.
    // peak = max(b) = 1  =>  PSNR = 20 log10(1/sqrt(2)) = -10 log10(2) = -3.0103 dB.
    assert!(close(s.rmse, 2f64.sqrt()), "{s:?}");
    assert!(close(s.rel_rmse, 2f64.sqrt()), "{s:?}");
    assert!(close(s.max_abs, 2.0), "{s:?}");
    assert!(close(s.mean_ref, 1.0), "{s:?}");
    assert!(close(s.psnr, -10.0 * 2f64.log10()), "{s:?}");
    assert!((s.psnr - (-3.0103)).abs() < 1e-4, "{s:?}");
    assert_eq!(s.non_finite, 0);
    assert_eq!(s.pixels, 2);
}

#[test]
fn worst_pixels_share_tells_one_bad_pixel_from_error_everywhere() {
    let zeros = vec![[0.0f32; 3]; 100];
    let reference = img(10, 10, &zeros);
    // One pixel of 100 holds all of it: the worst 1% (one pixel), and the worst 0.1% (rounded up
    // to one pixel), hold 100%.
    let mut one = zeros.clone();
    one[37] = [0.5, 0.0, 1.0];
    let s = worst_pixels_share(&img(10, 10, &one), &reference, &[0.001, 0.01, 0.1]).unwrap().unwrap();
    assert_eq!(s, [1.0, 1.0, 1.0]);
    // The same difference in every pixel: the worst 10% hold 10%.
    let all = vec![[0.25f32, 0.25, 0.25]; 100];
    let s = worst_pixels_share(&img(10, 10, &all), &reference, &[0.01, 0.1, 1.0]).unwrap().unwrap();
    assert!(close(s[0], 0.01) && close(s[1], 0.1) && close(s[2], 1.0), "{s:?}");
    // Two pixels, squared errors 1 + 1 + 1 = 3 and 9 (channels summed): 9/12 in the worst half.
    let a = img(2, 1, &[[1.0, 1.0, 1.0], [0.0, 0.0, 3.0]]);
    let b = img(2, 1, &[[0.0; 3], [0.0; 3]]);
    let s = worst_pixels_share(&a, &b, &[0.5]).unwrap().unwrap();
    assert!(close(s[0], 0.75), "{s:?}");
    // Nothing to share out: equal images, or a non-finite value (compare says infinite RMSE).
    assert_eq!(worst_pixels_share(&reference, &reference, &[0.1]).unwrap(), None);
    let mut nan = zeros.clone();
    nan[3] = [f32::NAN, 0.0, 0.0];
    assert_eq!(worst_pixels_share(&img(10, 10, &nan), &reference, &[0.1]).unwrap(), None);
    assert!(matches!(
        worst_pixels_share(&img(2, 1, &[[0.0; 3]; 2]), &reference, &[0.1]),
        Err(MetricsError::SizeMismatch { .. })
    ));
}

#[test]
fn metrics_mixed_channels_2x1() {
    let b = img(2, 1, &[[1.0, 2.0, 4.0], [1.0, 0.0, 0.0]]);
    let a = img(2, 1, &[[1.5, 1.0, 4.0], [1.0, 0.0, 2.0]]);
    let s = compare(&a, &b).unwrap();
    // N = 6 values.
    // differences a-b: 0.5 -1 0 | 0 0 2; squared: 0.25 1 0 | 0 0 4; sum 5.25; mean 5.25/6 = 0.875.
    // RMSE = sqrt(0.875) = 0.935414346693...
    // mean(b) = (1+2+4+1+0+0)/6 = 8/6 = 4/3  =>  rel RMSE = 0.935414.../(4/3) = 0.701560760...
    // max |a-b| = 2.
    // peak = max(b) = 4  =>  PSNR = 20 log10(4/0.935414...) = 12.6211... dB.
    assert!(close(s.rmse, 0.875f64.sqrt()));
    assert!((s.rmse - 0.935_414_346_693).abs() < 1e-11);
    assert!(close(s.mean_ref, 4.0 / 3.0));
    assert!(close(s.rel_rmse, 0.875f64.sqrt() * 3.0 / 4.0));
    assert!((s.rel_rmse - 0.701_560_760_020).abs() < 1e-11);
    assert!(close(s.max_abs, 2.0));
    assert!(close(s.psnr, 20.0 * (4.0 / 0.875f64.sqrt()).log10()));
    assert!((s.psnr - 12.6211).abs() < 1e-4, "{}", s.psnr);
    assert_eq!(s.to_string(), "rel RMSE 70.16% | max abs 2.0e0 | PSNR 12.6 dB");
}

#[test]
fn metrics_identical_images() {
    let a = img(2, 2, &[[0.1, 0.2, 0.3], [1.0, 2.0, 3.0], [0.0, 0.0, 0.0], [5.0, 0.5, 0.05]]);
    let s = compare(&a, &a.clone()).unwrap();
    assert_eq!(s.rmse, 0.0);
    assert_eq!(s.rel_rmse, 0.0);
    assert_eq!(s.max_abs, 0.0);
    assert_eq!(s.psnr, f64::INFINITY);
    assert_eq!(s.pixels, 4);
    assert_eq!(s.to_json()["psnr"], "inf");
    assert_eq!(s.to_json()["rmse"], 0.0);
    assert_eq!(s.to_string(), "rel RMSE 0.00% | max abs 0.0e0 | PSNR inf dB");
}

#[test]
fn metrics_black_reference() {
    let zero = Image::new(3, 2);
    let s = compare(&zero, &zero).unwrap();
    assert_eq!((s.rel_rmse, s.psnr), (0.0, f64::INFINITY));
    let mut a = Image::new(3, 2);
    a.set(1, 1, [0.0, 0.5, 0.0]);
    let s = compare(&a, &zero).unwrap();
    assert_eq!(s.mean_ref, 0.0);
    assert_eq!(s.rel_rmse, f64::INFINITY);
    assert_eq!(s.psnr, f64::NEG_INFINITY);
    assert!(close(s.rmse, (0.25f64 / 18.0).sqrt()));
}

#[test]
fn metrics_size_mismatch_names_both_sizes() {
    let err = compare(&Image::new(4, 3), &Image::new(3, 4)).unwrap_err();
    assert!(matches!(err, MetricsError::SizeMismatch { .. }));
    let msg = err.to_string();
    assert!(msg.contains("4x3") && msg.contains("3x4"), "{msg}");
}

#[test]
fn metrics_empty_and_broken_reference_are_errors() {
    assert!(matches!(compare(&Image::new(0, 5), &Image::new(0, 5)), Err(MetricsError::Empty { .. })));
    let mut r = Image::new(2, 1);
    r.set(0, 0, [f32::NAN, 0.0, 0.0]);
    assert!(matches!(compare(&Image::new(2, 1), &r), Err(MetricsError::NonFiniteReference { count: 1 })));
    let bad = Image { width: 2, height: 2, pixels: vec![[0.0; 3]; 3] };
    assert!(matches!(compare(&bad, &Image::new(2, 2)), Err(MetricsError::BadPixelCount { .. })));
}

#[test]
fn metrics_non_finite_test_values_are_counted() {
    let b = img(2, 1, &[[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]);
    let a = img(2, 1, &[[f32::NAN, 1.0, 1.0], [1.0, f32::INFINITY, 1.0]]);
    let s = compare(&a, &b).unwrap();
    assert_eq!(s.non_finite, 2);
    assert_eq!(s.rel_rmse, f64::INFINITY);
    assert_eq!(s.max_abs, f64::INFINITY);
    assert_eq!(s.rmse, f64::INFINITY);
    assert_eq!(s.psnr, f64::NEG_INFINITY);
    assert!(close(s.mean_ref, 1.0));
    let j = s.to_json();
    assert_eq!(j["non_finite"], 2);
    assert_eq!(j["rel_rmse"], "inf");
    assert_eq!(j["psnr"], "-inf");
    assert_eq!(j["pixels"], 2);
    assert!(s.to_string().ends_with("| 2 non-finite values"), "{s}");
}

// ---------------------------------------------------------------- image basics

#[test]
fn construction_and_accessors() {
    let data: Vec<f32> = (0..2 * 3 * 4).map(|i| i as f32).collect();
    let im = Image::from_rgba_f32(2, 3, &data).unwrap();
    assert_eq!(im.get(0, 0), [0.0, 1.0, 2.0]);
    assert_eq!(im.get(1, 0), [4.0, 5.0, 6.0]);
    assert_eq!(im.get(1, 2), [20.0, 21.0, 22.0]);
    // R values 0,4,...,20 mean 10; G 11; B 12.
    assert_eq!(im.mean(), [10.0, 11.0, 12.0]);
    assert_eq!(im.count_non_finite(), 0);
    assert_eq!(Image::new(0, 0).mean(), [0.0; 3]);

    let err = Image::from_rgba_f32(2, 3, &data[..23]).unwrap_err();
    assert!(matches!(err, ImageError::SizeMismatch { expected: 24, actual: 23, .. }), "{err}");
    assert!(Image::from_pixels(2, 2, vec![[0.0; 3]; 5]).is_err());

    let mut im = Image::new(2, 2);
    im.set(1, 0, [f32::NAN, f32::INFINITY, 1.0]);
    im.set(0, 1, [f32::NEG_INFINITY, 0.0, 0.0]);
    assert_eq!(im.count_non_finite(), 3);
}

#[test]
fn tone_map_and_srgb() {
    assert_eq!(tone_map_aces(0.0), 0.0);
    assert_eq!(tone_map_aces(-1.0), 0.0);
    assert_eq!(tone_map_aces(f32::NAN), 0.0);
    assert_eq!(tone_map_aces(f32::INFINITY), 1.0);
    assert_eq!(tone_map_aces(1e30), 1.0);
    assert_eq!(tone_map_aces(8.0), 1.0);
    // f(1) = 2.54 / 3.16
    assert!((tone_map_aces(1.0) - 2.54 / 3.16).abs() < 1e-6);
    let mut prev = 0.0;
    for i in 1..1000 {
        let y = tone_map_aces(i as f32 * 0.01);
        assert!(y >= prev, "monotone");
        prev = y;
    }
    assert_eq!(encode_srgb8(0.0), 0);
    assert_eq!(encode_srgb8(1.0), 255);
    assert_eq!(encode_srgb8(2.0), 255);
    // 0.5 linear -> 0.7354 encoded -> 187.5 -> 188
    assert_eq!(encode_srgb8(0.5), 188);
    // linear segment: 0.001 * 12.92 * 255 = 3.29 -> 3
    assert_eq!(encode_srgb8(0.001), 3);

    let im = img(2, 1, &[[0.0, 1.0, f32::NAN], [100.0, -1.0, 1.0]]);
    let rgba = im.to_srgb8(0.0);
    let one = encode_srgb8(tone_map_aces(1.0));
    assert_eq!(rgba, vec![0, one, 0, 255, 255, 0, one, 255]);
    // +1 stop doubles the input: 0.5 at +1 stop is the same as 1.0 at 0 stops.
    let half = img(1, 1, &[[0.5, 0.5, 0.5]]);
    assert_eq!(half.to_srgb8(1.0)[..3], [one, one, one]);
}

// ---------------------------------------------------------------- files

fn test_image(w: u32, h: u32) -> Image {
    let mut im = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let t = (y * w + x) as f32;
            im.set(x, y, [t * 0.123_456_79, 1.0 / (t + 1.0), (t * 0.7).sin() * 1e-3 + 1e6 * (x == 0) as u32 as f32]);
        }
    }
    // Exotic values must survive too.
    im.set(1, 0, [f32::MIN_POSITIVE, -0.0, f32::MAX]);
    im.set(2, 0, [f32::INFINITY, f32::NEG_INFINITY, -3.5]);
    im
}

#[test]
fn exr_round_trip_is_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("img.exr");
    // Odd sizes, larger than one 16-line ZIP block.
    let im = test_image(37, 23);
    im.write_exr(&path).unwrap();
    let back = Image::read_exr(&path).unwrap();
    assert_eq!((back.width, back.height), (37, 23));
    for (a, b) in im.pixels.iter().zip(&back.pixels) {
        for c in 0..3 {
            assert_eq!(a[c].to_bits(), b[c].to_bits());
        }
    }
    // NaN survives as NaN.
    let mut nan = Image::new(1, 1);
    nan.set(0, 0, [f32::NAN, 1.0, 2.0]);
    nan.write_exr(&path).unwrap();
    let back = Image::read_exr(&path).unwrap();
    assert!(back.get(0, 0)[0].is_nan());
    assert_eq!(back.get(0, 0)[1..], [1.0, 2.0]);
    // Only the destination file is left: no temporary files.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, vec![std::ffi::OsString::from("img.exr")]);
}

#[test]
fn exr_reads_rgba_f16_files() {
    use exr::prelude::{f16, write_rgba_file};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("half.exr");
    write_rgba_file(&path, 3, 2, |x, y| {
        let v = f16::from_f32((x + 3 * y) as f32 * 0.5);
        (v, v, f16::from_f32(1.0), f16::from_f32(0.25))
    })
    .unwrap();
    let im = Image::read_exr(&path).unwrap();
    assert_eq!((im.width, im.height), (3, 2));
    assert_eq!(im.get(2, 1), [2.5, 2.5, 1.0]);
    assert_eq!(im.get(0, 0), [0.0, 0.0, 1.0]);
}

#[test]
fn png_has_the_right_size() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.png");
    let im = test_image(13, 7);
    im.write_png(&path, 0.0).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height as big-endian u32 at bytes 16..24.
    assert_eq!(u32::from_be_bytes(bytes[16..20].try_into().unwrap()), 13);
    assert_eq!(u32::from_be_bytes(bytes[20..24].try_into().unwrap()), 7);
    // Overwriting an existing file works (rename over it).
    Image::new(2, 3).write_png(&path, -1.0).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(u32::from_be_bytes(bytes[16..20].try_into().unwrap()), 2);
    assert_eq!(u32::from_be_bytes(bytes[20..24].try_into().unwrap()), 3);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary files left");
}

#[test]
fn writing_into_a_missing_directory_names_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let im = Image::new(2, 2);
    for path in [dir.path().join("missing/sub/out.png"), dir.path().join("missing/out.exr")] {
        let err = if path.extension().unwrap() == "png" {
            im.write_png(&path, 0.0).unwrap_err()
        } else {
            im.write_exr(&path).unwrap_err()
        };
        assert!(matches!(err, ImageError::Io { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains(&*path.to_string_lossy()), "{msg}");
        assert!(msg.contains("write"), "{msg}");
    }
}

#[test]
fn writing_an_empty_image_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.exr");
    let err = Image::new(0, 4).write_exr(&path).unwrap_err();
    assert!(err.to_string().contains(&*path.to_string_lossy()), "{err}");
    assert!(!path.exists());
}

#[test]
fn reading_bad_files_names_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let not_exr = dir.path().join("not.exr");
    std::fs::write(&not_exr, b"this is a text file, not an OpenEXR image\n").unwrap();
    let err = Image::read_exr(&not_exr).unwrap_err();
    assert!(matches!(err, ImageError::Exr { .. }), "{err:?}");
    assert!(err.to_string().contains(&*not_exr.to_string_lossy()), "{err}");

    // A PNG is not an EXR either.
    let png = dir.path().join("img.png");
    Image::new(2, 2).write_png(&png, 0.0).unwrap();
    let err = Image::read_exr(&png).unwrap_err();
    assert!(err.to_string().contains(&*png.to_string_lossy()), "{err}");

    // A truncated EXR.
    let exr = dir.path().join("cut.exr");
    test_image(20, 20).write_exr(&exr).unwrap();
    let bytes = std::fs::read(&exr).unwrap();
    std::fs::write(&exr, &bytes[..bytes.len() / 2]).unwrap();
    let err = Image::read_exr(&exr).unwrap_err();
    assert!(err.to_string().contains(&*exr.to_string_lossy()), "{err}");

    let missing = dir.path().join("missing.exr");
    let err = Image::read_exr(&missing).unwrap_err();
    assert!(matches!(err, ImageError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains(&*missing.to_string_lossy()), "{err}");
}
