//! The viewer's page against hostile names (issue 44, item 3): an input path that closes the
//! inline script, and query values that are Object.prototype's names.

use super::SKY_EXR;
use crate::cli_options::run_ok;
use crate::view::{browser, shoot, Shot};
use std::path::Path;

/// A folder name that ends a script element and starts an image whose error handler runs.
const HOSTILE: &str = "x</SCRIPT><img src=x onerror=alert(1)>";

/// `view --single-file` of `d/x</SCRIPT><img src=x onerror=alert(1)>/sky.exr` (the folder
/// `x<` holding the folder `SCRIPT><img ...>`): the path is in the page's scene (what `info`
/// says of the input) as data only: each of the four inline scripts ends at its own end, no
/// `<img` or `<!--` anywhere, and the scene reads back as JSON holding the path. In Chromium,
/// where present, the page draws.
#[test]
fn a_hostile_input_path_stays_data_in_a_single_page() {
    let t = tempfile::tempdir().unwrap();
    let folder = t.path().join("d").join(HOSTILE);
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::copy(SKY_EXR, folder.join("sky.exr")).unwrap();
    let input = format!("d/{HOSTILE}/sky.exr");
    run_ok(
        &["view", &input, "-o", "page.html", "--single-file", "-q"],
        t.path(),
    );
    let page = std::fs::read_to_string(t.path().join("page.html")).unwrap();
    let lower = page.to_ascii_lowercase();
    assert!(!lower.contains("<img"), "markup from the path in the page");
    assert!(!page.contains("<!--"), "a comment opener in the page");
    assert_eq!(lower.matches("<script>").count(), 4, "four inline scripts");
    assert_eq!(
        lower.matches("</script").count(),
        4,
        "a `</script` in any case beside the four scripts' own ends"
    );
    // Each script runs from its `<script>` to the first `</script` after it: the scene is
    // whole there, and every script ends where the next element begins.
    let mut at = 0;
    let mut bodies = Vec::new();
    for _ in 0..4 {
        let open = at + lower[at..].find("<script>").unwrap() + "<script>".len();
        let end = open + lower[open..].find("</script").unwrap();
        assert_eq!(&page[end..end + 10], "</script>\n", "a script's end");
        bodies.push(&page[open..end]);
        at = end;
    }
    let scene = bodies[0]
        .trim()
        .strip_prefix("window.cubeforgeScene = ")
        .and_then(|s| s.strip_suffix(';'))
        .expect("the first script is the scene");
    let scene: serde_json::Value = serde_json::from_str(scene).expect("the scene is JSON");
    let file = scene["info"]["file"]
        .as_str()
        .expect("info names the input");
    assert!(file.contains(HOSTILE), "{file}");
    assert!(!page.contains(HOSTILE));
    if browser() {
        let shots = shoot(
            &t.path().join("page.html"),
            &t.path().join("shots"),
            &["size=32&samples=1".to_owned()],
        );
        shots[0].png("the page of a hostile path");
    }
}

/// The query's material `__proto__`, `constructor`, `toString` or `hasOwnProperty` (names
/// every object answers to), and other values no option takes: each the page's one-line
/// message naming the key, never a shader's log nor a frame drawn on a default.
#[test]
fn query_values_that_are_no_option_get_one_line() {
    if !browser() {
        return;
    }
    let t = tempfile::tempdir().unwrap();
    run_ok(&["view", SKY_EXR, "-o", "site", "-q"], t.path());
    let cases = [
        ("material=__proto__", "unknown material \"__proto__\""),
        ("material=constructor", "unknown material \"constructor\""),
        ("material=toString", "unknown material \"toString\""),
        (
            "material=hasOwnProperty",
            "unknown material \"hasOwnProperty\"",
        ),
        ("material=a%0Ab", "unknown material \"a\\nb\""),
        ("tonemap=__proto__", "unknown tonemap \"__proto__\""),
        ("layout=constructor", "unknown layout"),
        ("fov=1e999", "fov must be"),
        ("fov=0", "fov must be"),
        ("distance=NaN", "distance must be"),
        ("exposure=Infinity", "exposure must be"),
        ("size=abc", "size must be"),
        ("roughness=2&material=gold", "roughness must be"),
        ("eta=0", "eta must be"),
        ("env_center=1,2", "env_center must be"),
    ];
    let queries: Vec<String> = cases.iter().map(|(q, _)| format!("{q}&size=32")).collect();
    let shots = shoot(
        &t.path().join("site/index.html"),
        &t.path().join("shots"),
        &queries,
    );
    for ((query, says), shot) in cases.iter().zip(&shots) {
        let Shot::Error { shown, .. } = shot else {
            panic!("{query}: the page drew a frame instead of refusing");
        };
        assert!(
            shown.starts_with("cubeforge view: ") && !shown.contains('\n'),
            "{query}: {shown:?}"
        );
        assert!(shown.contains(says), "{query}: {shown:?}");
        assert!(
            !shown.contains("ERROR:"),
            "{query}: a shader's log: {shown:?}"
        );
    }
    assert!(Path::new(&t.path().join("site/index.html")).is_file());
}
