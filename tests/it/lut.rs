//! BRDF lookup tables against a brute-force quadrature of the same integrals over the
//! hemisphere of half vectors (no importance sampling, no Hammersley set), their layout, and
//! the files `cubeforge lut` writes.

use crate::common;

use cubeforge::internals::lut::{self, LutOptions};
use std::f64::consts::PI;

/// Which integral.
#[derive(Clone, Copy, Debug)]
enum Brdf {
    /// GGX, height-correlated Smith, Schlick: (scale, bias).
    Ggx,
    /// Charlie sheen with Ashikhmin visibility: (E, E).
    Charlie,
}

/// The integral of f(v, l) n.l over the hemisphere, by the midpoint rule over half vectors
/// h(theta, phi) with dl = 4 (v.h) dh. An angle psi = (pi/4)(1 - cos(pi s)), s uniform, puts
/// the steps closest at both ends (Charlie peaks at theta = pi/2, grazing n.v needs the
/// horizon resolved); for GGX theta = atan(alpha tan psi) then also spreads the peak at
/// theta = 0, however narrow, over many steps (in psi, D is smooth). phi covers [0, pi] (the
/// integrand is symmetric about the n-v plane). Returns the (1 - Fc) and Fc parts for GGX, the
/// albedo twice for Charlie.
fn quadrature(brdf: Brdf, nv: f64, roughness: f64, steps: usize) -> (f64, f64) {
    let a = roughness * roughness;
    let v = [(1.0 - nv * nv).sqrt(), 0.0, nv];
    let (nt, np) = (steps, steps / 2);
    let (ds, dp) = (1.0 / nt as f64, PI / np as f64);
    let (mut s0, mut s1) = (0.0f64, 0.0f64);
    for i in 0..nt {
        let s = (i as f64 + 0.5) * ds;
        let psi = PI / 4.0 * (1.0 - (PI * s).cos());
        let dpsi = PI * PI / 4.0 * (PI * s).sin() * ds;
        let (theta, dtheta) = match brdf {
            Brdf::Ggx => {
                // d theta / d psi = a sec^2(psi) / (1 + a^2 tan^2(psi)) = a / (cos^2 + a^2 sin^2).
                let (sp, cp) = psi.sin_cos();
                let theta = (a * sp).atan2(cp);
                (theta, a / (cp * cp + a * a * sp * sp) * dpsi)
            }
            Brdf::Charlie => (psi, dpsi),
        };
        let (st, ct) = theta.sin_cos();
        let d = match brdf {
            Brdf::Ggx => {
                let k = ct * ct * (a * a - 1.0) + 1.0;
                a * a / (PI * k * k)
            }
            Brdf::Charlie => (2.0 + 1.0 / a) * st.powf(1.0 / a) / (2.0 * PI),
        };
        for j in 0..np {
            let phi = (j as f64 + 0.5) * dp;
            let h = [st * phi.cos(), st * phi.sin(), ct];
            let vh = v[0] * h[0] + v[2] * h[2];
            let nl = 2.0 * vh * h[2] - v[2];
            if vh <= 0.0 || nl <= 0.0 {
                continue;
            }
            let vis = match brdf {
                Brdf::Ggx => {
                    let a2 = a * a;
                    let gv = nl * (nv * nv * (1.0 - a2) + a2).sqrt();
                    let gl = nv * (nl * nl * (1.0 - a2) + a2).sqrt();
                    0.5 / (gv + gl)
                }
                Brdf::Charlie => 1.0 / (4.0 * (nl + nv - nl * nv)),
            };
            // f n.l dl = D V n.l 4 (v.h) sin(theta) dtheta dphi, twice for phi in [pi, 2 pi].
            let w = d * vis * nl * 4.0 * vh * st * dtheta * dp * 2.0;
            match brdf {
                Brdf::Ggx => {
                    let fc = (1.0 - vh).powi(5);
                    s0 += (1.0 - fc) * w;
                    s1 += fc * w;
                }
                Brdf::Charlie => {
                    s0 += w;
                    s1 += w;
                }
            }
        }
    }
    (s0, s1)
}

