//! Issue 44, items 6 and 7 in `cubeforge batch`: a FIFO as the state file or in a record's
//! reads never blocks a batch (`--dry-run` included); jobs that would write each other's
//! inputs, one file under several spellings, a folder and a file inside it, standard output
//! or each other's depfiles are refused before anything runs, with one line and nothing
//! written; and a record edited by hand keeps no job up to date.

use super::{is_fifo, mkfifo, run_within, snapshot, SKY_EXR};
use crate::fault_campaign::{ok, refused};
use std::path::Path;

/// `d/a.exr` and `d/b.exr`, copies of the bundled sky.
fn skies(d: &Path) {
    for n in ["a.exr", "b.exr"] {
        std::fs::copy(SKY_EXR, d.join(n)).unwrap();
    }
}

/// A `[[job]]` table: `convert INPUT -o OUTPUT --size 8` and `extra` args.
fn job(input: &str, output: &str, extra: &[&str]) -> String {
    let mut args = vec!["\"--size\"".to_string(), "\"8\"".to_string()];
    args.extend(extra.iter().map(|a| format!("{a:?}")));
    format!(
        "[[job]]\ninputs = [{input:?}]\ncommand = \"convert\"\nargs = [{}]\noutput = {output:?}\n\n",
        args.join(", ")
    )
}

/// A batch of `jobs` that must be refused before anything runs: exit 1, one line holding
/// each of `what`, and the folder as it was (no output, no state file).
fn refused_batch(d: &Path, jobs: &[String], flags: &[&str], what: &[&str]) {
    std::fs::write(d.join("m.toml"), jobs.concat()).unwrap();
    let before = snapshot(d);
    for dry in [false, true] {
        let mut args = vec!["batch", "m.toml"];
        args.extend_from_slice(flags);
        if dry {
            args.push("--dry-run");
        }
        let o = run_within(d, &args);
        refused(&o, what);
        assert!(
            o.stdout.is_empty(),
            "{}",
            String::from_utf8_lossy(&o.stdout)
        );
        assert_eq!(snapshot(d), before, "{args:?} wrote something");
    }
}

#[test]
fn a_fifo_as_the_state_file_is_refused_without_waiting() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d);
    std::fs::write(d.join("m.toml"), job("a.exr", "out/a.ktx2", &[])).unwrap();
    mkfifo(&d.join("m.state.json"));
    for dry in [&[][..], &["--dry-run"]] {
        let mut args = vec!["batch", "m.toml"];
        args.extend_from_slice(dry);
        refused(
            &run_within(d, &args),
            &["m.state.json", "is a FIFO, not a regular file"],
        );
    }
    assert!(is_fifo(&d.join("m.state.json")));
    assert!(!d.join("out").exists(), "no job ran");
}

#[test]
fn a_record_that_read_a_fifo_reruns_its_job_without_waiting() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d);
    std::fs::write(d.join("m.toml"), job("a.exr", "out/a.ktx2", &[])).unwrap();
    ok(&run_within(d, &["batch", "m.toml"]));
    // The record now says the job also read a FIFO (a file since replaced by one, or an
    // edited record): hashing it must not wait for a writer.
    mkfifo(&d.join("pipe"));
    let state = d.join("m.state.json");
    let mut s: serde_json::Value = serde_json::from_slice(&std::fs::read(&state).unwrap()).unwrap();
    let record = s["jobs"]
        .as_object_mut()
        .unwrap()
        .values_mut()
        .next()
        .unwrap();
    let pipe = d.join("pipe").display().to_string();
    record["reads"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!([pipe, "0".repeat(32)]));
    std::fs::write(&state, serde_json::to_vec_pretty(&s).unwrap()).unwrap();
    let dry = run_within(d, &["batch", "m.toml", "--dry-run"]);
    ok(&dry);
    let text = String::from_utf8_lossy(&dry.stdout).into_owned();
    assert!(text.contains("1 would run"), "{text}");
    assert!(text.contains("pipe changed"), "{text}");
    let o = run_within(d, &["batch", "m.toml"]);
    ok(&o);
    assert_eq!(crate::batch::ran(&o).len(), 1);
    assert!(is_fifo(&d.join("pipe")));
    // Its new record reads no FIFO: up to date.
    let again = run_within(d, &["batch", "m.toml"]);
    assert!(crate::batch::ran(&again).is_empty());
}

