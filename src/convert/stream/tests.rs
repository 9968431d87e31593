use super::*;

/// A 512 x 256 panorama: a dim gradient, a wide bright band (a glass roof: many rows of
/// peaks, uneven) and a small sun.
fn sky() -> Image {
    let (w, h) = (512, 256);
    let mut img = Image::new(w, h);
    for (i, p) in img.pixels.iter_mut().enumerate() {
        let (x, y) = ((i % w) as f32, (i / w) as f32);
        *p = Vec4::new(0.2 + x / 2048.0, 0.3, 0.1 + y / 1024.0, 1.0);
        if (40.0..70.0).contains(&y) && (100.0..250.0).contains(&x) {
            let v = 10.0 + 20.0 * ((x * 0.37).sin() * (y * 0.21).cos()).abs();
            *p = Vec4::new(v, 0.9 * v, 0.7 * v, 1.0);
        }
        if (20.0..23.0).contains(&y) && (450.0..453.0).contains(&x) {
            *p = Vec4::new(900.0, 800.0, 600.0, 1.0);
        }
    }
    img
}

/// The copy and its peaks when the ceiling is guessed as `guess`.
fn reduced(path: &Path, guess: Vec3) -> (Image, Peaks) {
    let got = bands::with_bands(path, &ReadOptions::default(), |b| {
        reduce_from(b, path, MIN_BAND, guess)
    });
    match got.expect("reads").expect("streams").source {
        Source::Reduced(r) => (r.image, r.peaks.expect("peaks")),
        _ => panic!("a reduced copy"),
    }
}

/// Whatever the guess (below the mean's ceiling, above it, or so low that too many texels
/// would be peaks), the copy and its peaks are those the mean's own ceiling gives: the raise
/// puts back what lay between the two, the other two read the bands again.
#[test]
fn every_guess_settles_to_the_mean_s_own_ceiling() {
    let dir = tempfile::tempdir().expect("a folder");
    let path = dir.path().join("sky.exr");
    std::fs::write(
        &path,
        crate::io::exr::encode(&sky(), false).expect("encodes"),
    )
    .expect("writes");
    // An infinite guess is above the mean's ceiling: the bands are read again below it.
    let (image, peaks) = reduced(&path, Vec3::INFINITY);
    let exact = peaks.ceiling;
    assert!(peaks.len() > 1000, "{} peaks", peaks.len());
    for guess in [exact, 0.4 * exact, 1.5 * exact, 0.001 * exact] {
        let (other, p) = reduced(&path, guess);
        assert_eq!(p.ceiling, exact, "guess {guess}");
        assert_eq!(p.len(), peaks.len(), "guess {guess}");
        let (f, g) = (peaks.flux(), p.flux());
        for c in 0..3 {
            assert!(
                (f[c] - g[c]).abs() <= 1e-5 * f[c],
                "guess {guess}: {f:?} {g:?}"
            );
        }
        for (a, b) in image.pixels.iter().zip(&other.pixels) {
            let tol = 1e-5 * a.abs().max_element().max(1.0);
            assert!(
                (*a - *b).abs().max_element() <= tol,
                "guess {guess}: {a} {b}"
            );
        }
    }
}
