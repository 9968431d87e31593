//! The page's files: index.html filled in one pass, the scripts beside it or inline. User data
//! (the input's name and path, in the title and the scene) reaches the page in two places only,
//! each escaped for where it lands: the title as HTML text, the scene as JSON whose strings
//! cannot end a script element (`<`, `>`, `&`, U+2028 and U+2029 as `\u` escapes).

use std::path::{Path, PathBuf};

const INDEX: &str = include_str!("index.html");
const VIEWER: &str = include_str!("viewer.js");
const SHADERS: &str = include_str!("shaders.js");
const UI: &str = include_str!("ui.js");

/// The page's scripts in the order index.html loads them, by file name.
const SCRIPTS: [&str; 4] = ["data.js", "shaders.js", "ui.js", "viewer.js"];

/// The files [`files`] writes for `dir`, the page first: the folder's index.html and its four
/// scripts, or with `single_file` the one page `dir` names. `view --serve` serves these and
/// nothing else.
pub fn paths(dir: &Path, single_file: bool) -> Vec<PathBuf> {
    if single_file {
        return vec![dir.to_path_buf()];
    }
    std::iter::once("index.html")
        .chain(SCRIPTS)
        .map(|name| dir.join(name))
        .collect()
}

/// The page's files in `dir` (index.html, data.js, shaders.js, ui.js, viewer.js), or with
/// `single_file` the one page `dir` names, everything inline. `scene` is
/// [`super::scene_script`]'s.
pub fn files(dir: &Path, single_file: bool, title: &str, scene: String) -> Vec<(PathBuf, Vec<u8>)> {
    let title = html_escape(title);
    let paths = paths(dir, single_file);
    if single_file {
        let scripts = [&scene as &str, SHADERS, UI, VIEWER].map(inline_script);
        let tags = SCRIPTS.map(script_tag);
        let mut slots = vec![("{{title}}", title.as_str())];
        slots.extend(
            tags.iter()
                .zip(&scripts)
                .map(|(t, s)| (t.as_str(), s.as_str())),
        );
        return vec![(paths[0].clone(), fill(INDEX, &slots).into_bytes())];
    }
    let contents = [
        fill(INDEX, &[("{{title}}", &title)]).into_bytes(),
        scene.into_bytes(),
        SHADERS.as_bytes().to_vec(),
        UI.as_bytes().to_vec(),
        VIEWER.as_bytes().to_vec(),
    ];
    paths.into_iter().zip(contents).collect()
}

fn script_tag(name: &str) -> String {
    format!("<script src=\"{name}\"></script>")
}

/// `template` with each slot's key replaced by its value, in one pass from the left: a value
/// is never searched again, so user data that holds another key stays as it is.
fn fill(template: &str, slots: &[(&str, &str)]) -> String {
    let mut out =
        String::with_capacity(template.len() + slots.iter().map(|s| s.1.len()).sum::<usize>());
    let mut rest = template;
    while let Some((at, key, value)) = slots
        .iter()
        .filter_map(|(k, v)| rest.find(k).map(|at| (at, *k, *v)))
        .min_by_key(|(at, ..)| *at)
    {
        out.push_str(&rest[..at]);
        out.push_str(value);
        rest = &rest[at + key.len()..];
    }
    out.push_str(rest);
    out
}

/// Text for an HTML element or a quoted attribute.
pub(crate) fn html_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Serialized JSON with `<`, `>`, `&`, U+2028 and U+2029 written as `\u` escapes. Outside its
/// strings JSON holds none of them, so every one escaped is inside a string, where the escape
/// reads back as the same character: the text stays the same JSON and valid JavaScript, and
/// no string in it can end a script element or open an HTML comment in a page.
pub(crate) fn script_json(json: &str) -> String {
    let mut out = String::with_capacity(json.len());
    for c in json.chars() {
        match c {
            '<' => out.push_str("\\u003c"),
            '>' => out.push_str("\\u003e"),
            '&' => out.push_str("\\u0026"),
            '\u{2028}' => out.push_str("\\u2028"),
            '\u{2029}' => out.push_str("\\u2029"),
            c => out.push(c),
        }
    }
    out
}

