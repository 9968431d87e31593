//! Tests of the parallel search for scanline starts, against a single walk.

use super::*;
use glam::Vec4;

/// The starts one walk from the first line finds, or the line it fails at.
fn serial(data: &[u8], first: usize, w: usize, h: usize) -> std::result::Result<Vec<usize>, usize> {
    let mut starts = Vec::with_capacity(h);
    let mut p = first;
    for y in 0..h {
        starts.push(p);
        p = scanline(data, p, w, None).ok_or(y)?;
    }
    Ok(starts)
}

/// The walk in pieces finds the one walk's starts, or fails at its line: for a file,
/// the file with false starts planted in every piece, and cut short or corrupted.
#[test]
fn pieces_find_the_starts_of_one_walk() {
    let (w, h) = (700, 600);
    let img = Image::from_fn(w, h, |x, y| {
        let n = ((x * 7919 + y * 104_729) % 1009) as f32;
        Vec4::new(
            n / 100.0,
            (x % 13) as f32,
            if y % 50 < 5 { 3.0 } else { n },
            1.0,
        )
    });
    let file = encode(&img);
    let first = file.iter().position(|&b| b == b'\n').unwrap();
    let first = first + file[first..].windows(2).position(|p| p == b"\n-").unwrap();
    let first = first + 1 + file[first + 1..].iter().position(|&b| b == b'\n').unwrap() + 1;
    assert!(file.len() - first > 1 << 20);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(5)
        .build()
        .unwrap();
    let both = |data: &[u8], what: &str| {
        let want = serial(data, first, w, h);
        assert_eq!(
            pool.install(|| line_starts(data, first, w, h)),
            want,
            "{what}"
        );
        want
    };
    assert!(both(&file, "file").is_ok());
    // False starts planted in literal runs (any bytes go there: the file stays valid)
    // all through the file: a whole line of runs (so a piece's walk takes it for a
    // start, and the true walk must walk that piece again), or just the line's key.
    let line = serial(&file, first, w, h).unwrap();
    let mut fake = vec![2, 2, (w >> 8) as u8, w as u8];
    for _ in 0..4 {
        for n in [127; 5].into_iter().chain([w - 5 * 127]) {
            fake.extend([128 + n as u8, 9]);
        }
    }
    for plant in [&fake[..], &fake[..4]] {
        let mut planted = file.clone();
        for &s in line.iter().step_by(5) {
            // The first literal run long enough in the line.
            let mut q = s + 4;
            while file[q] > 128 || (file[q] as usize) < plant.len() {
                q += if file[q] > 128 {
                    2
                } else {
                    1 + file[q] as usize
                };
            }
            planted[q + 1..q + 1 + plant.len()].copy_from_slice(plant);
        }
        assert_eq!(both(&planted, "planted"), Ok(line.clone()));
    }
    for cut in [first + 5, file.len() / 2, file.len() - 1] {
        assert!(both(&file[..cut], &format!("cut at {cut}")).is_err());
    }
    for at in [first + 4, file.len() / 3, file.len() - 200] {
        let mut bad = file.clone();
        bad[at] = 0;
        let _ = both(&bad, &format!("zero at {at}"));
    }
}