/// Texel centres of a 128 table: the grazing columns, the smoothest rows and the roughest.
fn grid() -> Vec<(usize, usize)> {
    let at = [0, 1, 5, 20, 50, 90, 127];
    at.iter()
        .flat_map(|&y| at.iter().map(move |&x| (x, y)))
        .collect()
}

/// Quadrature steps in theta (half as many in phi): 5000 changes no result by more than
/// 2e-4 of it.
const STEPS: usize = 1500;

/// The default tables (128, 4096 samples) against the quadrature at 49 texel centres, the
/// grazing columns and the smoothest and roughest rows among them. Measured: DFG (both
/// layouts) max error 3.2e-4; Charlie 6.7e-4 of its value (it exceeds 1 at grazing n.v: 21.8
/// in the corner). Bounds: 1e-3 and 2e-3, under half a step of an 8-bit PNG.
#[test]
fn tables_match_a_brute_force_quadrature() {
    let size = 128;
    let opts = LutOptions::default();
    let dfg = lut::dfg(size, &opts);
    let ms = lut::dfg(
        size,
        &LutOptions {
            multiscatter: true,
            ..opts
        },
    );
    let sheen = lut::charlie(size, &opts);
    let (mut worst_dfg, mut worst_sheen) = ((0.0f64, String::new()), (0.0f64, String::new()));
    for (x, y) in grid() {
        let (nv, r) = lut::texel_coords(size, x, y);
        let (scale, bias) = quadrature(Brdf::Ggx, nv, r, STEPS);
        let p = dfg.get(x, y);
        let q = ms.get(x, y);
        for (got, want) in [(p.x, scale), (p.y, bias), (q.x, bias), (q.y, scale + bias)] {
            let e = (got as f64 - want).abs();
            if e > worst_dfg.0 {
                worst_dfg = (e, format!("n.v {nv:.4} roughness {r:.4}: {got} vs {want}"));
            }
        }
        let (e_sheen, _) = quadrature(Brdf::Charlie, nv, r, STEPS);
        let s = sheen.get(x, y);
        assert!(s.x == s.y && s.y == s.z && s.w == 1.0);
        let e = (s.x as f64 - e_sheen).abs() / e_sheen.max(1.0);
        if e > worst_sheen.0 {
            worst_sheen = (
                e,
                format!("n.v {nv:.4} roughness {r:.4}: {} vs {e_sheen}", s.x),
            );
        }
    }
    println!("DFG max error {:.2e} at {}", worst_dfg.0, worst_dfg.1);
    println!(
        "Charlie max error {:.2e} at {}",
        worst_sheen.0, worst_sheen.1
    );
    assert!(worst_dfg.0 < 1e-3, "DFG: {worst_dfg:?}");
    assert!(worst_sheen.0 < 2e-3, "Charlie: {worst_sheen:?}");
}

/// The quadrature itself, at a limit known in closed form: a nearly smooth surface reflects
/// F(n.v) whole (G -> 1), so scale + bias -> 1 and bias -> (1 - n.v)^5.
#[test]
fn quadrature_knows_the_limits() {
    let (s, b) = quadrature(Brdf::Ggx, 0.5, 0.05, STEPS);
    assert!((s + b - 1.0).abs() < 2e-3, "{}", s + b);
    assert!((b - 0.5f64.powi(5)).abs() < 1e-3, "{b}");
}

