//! The page itself: its one-line message for missing or broken data (never a blank success),
//! a 512-face chain's load time, and `--single-file` drawing what the folder draws.

use super::against_cpu::{gauss, SINGLE_FILE_QUERY, UNKNOWN_MATERIAL};
use super::{browser, cubeforge, done, shoot, work, Shot, SKY_EXR};
use std::path::Path;

/// The page's message for a shot that must fail: one line, from cubeforge view.
fn message(shot: &Shot, what: &str) -> String {
    match shot {
        Shot::Ready { png, .. } => panic!(
            "{what}: the page drew a frame ({}) instead of saying what is wrong",
            png.display()
        ),
        Shot::Error { error, shown } => {
            assert!(!error.is_empty(), "{what}: window.cubeforgeError is empty");
            assert!(
                shown.starts_with("cubeforge view: ") && !shown.contains('\n'),
                "{what}: the page shows {shown:?}"
            );
            shown.clone()
        }
    }
}

/// data.js missing, cut in half, or whole but with a level's data cut short: the page says so
/// in #status (the first two name data.js as missing or broken) and never draws.
#[test]
fn missing_or_broken_data_shows_a_message() {
    if !browser() {
        return;
    }
    let dir = work("broken");
    cubeforge(&["view", SKY_EXR, "-o", "good", "-q"], &dir);
    let data = std::fs::read_to_string(dir.join("good/data.js")).unwrap();
    let copy = |name: &str, data: Option<&str>| {
        let to = dir.join(name);
        std::fs::create_dir_all(&to).unwrap();
        for e in std::fs::read_dir(dir.join("good")).unwrap() {
            let e = e.unwrap();
            if e.file_name() != "data.js" {
                std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
            }
        }
        if let Some(d) = data {
            std::fs::write(to.join("data.js"), d).unwrap();
        }
        to.join("index.html")
    };
    // A base64 string of the environment's levels, a quarter of it dropped: still a script.
    let env = data.find("\"env\":").expect("data.js holds the env chain");
    let start = env + data[env..].find("\"data\":\"").unwrap() + 8;
    let end = start + data[start..].find('"').unwrap();
    let cut = start + (end - start) / 4 * 3;
    let short = format!("{}{}", &data[..cut], &data[end..]);
    let pages = [
        ("missing", copy("missing", None)),
        (
            "truncated",
            copy("truncated", Some(&data[..data.len() / 2])),
        ),
        ("short level data", copy("short", Some(&short))),
    ];
    let query = ["material=chrome&size=96".to_owned()];
    for (what, page) in &pages {
        let shot = &shoot(page, &dir.join(format!("shots_{what}")), &query)[0];
        let shown = message(shot, what);
        eprintln!("view, {what} data.js: the page shows {shown:?}");
        if *what != "short level data" {
            assert!(
                shown.contains("data.js") && shown.contains("missing or broken"),
                "{what}: {shown:?}"
            );
        }
    }
    done(&dir);
}

/// An unknown material in the query: the page names it and the choices.
#[test]
fn an_unknown_material_is_named_on_the_page() {
    if !browser() {
        return;
    }
    let shown = message(gauss().shot(UNKNOWN_MATERIAL), UNKNOWN_MATERIAL);
    assert!(
        shown.contains("\"nonesuch\"") && shown.contains("chrome"),
        "{shown:?}"
    );
}

/// A 512-face Gaussian chain (10 levels, a 34 MB data.js) becomes ready. The target
/// is under 2 s in headless Chromium on 2 cores (1.8 s by hand; 3.0-4.2 s here on 2 cores
/// busy with builds); a timed assertion on a shared machine is flaky, so the bound here is
/// generous (10 s) and the time is printed (`--nocapture`).
#[test]
fn a_512_face_chain_loads() {
    if !browser() {
        return;
    }
    let dir = work("big");
    cubeforge(
        &[
            "prefilter",
            SKY_EXR,
            "-o",
            "big.ktx2",
            "--filter",
            "gaussian",
            "--size",
            "512",
            "--min-size",
            "1",
            "-q",
        ],
        &dir,
    );
    cubeforge(&["view", "big.ktx2", "-o", "page", "-q"], &dir);
    let bytes = std::fs::metadata(dir.join("page/data.js")).unwrap().len();
    let shots = shoot(
        &dir.join("page/index.html"),
        &dir.join("gpu"),
        &["material=glass&size=256&lod_bias=2".to_owned()],
    );
    let Shot::Ready { ms, png } = &shots[0] else {
        panic!("the 512-face chain's page failed: {:?}", shots[0]);
    };
    let dims = super::rgb(png).dimensions();
    assert_eq!(dims, (256, 256));
    eprintln!(
        "view: a 512-face chain ({:.1} MB data.js) ready in {ms} ms (target: under 2000 ms on 2 cores)",
        bytes as f64 / 1e6
    );
    assert!(*ms < 10_000, "a 512-face chain took {ms} ms to draw");
    done(&dir);
}

/// `--single-file -o NAME.html`: that file and nothing else, which draws the same picture as
/// the folder of the same chain, to the bit.
#[test]
fn a_single_file_page_draws_what_the_folder_draws() {
    if !browser() {
        return;
    }
    let g = gauss();
    let dir = work("single");
    let chain = g.dir.join("chain.ktx2");
    cubeforge(
        &[
            "view",
            chain.to_str().unwrap(),
            "-o",
            "out/sky.html",
            "--single-file",
            "-q",
        ],
        &dir,
    );
    let written: Vec<String> = std::fs::read_dir(dir.join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(written, ["sky.html"], "--single-file wrote {written:?}");
    let html = std::fs::read_to_string(dir.join("out/sky.html")).unwrap();
    assert!(
        !html.contains("src=\"data.js\"") && !html.contains("src=\"viewer.js\""),
        "the single page still loads files beside it"
    );
    let shots = shoot(
        &dir.join("out/sky.html"),
        &dir.join("gpu"),
        &[SINGLE_FILE_QUERY.to_owned()],
    );
    let single = shots[0].png("the single-file page");
    let folder = g.shot(SINGLE_FILE_QUERY).png("the folder page");
    assert_eq!(
        super::rgb(single),
        super::rgb(folder),
        "the single-file page ({}) and the folder ({}) draw different pictures",
        single.display(),
        folder.display()
    );
    assert!(Path::new(single).is_file());
    done(&dir);
}
