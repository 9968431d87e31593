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

/// The guess against the mean's own ceiling on the real panoramas, each sampled as a 16K
/// file's bands are (16 rows of 256, as 16 bands of 32 rows of 8192), from a Radiance copy
/// (one row a band): never above it (a second read of the whole file), and the share of
/// texels it keeps as peaks. Skipped without ../shared/fixtures/real.
#[test]
fn the_guess_stays_below_the_mean_s_ceiling_on_real_panoramas() {
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/fixtures/real/dwab");
    let Ok(entries) = std::fs::read_dir(&real) else {
        println!("SKIPPED: {} not found", real.display());
        return;
    };
    let mut files: Vec<_> = entries.flatten().map(|e| e.path()).collect();
    files.sort();
    let dir = tempfile::tempdir().expect("a folder");
    let opts = ReadOptions::default();
    for file in files {
        let Ok((crate::io::Decoded::Image(img), _)) = crate::convert::read::read(&file, &opts)
        else {
            continue;
        };
        let hdr = dir.path().join("pano.hdr");
        std::fs::write(&hdr, crate::io::rgbe::encode(&img)).expect("writes");
        let guess = bands::with_bands(&hdr, &opts, |b| guess_ceiling(b, &hdr, 1))
            .expect("reads")
            .expect("streams");
        let (Ok((crate::io::Decoded::Image(back), _)), (w, h)) = (
            crate::convert::read::read(&hdr, &opts),
            (img.width, img.height),
        ) else {
            panic!("reads back");
        };
        let grid = Grid::Projection(Projection::Equirect, w, h);
        let rows: Vec<RowStats> = (0..h)
            .map(|y| RowStats::of_row(grid, &back.pixels[y * w..(y + 1) * w], y))
            .collect();
        let exact = Peaks::ceiling_of(&rows).expect("a mean");
        let kept = back
            .pixels
            .iter()
            .filter(|p| p.truncate().cmpgt(guess).any())
            .count();
        println!(
            "{}: guess {:.2} of the mean's ceiling (largest channel), {:.2}% of texels kept",
            file.file_name().unwrap().to_string_lossy(),
            (guess / exact).max_element(),
            100.0 * kept as f64 / (w * h) as f64
        );
        assert!(
            guess.cmple(exact).all(),
            "{}: {guess} above {exact}",
            file.display()
        );
    }
}
