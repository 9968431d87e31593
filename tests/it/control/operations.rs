//! The operations on a source (invert, remap, multiply, mix) and `[pack]`, which moves
//! parameters between channels: exact values for each.

use super::*;
use cubeforge::internals::control::Slot;
use glam::Vec4;

#[test]
fn invert() {
    assert_eq!(
        refl("checker = { cells = [2, 1] }\ninvert = true", 4, 1),
        [1., 1., 0., 0.]
    );
    assert_close(&refl("constant = 0.25\ninvert = true", 1, 1), &[0.75]);
    assert_close(&refl("constant = 0.25\ninvert = false", 1, 1), &[0.25]);
}

#[test]
fn remap_levels_and_gamma() {
    // Gradient 0.125 .. 0.875 onto 0.2 .. 0.6.
    assert_close(
        &refl(
            "linear_gradient = {}\nremap = { in = [0.125, 0.875], out = [0.2, 0.6] }",
            4,
            1,
        ),
        &[0.2, 0.2 + 0.4 / 3.0, 0.2 + 0.8 / 3.0, 0.6],
    );
    // Below and above the input levels clamp.
    assert_close(
        &refl(
            "linear_gradient = {}\nremap = { in = [0.375, 0.625] }",
            4,
            1,
        ),
        &[0.0, 0.0, 1.0, 1.0],
    );
    // Gamma like the middle slider of Levels: t^(1/gamma).
    assert_close(
        &refl("constant = 0.25\nremap = { gamma = 2 }", 1, 1),
        &[0.5],
    );
    assert_close(
        &refl("constant = 0.25\nremap = { gamma = 0.5 }", 1, 1),
        &[0.0625],
    );
    // Reversed output levels invert; gamma applies before the output levels.
    assert_close(
        &refl(
            "constant = 0.25\nremap = { out = [1, 0.5], gamma = 2 }",
            1,
            1,
        ),
        &[0.75],
    );
    // Remap comes before invert, whatever the order in the file.
    assert_close(
        &refl(
            "constant = 0.25\ninvert = true\nremap = { gamma = 2 }",
            1,
            1,
        ),
        &[0.5],
    );
}

#[test]
fn multiply() {
    assert_close(
        &refl("checker = { cells = [2, 1] }\nmultiply = 0.5", 4, 1),
        &[0.0, 0.0, 0.5, 0.5],
    );
    assert_close(
        &refl("constant = 0.5\nmultiply = { linear_gradient = {} }", 4, 1),
        &[0.0625, 0.1875, 0.3125, 0.4375],
    );
}

#[test]
fn mix_with_another_source() {
    // amount 0 keeps the value, 1 takes `with`, exactly.
    assert_eq!(
        refl(
            "constant = 0.2\nmix = { with = 0.9, amount = { checker = { cells = [2, 1] } } }",
            4,
            1
        ),
        [0.2, 0.2, 0.9, 0.9]
    );
    assert_close(
        &refl("constant = 0.2\nmix = { with = 1, amount = 0.25 }", 1, 1),
        &[0.4],
    );
    // Operations nest: `with` and `amount` are sources with operations of their own.
    assert_close(
        &refl(
            "constant = 0\nmix = { with = { constant = 0.25, invert = true }, amount = { constant = 1, multiply = 0.5 } }",
            1,
            1,
        ),
        &[0.375],
    );
    // The order: remap, invert, multiply, mix.
    assert_close(
        &refl(
            "constant = 0.25\nmix = { with = 1, amount = 0.5 }\nmultiply = 0.5\ninvert = true\nremap = { gamma = 2 }",
            1,
            1,
        ),
        // 0.25 -> remap 0.5 -> invert 0.5 -> x0.5 0.25 -> mix with 1 by 0.5: 0.625
        &[0.625],
    );
}

#[test]
fn pack_reassigns_channels() {
    let b = bake(
        "max_lod_bias = 3\nreflectivity = 0.2\ntransmittance = 0.4\nblur = 0.6\n\n[pack]\nr = \"blur\"\ng = \"one\"\nb = \"zero\"\na = \"reflectivity\"\n",
        2,
        2,
    );
    for p in &b.image.pixels {
        assert_eq!(*p, Vec4::new(0.6, 1.0, 0.0, 0.2));
    }
    let holds: Vec<Slot> = b.channels.iter().map(|c| c.holds).collect();
    assert_eq!(
        holds,
        [Slot::Blur, Slot::One, Slot::Zero, Slot::Reflectivity]
    );
    // transmittance is set but packed nowhere: a warning says so.
    assert_eq!(b.warnings.len(), 1, "{:?}", b.warnings);
    assert!(b.warnings[0].contains("transmittance"));
    // Channels not named keep their default.
    let b = bake(
        "reflectivity = 0.2\nfresnel = 0.8\n[pack]\nr = \"fresnel\"\n",
        1,
        1,
    );
    assert_eq!(b.image.pixels[0], Vec4::new(0.8, 0.0, 0.0, 0.8));
    assert!(b.warnings[0].contains("reflectivity"));
}
