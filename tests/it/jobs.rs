//! Commands as library jobs (issue 27): a job run from the library does what the command
//! does, tells its stages and warnings to a `Progress`, refuses a plan over the memory budget
//! before reading pixels, and writes only through `output::deliver`. Two guards keep the
//! structure: the command line's `run` functions stay short (flags -> job -> report), and no
//! module but `output` and `io::atomic` writes files.

use cubeforge::{
    ConvertJob, Destination, Error, GpuFormat, Job, LimitKind, LutJob, PrefilterJob, Progress,
    Warning,
};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Records what a job tells its observer.
#[derive(Default)]
struct Record {
    stages: Mutex<Vec<String>>,
    warnings: Mutex<Vec<String>>,
    units: Mutex<(u64, u64)>,
    begun: Mutex<Vec<String>>,
}

impl Progress for Record {
    fn begin(&self, what: &str) {
        self.begun.lock().unwrap().push(what.to_owned());
    }
    fn stage(&self, name: &str) {
        self.stages.lock().unwrap().push(name.to_owned());
    }
    fn start(&self, total: u64, _label: &str) {
        self.units.lock().unwrap().0 += total;
    }
    fn advance(&self, units: u64) {
        self.units.lock().unwrap().1 += units;
    }
    fn warning(&self, w: &Warning) {
        self.warnings.lock().unwrap().push(w.to_string());
    }
}

fn sky() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/sky.exr")
}

#[test]
fn a_conversion_reports_its_stages_files_and_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cross.png");
    let job = ConvertJob {
        size: Some(16),
        encoding: cubeforge::Encoding {
            gpu_format: Some(GpuFormat::Bc7),
            ..Default::default()
        },
        ..ConvertJob::new(vec![sky()], Destination::Path(out.clone()))
    };
    let record = Record::default();
    let report = job.run(&record).unwrap();
    assert_eq!(report.written, std::slice::from_ref(&out));
    assert!(out.is_file());
    assert_eq!(
        *record.stages.lock().unwrap(),
        ["decode", "resample", "encode", "write"]
    );
    // Warnings are data, named by the library's field names, and heard as they come.
    assert_eq!(report.warnings.len(), 2, "{:?}", report.warnings);
    assert!(report.warnings[0]
        .to_string()
        .contains("`gpu_format` applies to KTX2 and DDS"));
    // The sun of sky.exr clips in an 8-bit cross.
    assert!(report.warnings[1]
        .to_string()
        .contains("clip to white in an 8-bit file"));
    assert_eq!(record.warnings.lock().unwrap().len(), 2);
}

#[test]
fn a_chain_counts_its_progress_and_lists_its_levels() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ggx.ktx2");
    let mut job = PrefilterJob::new(vec![sky()], Destination::Path(out.clone()));
    job.size = Some(16);
    job.chain.samples = 4;
    job.chain.min_size = Some(1);
    let record = Record::default();
    let report = job.run(&record).unwrap();
    let (total, done) = *record.units.lock().unwrap();
    assert!(total > 0 && total == done, "{total} units, {done} done");
    assert_eq!(report.summary.len(), 6, "{:?}", report.summary);
    assert!(report.summary[0].to_string().starts_with("wrote "));
    assert!(report.summary[1].to_string().starts_with("level  0"));
}

#[test]
fn validate_refuses_before_any_file_is_read() {
    // The input does not exist: validate never looks at it.
    let job = ConvertJob {
        encoding: cubeforge::Encoding {
            zstd: Some(3),
            ..Default::default()
        },
        ..ConvertJob::new(
            vec!["no/such/input.exr".into()],
            Destination::Path("out.dds".into()),
        )
    };
    let e = job.validate().unwrap_err();
    assert!(e.to_string().contains("`zstd`"), "{e}");
    let lut = LutJob {
        encoding: cubeforge::Encoding {
            png16: true,
            ..Default::default()
        },
        ..LutJob::new("table.exr".into())
    };
    assert!(lut.validate().unwrap_err().to_string().contains("`png16`"));
}

#[test]
fn a_plan_over_the_budget_is_refused_with_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.ktx2");
    let mut job = ConvertJob::new(vec![sky()], Destination::Path(out.clone()));
    job.size = Some(2048);
    job.read.limits.max_memory = 64 << 20;
    let estimate = job.memory_estimate().unwrap();
    assert!(estimate > 64 << 20, "{estimate}");
    match job.run(&()) {
        Err(Error::Limit {
            kind: LimitKind::Memory,
            ..
        }) => {}
        other => panic!("expected a memory limit, got {other:?}"),
    }
    assert!(!out.exists());
}

