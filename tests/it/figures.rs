//! Figures the docs quote, checked by the tests that measure them (issue 45: hand-copied
//! numbers had moved). Each sits in a doc between `<!-- figures: KEY -->` and
//! `<!-- /figures -->`; the test that measures it builds the block's text and calls [`check`]:
//! words must match exactly, numbers within two units of their last printed digit (the last
//! bits of libm's functions may differ between machines). With `CUBEFORGE_BLESS=1` the
//! measured text is written into the doc instead, so a figure that moves is regenerated, never
//! retyped.

use std::path::PathBuf;
use std::sync::Mutex;

/// Tests bless in parallel; one doc is rewritten at a time.
static DOCS: Mutex<()> = Mutex::new(());

/// Checks (or blesses) the block `key` of `doc` (a path from the repository's root) against
/// `measured`.
pub fn check(doc: &str, key: &str, measured: &str) {
    let _guard = DOCS.lock().unwrap_or_else(|e| e.into_inner());
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(doc);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{doc}: {e}"));
    let open = format!("<!-- figures: {key} -->");
    let close = "<!-- /figures -->";
    let start = text
        .find(&open)
        .unwrap_or_else(|| panic!("{doc} has no `{open}`"))
        + open.len();
    let end = start
        + text[start..]
            .find(close)
            .unwrap_or_else(|| panic!("{doc}: `{open}` is not closed"));
    let quoted = &text[start..end];
    // A block on lines of its own stays so; one inside a sentence stays inline.
    let measured = if quoted.starts_with('\n') || measured.contains('\n') {
        format!("\n{}\n", measured.trim())
    } else {
        measured.trim().to_string()
    };
    if std::env::var_os("CUBEFORGE_BLESS").is_some() {
        if quoted != measured {
            let out = format!("{}{measured}{}", &text[..start], &text[end..]);
            std::fs::write(&path, out).unwrap_or_else(|e| panic!("{doc}: {e}"));
        }
        return;
    }
    if let Some(why) = differ(quoted, &measured) {
        panic!(
            "{doc}'s figures `{key}` moved ({why}); rerun this test with CUBEFORGE_BLESS=1 to \
             write them.\nquoted:{quoted}measured:{measured}"
        );
    }
}

/// Why `quoted` and `measured` differ beyond the numbers' last digits, or None.
fn differ(quoted: &str, measured: &str) -> Option<String> {
    let (a, b) = (tokens(quoted), tokens(measured));
    if a.len() != b.len() {
        return Some(format!("{} tokens against {}", a.len(), b.len()));
    }
    for (x, y) in a.iter().zip(&b) {
        match (x, y) {
            (Token::Number(p, _), Token::Number(q, unit)) if (p - q).abs() > 2.0 * unit + 1e-12 => {
                return Some(format!("{p} is now {q}"));
            }
            (Token::Number(..), Token::Number(..)) => {}
            (x, y) if x != y => return Some(format!("{x:?} is now {y:?}")),
            _ => {}
        }
    }
    None
}

#[derive(Debug, PartialEq)]
enum Token {
    Word(String),
    /// A value and one unit of its last printed digit.
    Number(f64, f64),
}

/// Numbers (with their sign and decimals) and runs of everything else, spaces collapsed.
fn tokens(s: &str) -> Vec<Token> {
    let mut out = Vec::new();
    let mut word = String::new();
    let chars: Vec<char> = s.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let signed = (c == '-' || c == '+')
            && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit())
            && (i == 0 || !chars[i - 1].is_alphanumeric());
        if c.is_ascii_digit() || signed {
            let mut j = i + 1;
            while j < chars.len()
                && (chars[j].is_ascii_digit()
                    || (chars[j] == '.' && chars.get(j + 1).is_some_and(|d| d.is_ascii_digit())))
            {
                j += 1;
            }
            let digits: String = chars[i..j].iter().collect();
            let decimals = digits.split('.').nth(1).map_or(0, str::len);
            if !word.trim().is_empty() {
                out.push(Token::Word(collapse(&word)));
            }
            word.clear();
            let value = digits.parse::<f64>().expect("a number");
            out.push(Token::Number(value, 10f64.powi(-(decimals as i32))));
            i = j;
        } else {
            word.push(c);
            i += 1;
        }
    }
    if !word.trim().is_empty() {
        out.push(Token::Word(collapse(&word)));
    }
    out
}

fn collapse(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[test]
fn numbers_may_move_in_their_last_digit_only() {
    assert!(differ("a 0.145% b", "a 0.146% b").is_none());
    assert!(differ("a 0.145% b", "a 0.148% b").is_some());
    assert!(differ("ratio 0.9986 to 1.0004", "ratio 0.9987 to 1.0004").is_none());
    assert!(differ("esplanade 12", "park 12").is_some());
    assert!(differ("| -0.03% |", "| +0.03% |").is_some());
    assert!(differ("x\n| a |  b", "x | a | b").is_none());
}
