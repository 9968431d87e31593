use super::*;
use glam::Vec4;

/// A 64 x 32 panorama with bright texels: single ones, even and uneven whole blocks, a block
/// across the wrapping column, both poles' rows.
fn sky() -> Image {
    let mut img = Image::new(64, 32);
    img.pixels.fill(Vec4::new(0.1, 0.2, 0.3, 1.0));
    let mut put = |x: usize, y: usize, v: f32| img.set(x, y, Vec4::new(v, 0.5 * v, 0.1, 1.0));
    for (x, y, v) in [(0, 0, 9.0), (63, 31, 7.0), (10, 10, 50.0), (11, 10, 3.0)] {
        put(x, y, v);
    }
    for i in 0..4 {
        put(20 + i % 2, 16 + i / 2, 40.0 + i as f32);
        put(30 + i % 2, 20 + i / 2, if i == 0 { 90.0 } else { 40.0 });
        put(62 + i % 2, 6 + i / 2, 30.0);
    }
    img
}

fn grid(img: &Image) -> Grid {
    Grid::Projection(Projection::Equirect, img.width, img.height)
}

/// Each row's peaks above `ceiling`, found from its planes as a stream finds them.
fn rows(img: &Image, ceiling: Vec3) -> Vec<PeakRow> {
    let w = img.width;
    (0..img.height)
        .map(|y| {
            let row = &img.pixels[y * w..(y + 1) * w];
            let planes: Vec<f32> = (0..4).flat_map(|c| row.iter().map(move |p| p[c])).collect();
            Peaks::of_planes(grid(img), y, &planes, ceiling)
        })
        .filter(|r| r.len() > 0)
        .collect()
}

fn settle(img: &Image, from: Vec3, to: Vec3, half: &mut Image) -> Peaks {
    Peaks::settle(grid(img), (from, to), rows(img, from), half, |_| 1.0).expect("peaks")
}

#[test]
fn centred_blocks_are_summed_and_every_texel_s_flux_is_kept() {
    let img = sky();
    let found = Peaks::find(grid(&img), &[&img]).expect("peaks");
    let c = found.ceiling;
    let mut half = Image::new(32, 16);
    let settled = settle(&img, c, c, &mut half);
    assert!(
        half.pixels.iter().all(|p| *p == Vec4::ZERO),
        "nothing to raise"
    );
    assert_eq!(
        settled.block_grid(),
        Grid::Projection(Projection::Equirect, 32, 16)
    );
    // The even block and the one at the seam; the uneven one (90 beside 40s) stays.
    let mut made: Vec<(u32, u32)> = settled.blocks.iter().map(|b| (b.x, b.y)).collect();
    made.sort();
    assert_eq!(made, vec![(10, 8), (31, 3)]);
    assert_eq!(settled.texels.len(), found.len() - 8);
    let (f, g) = (found.flux(), settled.flux());
    for ch in 0..3 {
        assert!((f[ch] - g[ch]).abs() <= 1e-6 * f[ch], "{ch}: {f:?} {g:?}");
    }
    for b in &settled.blocks {
        let own: Vec3 = found
            .texels
            .iter()
            .filter(|p| (p.x / 2, p.y / 2) == (b.x, b.y))
            .map(|p| p.excess * grid(&img).solid_angle(p.x as usize, p.y as usize) as f32)
            .sum();
        let omega = settled.block_grid().solid_angle(b.x as usize, b.y as usize) as f32;
        assert!((b.excess * omega - own).abs().max_element() <= 1e-5 * own.max_element());
    }
}

#[test]
fn a_raised_ceiling_gives_back_what_lies_between() {
    let img = sky();
    let c = Peaks::find(grid(&img), &[&img]).expect("peaks").ceiling;
    let (mut low, mut none) = (Image::new(32, 16), Image::new(32, 16));
    let raised = settle(&img, 0.25 * c, c, &mut low);
    let direct = settle(&img, c, c, &mut none);
    let key = |p: &Peaks| {
        let all = p.texels.iter().chain(&p.blocks);
        all.map(|t| (t.x, t.y, t.excess.to_array()))
            .collect::<Vec<_>>()
    };
    assert_eq!(raised.ceiling, c);
    assert_eq!(key(&raised), key(&direct));
    // Each reduced texel got its texels' parts between the two ceilings.
    for (i, got) in low.pixels.iter().enumerate() {
        let (hx, hy) = (i % 32, i / 32);
        let mut want = Vec3::ZERO;
        for (x, y) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let v = img.get(2 * hx + x, 2 * hy + y).truncate();
            want += (v.min(c) - 0.25 * c).max(Vec3::ZERO);
        }
        assert!(
            (got.truncate() - want).abs().max_element() < 1e-5,
            "{hx} {hy}"
        );
    }
}

#[test]
fn an_even_block_splats_as_its_four_texels() {
    let mut img = Image::new(256, 128);
    img.pixels.fill(Vec4::splat(0.2));
    for (x, y) in [(100, 40), (101, 40), (100, 41), (101, 41)] {
        img.set(x, y, Vec4::new(80.0, 60.0, 40.0, 1.0));
    }
    let found = Peaks::find(grid(&img), &[&img]).expect("peaks");
    let c = found.ceiling;
    let settled = settle(&img, c, c, &mut Image::new(128, 64));
    assert_eq!((settled.texels.len(), settled.blocks.len()), (0, 1));
    let splat = |p: &Peaks| {
        let mut faces: Vec<Image> = (0..6).map(|_| Image::new(16, 16)).collect();
        p.splat(Grid::Cube(16), None, &mut faces);
        faces
    };
    for (fa, fb) in splat(&found).iter().zip(&splat(&settled)) {
        for (p, q) in fa.pixels.iter().zip(&fb.pixels) {
            assert!((*p - *q).abs().max_element() <= 1e-4 * p.max_element().max(1.0));
        }
    }
}