/// `cubeforge lut` writes what the library computes, the right way up, in every format:
/// read back by our readers (PNG within its quantisation, EXR and KTX2 within half-float
/// rounding), by Pillow (8-bit PNG: the bias-bright texel at the top left, as lut_ggx.png),
/// by oiiotool (16-bit PNG, half EXR) and by ktx-parse (RGBA16F, one 2D level).
#[test]
fn the_command_writes_each_format() {
    use cubeforge::internals::io::{Decoded, ReadOptions};
    let dir = tempfile::tempdir().unwrap();
    let size = 32;
    let opts = LutOptions {
        samples: 256,
        ..LutOptions::default()
    };
    let data = ReadOptions {
        linear: true,
        ..ReadOptions::default()
    };
    for (table, flags) in [
        (lut::dfg(size, &opts), vec![]),
        (
            lut::dfg(
                size,
                &LutOptions {
                    multiscatter: true,
                    ..opts
                },
            ),
            vec!["--multiscatter"],
        ),
        (lut::charlie(size, &opts), vec!["--charlie"]),
    ] {
        let name = flags.first().map_or("dfg", |f| f.trim_start_matches('-'));
        for (file, extra, tolerance) in [
            ("8.png", None, 0.5 / 255.0 + 1e-6),
            ("16.png", Some("--png16"), 0.5 / 65535.0 + 1e-6),
            (".exr", None, 1e-3),
            (".ktx2", None, 1e-3),
        ] {
            let out = dir.path().join(format!("{name}{file}"));
            let mut args = vec!["lut", "-o", out.to_str().unwrap(), "--size", "32"];
            args.extend(["--samples", "256"]);
            args.extend(flags.iter().copied().chain(extra));
            let o = common::run(&args);
            assert!(o.status.success(), "{}", common::stderr(&o));
            let Decoded::Image(back) = cubeforge::internals::convert::read(&out, &data).unwrap().0
            else {
                panic!("{}: not an image", out.display())
            };
            assert_eq!((back.width, back.height), (size, size));
            let png = file.ends_with("png");
            for (p, q) in back.pixels.iter().zip(&table.pixels) {
                for c in 0..3 {
                    // PNG holds 0 to 1 (Charlie exceeds 1 at grazing n.v: clamped, with a
                    // warning); half floats keep 11 significant bits.
                    let want = if png { q[c].min(1.0) } else { q[c] };
                    let tol = if png {
                        tolerance
                    } else {
                        tolerance * want.max(1.0)
                    };
                    assert!(
                        (p[c] - want).abs() <= tol,
                        "{}: {} vs {want}",
                        out.display(),
                        p[c]
                    );
                }
            }
        }
    }
    // The top-left texel (n.v 0, roughness 0) is all bias: green, as lut_ggx.png.
    if common::pillow() {
        let png = dir.path().join("dfg8.png");
        let code = format!(
            "from PIL import Image; im = Image.open({:?}).convert('RGB'); \
             print(im.size, im.getpixel((0, 0)), im.getpixel((31, 0)))",
            png.to_str().unwrap()
        );
        let o = std::process::Command::new("python3")
            .args(["-c", &code])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let nums: Vec<u32> = text
            .split(|c: char| !c.is_ascii_digit())
            .filter_map(|s| s.parse().ok())
            .collect();
        assert_eq!(&nums[..2], &[32, 32], "{text}");
        let (top_left, top_right) = (&nums[2..5], &nums[5..8]);
        assert!(top_left[1] > 200 && top_left[0] < 40, "{text}");
        assert!(top_right[0] > 250 && top_right[1] < 5, "{text}");
    }
    if common::oiiotool() {
        for (file, want) in [("dfg16.png", "uint16"), ("dfg.exr", "half")] {
            let o = std::process::Command::new("oiiotool")
                .args(["--info", "-v"])
                .arg(dir.path().join(file))
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(
                text.contains("32 x") && text.contains(want),
                "{file}: {text}"
            );
        }
    }
    if let Some(tools) = common::ktx_parse() {
        let v = common::ktx_check(&tools, &dir.path().join("dfg.ktx2"), "dfg.ktx2");
        assert_eq!(v["vkFormat"], 97, "RGBA16F: {v}");
        assert_eq!(
            (v["faceCount"].clone(), v["levelCount"].clone()),
            (1.into(), 1.into()),
            "{v}"
        );
        assert_eq!(v["dfd"]["transferFunction"], 1, "linear: {v}");
    }
}

/// A name the command cannot write, and --png16 on a float format, are one-line errors.
#[test]
fn the_command_refuses_what_it_cannot_write() {
    let dir = tempfile::tempdir().unwrap();
    let jpg = dir.path().join("dfg.jpg");
    let o = common::run(["lut", "-o", jpg.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(common::stderr(&o).contains(".png, .exr or .ktx2"));
    let exr = dir.path().join("dfg.exr");
    let o = common::run(["lut", "-o", exr.to_str().unwrap(), "--png16"]);
    assert!(!o.status.success() && common::stderr(&o).contains("--png16"));
    let o = common::run(["lut", "-o", "x.png", "--charlie", "--multiscatter"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!jpg.exists() && !exr.exists());
}
