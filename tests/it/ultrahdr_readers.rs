//! UltraHDR files as Google's own encoder writes them (issue 48): libultrahdr 2.0.2's default
//! build writes the gain-map metadata as ISO 21496-1 only (no XMP), another build writes both.
//! cubeforge reads each as its radiance at full boost, in BT.709 primaries (the pictures are in
//! Display P3, which their ICC profile says), and matches libultrahdr's own linear decode
//! (`*.libultrahdr.exr`, beside each file) within 0.1% of the light wherever that decode is
//! below its clamp (10000/203 = 49.26 x SDR white). The two builds' decodes differ: the ISO
//! build's is in BT.709, the XMP build's in the picture's Display P3, so that one is compared
//! with cubeforge's taken back to P3.

use crate::common::{self, read_image, run, stderr};

/// libultrahdr's linear output stops here (its peak of 10000 nits over SDR white's 203).
const CLAMP: f32 = 10000.0 / 203.0;

/// Linear Display P3 to linear BT.709 (both D65), from the primaries' chromaticities
/// (P3: 0.680 0.320, 0.265 0.690, 0.150 0.060; BT.709: 0.64 0.33, 0.30 0.60, 0.15 0.06).
fn p3_to_709() -> glam::Mat3 {
    let to_xyz = |p: [[f32; 2]; 3]| {
        let xyz = |[x, y]: [f32; 2]| glam::Vec3::new(x / y, 1.0, (1.0 - x - y) / y);
        let m = glam::Mat3::from_cols(xyz(p[0]), xyz(p[1]), xyz(p[2]));
        let white = xyz([0.3127, 0.3290]);
        let s = m.inverse() * white;
        glam::Mat3::from_cols(m.x_axis * s.x, m.y_axis * s.y, m.z_axis * s.z)
    };
    let p3 = to_xyz([[0.680, 0.320], [0.265, 0.690], [0.150, 0.060]]);
    let bt709 = to_xyz([[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]]);
    bt709.inverse() * p3
}

#[test]
fn libultrahdr_files_read_as_its_own_decode() {
    let Some(real) = common::real_dir() else {
        eprintln!("SKIPPED ultrahdr_readers: ../shared/fixtures/real not found");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let to_p3 = p3_to_709().inverse();
    // The docs' figures: the largest light difference, median and 99th percentile.
    let (mut light, mut med, mut pct) = (0f64, 0f32, 0f32);
    for (name, p3) in [("esplanade_iso", false), ("esplanade_xmp", true)] {
        let jpg = real.join("ultrahdr").join(format!("{name}.jpg"));
        let o = run(["info".as_ref(), jpg.as_os_str()]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(
            text.contains("UltraHDR JPEG") && text.contains("ISO 21496-1"),
            "{name}: {text}"
        );
        let out = dir.path().join(format!("{name}.exr"));
        let o = run([
            "convert".as_ref(),
            jpg.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--to".as_ref(),
            "equirect".as_ref(),
            "--exr-float".as_ref(),
            "f32".as_ref(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let mut ours = read_image(&out);
        if p3 {
            for p in &mut ours.pixels {
                *p = (to_p3 * p.truncate()).extend(p.w);
            }
        }
        let theirs = read_image(
            &real
                .join("ultrahdr")
                .join(format!("{name}.libultrahdr.exr")),
        );
        assert_eq!((ours.width, ours.height), (theirs.width, theirs.height));
        // Per channel, the light of the texels libultrahdr did not clamp; each texel's largest
        // relative difference (over a floor of 0.05: the JPEG decoders' own differences in the
        // dark), whose median and 99th percentile say how alike the two decodes are.
        let (mut a, mut b, mut offs) = ([0f64; 3], [0f64; 3], Vec::new());
        for (p, q) in ours.pixels.iter().zip(&theirs.pixels) {
            if q.truncate().max_element() >= 0.99 * CLAMP {
                continue;
            }
            let mut off = 0f32;
            for c in 0..3 {
                a[c] += p[c] as f64;
                b[c] += q[c] as f64;
                off = off.max((p[c] - q[c]).abs() / (q[c].abs() + 0.05));
            }
            offs.push(off);
        }
        offs.sort_by(f32::total_cmp);
        let (median, p99) = (offs[offs.len() / 2], offs[offs.len() * 99 / 100]);
        let off: Vec<f64> = (0..3).map(|c| a[c] / b[c] - 1.0).collect();
        println!(
            "{name}: {} texels below libultrahdr's clamp; light off by R {:+.3}% G {:+.3}% B {:+.3}%; texels off by {:.2}% (median), {:.2}% (99th percentile)",
            offs.len(),
            100.0 * off[0],
            100.0 * off[1],
            100.0 * off[2],
            100.0 * median,
            100.0 * p99
        );
        assert!(off.iter().all(|o| o.abs() < 1e-3), "{name}: {off:?}");
        assert!(median < 0.01 && p99 < 0.03, "{name}: {median} {p99}");
        light = off.iter().fold(light, |l, o| l.max(o.abs()));
        (med, pct) = (med.max(median), pct.max(p99));
    }
    let text = format!(
        "come within {:.2}% of the light of libultrahdr's own decode",
        100.0 * light
    );
    crate::figures::check("docs/formats.md", "libultrahdr light", &text);
    let text = format!(
        "each texel within {:.1}% at the median and {:.1}% at the 99th percentile",
        100.0 * med,
        100.0 * pct
    );
    crate::figures::check("docs/formats.md", "libultrahdr texels", &text);
}

/// A JPEG that declares an ISO 21496-1 gain map whose metadata cannot be read is refused in
/// one line, not lit by its SDR picture.
#[test]
fn a_gain_map_that_cannot_be_read_is_refused() {
    let Some(real) = common::real_dir() else {
        eprintln!("SKIPPED ultrahdr_readers: ../shared/fixtures/real not found");
        return;
    };
    let mut bytes = std::fs::read(real.join("ultrahdr/esplanade_iso.jpg")).unwrap();
    // Every ISO block's payload after its versions: the flags byte says 3 channels with a
    // common denominator, and the denominator becomes 0.
    let ns = b"urn:iso:std:iso:ts:21496:-1\0";
    let mut at = 0;
    let mut broken = 0;
    while let Some(i) = bytes[at..].windows(ns.len()).position(|w| w == ns) {
        let p = at + i + ns.len();
        // Segment length (2 bytes before the namespace) tells a full block from a version-only.
        let len = u16::from_be_bytes([bytes[at + i - 2], bytes[at + i - 1]]) as usize;
        if len > 2 + ns.len() + 4 {
            bytes[p + 4] |= 0x08;
            bytes[p + 5..p + 9].copy_from_slice(&[0; 4]);
            broken += 1;
        }
        at = p;
    }
    assert_eq!(broken, 1, "one full ISO block, in the gain map");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.jpg");
    std::fs::write(&path, bytes).unwrap();
    let o = run(["info".as_ref(), path.as_os_str()]);
    let err = stderr(&o);
    assert!(
        !o.status.success(),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("broken.jpg") && err.contains("ISO 21496-1"),
        "{err}"
    );
}