#[test]
fn a_job_never_writes_over_its_input() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("sky.exr");
    std::fs::copy(sky(), &input).unwrap();
    let before = std::fs::read(&input).unwrap();
    let job = ConvertJob {
        size: Some(8),
        to: Some(cubeforge::Layout::Equirect.into()),
        ..ConvertJob::new(vec![input.clone()], Destination::Path(input.clone()))
    };
    let e = job.run(&()).unwrap_err();
    assert!(
        e.to_string().contains("refusing to overwrite an input"),
        "{e}"
    );
    assert_eq!(std::fs::read(&input).unwrap(), before);
}

/// Every `pub fn run` of the command line: flags -> job -> report, nothing else.
#[test]
fn command_line_runs_are_short() {
    let mut files = Vec::new();
    crate::layers::walk(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("src/cli"),
        &mut files,
    );
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let Some(start) = text.find("\npub fn run(") else {
            continue;
        };
        let body = &text[start + 1..];
        let end = body.find("\n}\n").unwrap_or(body.len());
        let lines = body[..end].lines().count();
        assert!(
            lines <= 60,
            "{}: run is {lines} lines; move the work into its job",
            path.display()
        );
    }
}

/// Files are written in one place: `output` (the write path) over `io::atomic` (staging).
#[test]
fn only_the_output_module_writes_files() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    crate::layers::walk(&src, &mut files);
    // Opening for reading (`OpenOptions` with `read` and flags alone) is no write.
    let writes = [
        "fs::write(",
        "File::create(",
        ".write(true)",
        ".append(true)",
        ".create(true)",
        ".create_new(true)",
        ".truncate(true)",
        "stage_with(",
    ];
    for f in files {
        let rel = crate::layers::rel_path(&src, &f);
        if rel.starts_with("io/atomic/") || rel.starts_with("output/") {
            continue;
        }
        // `library_text` cuts a file's `#[cfg(test)]` part; a test module's own file is cut
        // whole.
        if crate::layers::is_test_file(&rel) {
            continue;
        }
        let text = crate::layers::library_text(&f);
        let text = text.as_str();
        for w in writes {
            let used = text
                .lines()
                .filter(|l| {
                    !l.trim_start().starts_with("//") && !l.trim_start().starts_with("pub use")
                })
                .any(|l| l.contains(w));
            assert!(!used, "src/{rel} calls {w}: write through output::deliver");
        }
    }
}

/// `ibl` says in one line what it will make before the long part, then counts the chain and
/// the irradiance integral texel by texel.
#[test]
fn ibl_says_what_it_makes_and_counts_its_progress() {
    let dir = tempfile::tempdir().unwrap();
    let job = cubeforge::IblJob {
        options: cubeforge::IblOptions {
            specular_size: Some(16),
            samples: Some(4),
            ..Default::default()
        },
        ..cubeforge::IblJob::new(
            vec![sky()],
            dir.path().join("bevy"),
            cubeforge::Engine::Bevy,
        )
    };
    let record = Record::default();
    job.run(&record).unwrap();
    let begun = record.begun.lock().unwrap().clone();
    assert_eq!(begun.len(), 1, "{begun:?}");
    assert!(
        begun[0].starts_with("ibl bevy: a GGX chain of 16 px faces down to 8 px"),
        "{begun:?}"
    );
    let (total, done) = *record.units.lock().unwrap();
    assert!(total > 0 && total == done, "{total} units, {done} done");
}

/// three.js's KTX2 panorama (its mips, their upside-down copy, the encoding) counts in the
/// ibl job's memory estimate, so the budget still bounds it: at least 48 bytes a texel more of
/// the 4 x 2 panorama of 256 px faces.
#[test]
fn ibl_three_counts_its_ktx2_panorama_in_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let job = |gpu_format| cubeforge::IblJob {
        options: cubeforge::IblOptions {
            encoding: cubeforge::Encoding {
                gpu_format,
                ..Default::default()
            },
            ..Default::default()
        },
        ..cubeforge::IblJob::new(
            vec![sky()],
            dir.path().join("three"),
            cubeforge::Engine::Three,
        )
    };
    let plain = job(None).memory_estimate().unwrap();
    let ktx2 = job(Some(GpuFormat::UastcHdr4x4)).memory_estimate().unwrap();
    assert!(ktx2 >= plain + 8 * 256 * 256 * 48, "{plain} -> {ktx2}");
}