/// A script inline in a page: `</script` and `<!--` in any case become `<\/script` and
/// `<\!--` (the same text inside a JavaScript string), so the script element ends where it was
/// meant to, whatever the script holds.
pub(crate) fn inline_script(js: &str) -> String {
    let mut out = String::with_capacity(js.len() + 32);
    out.push_str("<script>\n");
    let mut rest = js;
    while let Some(at) = rest.find('<') {
        out.push_str(&rest[..at]);
        let tail = &rest[at + 1..];
        let starts = |s: &str| {
            tail.get(..s.len())
                .is_some_and(|t| t.eq_ignore_ascii_case(s))
        };
        out.push('<');
        if starts("/script") || starts("!--") {
            out.push('\\');
        }
        rest = tail;
    }
    out.push_str(rest);
    out.push_str("\n</script>");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where the first `</script` in any case ends the script element opened at `open`.
    fn script_end(page: &str, open: usize) -> usize {
        open + page[open..].to_ascii_lowercase().find("</script").unwrap()
    }

    #[test]
    fn inline_scripts_cannot_be_ended_early() {
        for hostile in [
            "x</SCRIPT><img src=x onerror=alert(1)>",
            "x</ScRiPt >",
            "x</script>",
            "<!--<script>",
            "<!-- </sCrIpT",
        ] {
            let js = format!("var s = {};", serde_json::to_string(hostile).unwrap());
            let inline = inline_script(&js);
            let end = script_end(&inline, 0);
            assert_eq!(end, inline.len() - "</script>".len(), "{hostile}: {inline}");
            assert!(!inline.contains("<!--"), "{hostile}: {inline}");
        }
    }

    #[test]
    fn scene_json_escapes_what_a_page_reads_as_markup() {
        let hostile = "a</SCRIPT><img src=x onerror=alert(1)>&<!--\u{2028}\u{2029}</ScRiPt";
        let json = script_json(&serde_json::json!({ "file": hostile, "<key>": 1 }).to_string());
        for c in ['<', '>', '&', '\u{2028}', '\u{2029}'] {
            assert!(!json.contains(c), "{c:?} left in {json}");
        }
        assert!(
            json.contains("\\u003c/SCRIPT\\u003e") && json.contains("\\u2028"),
            "{json}"
        );
        // Still the same JSON.
        let back: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(back["file"], hostile);
        assert_eq!(back["<key>"], 1);
    }

    #[test]
    fn the_template_is_filled_in_one_pass() {
        let filled = fill(
            "<title>{{title}}</title><script src=\"data.js\"></script>",
            &[
                ("{{title}}", "<script src=\"data.js\"></script>{{title}}"),
                ("<script src=\"data.js\"></script>", "DATA"),
            ],
        );
        assert_eq!(
            filled,
            "<title><script src=\"data.js\"></script>{{title}}</title>DATA"
        );
        assert_eq!(html_escape("'\"<&>"), "&#39;&quot;&lt;&amp;&gt;");
    }

    /// A single page whose title and scene hold every hostile string: four script elements,
    /// each ending where it was meant to, and no markup outside them but the template's.
    #[test]
    fn a_single_page_holds_hostile_names_as_text() {
        let hostile = "</SCRIPT><img src=x onerror=alert(1)><!--{{title}}\u{2028}";
        let scene = format!(
            "window.cubeforgeScene = {};\n",
            script_json(&serde_json::json!({ "name": hostile }).to_string())
        );
        let (_, page) = files(Path::new("p.html"), true, hostile, scene)
            .pop()
            .unwrap();
        let page = String::from_utf8(page).unwrap();
        let lower = page.to_ascii_lowercase();
        assert!(!lower.contains("<img") && !page.contains("<!--"), "{page}");
        assert_eq!(lower.matches("<script>").count(), 4);
        assert_eq!(lower.matches("</script").count(), 4);
        let mut at = 0;
        for expect in ["window.cubeforgeScene = ", SHADERS, UI, VIEWER] {
            let open = at + lower[at..].find("<script>\n").unwrap() + "<script>\n".len();
            let end = script_end(&page, open);
            let body = &page[open..end];
            assert!(
                body.starts_with(&expect[..expect.len().min(40)]),
                "{body:.80}"
            );
            at = end;
        }
    }
}