#[test]
fn a_job_never_writes_another_jobs_input() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d);
    // b.exr is the first job's output and the second's input, in either order.
    let (w, r) = (job("a.exr", "b.exr", &[]), job("b.exr", "c.exr", &[]));
    let what = ["writes b.exr", "reads b.exr", "another's input"];
    refused_batch(d, &[w.clone(), r.clone()], &[], &what);
    refused_batch(d, &[r, w], &[], &what);
    // A hard link of the input, or the folder that holds it.
    std::fs::hard_link(d.join("b.exr"), d.join("h.exr")).unwrap();
    refused_batch(
        d,
        &[job("a.exr", "h.exr", &[]), job("b.exr", "c.exr", &[])],
        &[],
        &["writes h.exr", "reads b.exr"],
    );
    std::fs::create_dir(d.join("in")).unwrap();
    std::fs::copy(SKY_EXR, d.join("in/x.exr")).unwrap();
    refused_batch(
        d,
        &[
            job("a.exr", "in", &["--to", "faces"]),
            job("in/x.exr", "c.exr", &[]),
        ],
        &[],
        &["writes in,", "reads in/x.exr"],
    );
    // The state file is no job's output, and no job's input.
    refused_batch(
        d,
        &[job("a.exr", "m.state.json", &[])],
        &[],
        &["state file m.state.json is written by"],
    );
}

#[test]
fn three_spellings_of_one_output_are_one_output() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d);
    std::fs::create_dir(d.join("out")).unwrap();
    std::os::unix::fs::symlink("out", d.join("link")).unwrap();
    for other in ["out/../out/x.ktx2", "link/x.ktx2", "./out/./x.ktx2"] {
        refused_batch(
            d,
            &[job("a.exr", "out/x.ktx2", &[]), job("b.exr", other, &[])],
            &[],
            &["two jobs write out/x.ktx2", other],
        );
    }
    // An existing output and its hard link.
    std::fs::write(d.join("out/x.ktx2"), b"old").unwrap();
    std::fs::hard_link(d.join("out/x.ktx2"), d.join("y.ktx2")).unwrap();
    refused_batch(
        d,
        &[job("a.exr", "out/x.ktx2", &[]), job("b.exr", "y.ktx2", &[])],
        &[],
        &["two jobs write out/x.ktx2"],
    );
}

#[test]
fn a_folder_output_and_a_file_inside_it_are_refused() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d);
    let folder = job("a.exr", "out/faces", &["--to", "faces"]);
    let inside = job("b.exr", "out/faces/../faces/x.exr", &[]);
    let what = ["writes the folder out/faces", "replaced whole", "inside it"];
    refused_batch(d, &[folder.clone(), inside.clone()], &[], &what);
    refused_batch(d, &[inside, folder], &[], &what);
}

#[test]
fn standard_output_is_no_batch_output() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d);
    refused_batch(
        d,
        &[job("a.exr", "-", &["--format", "exr"])],
        &[],
        &["cannot write to standard output"],
    );
}

#[test]
fn each_depfile_is_an_output_of_the_batch() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d);
    // A faces folder named `x.exr.d`, beside `x.exr`.
    let jobs = [
        job("a.exr", "x.exr", &[]),
        job("b.exr", "x.exr.d", &["--to", "faces"]),
    ];
    refused_batch(d, &jobs, &["--depfiles"], &["two jobs write x.exr.d"]);
    // Without depfiles, the two are apart.
    std::fs::write(d.join("m.toml"), jobs.concat()).unwrap();
    ok(&run_within(d, &["batch", "m.toml"]));
    // A depfile that would land on another job's input.
    std::fs::write(d.join("a.exr.d"), b"not read").unwrap();
    refused_batch(
        d,
        &[job("b.exr", "a.exr", &[]), job("a.exr.d", "z.exr", &[])],
        &["--depfiles"],
        &["writes a.exr.d", "reads a.exr.d"],
    );
}

#[test]
fn an_edited_record_keeps_no_job_up_to_date() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d);
    std::fs::write(d.join("m.toml"), job("a.exr", "faces", &["--to", "faces"])).unwrap();
    ok(&run_within(d, &["batch", "m.toml"]));
    // One face deleted, and dropped from the record's outputs by hand.
    std::fs::remove_file(d.join("faces/px.exr")).unwrap();
    let state = d.join("m.state.json");
    let mut s: serde_json::Value = serde_json::from_slice(&std::fs::read(&state).unwrap()).unwrap();
    let record = s["jobs"]
        .as_object_mut()
        .unwrap()
        .values_mut()
        .next()
        .unwrap();
    let outputs = record["outputs"].as_array_mut().unwrap();
    let n = outputs.len();
    outputs.retain(|p| !p.as_str().unwrap().ends_with("px.exr"));
    assert_eq!(outputs.len(), n - 1);
    std::fs::write(&state, serde_json::to_vec_pretty(&s).unwrap()).unwrap();
    let dry = run_within(d, &["batch", "m.toml", "--dry-run"]);
    ok(&dry);
    let text = String::from_utf8_lossy(&dry.stdout).into_owned();
    assert!(text.contains("1 would run"), "{text}");
    let o = run_within(d, &["batch", "m.toml"]);
    assert_eq!(crate::batch::ran(&o).len(), 1);
    assert!(d.join("faces/px.exr").is_file());
}
