//! The Kubernetes Indexed Job example checked where no cluster runs (issue 52, item 3): its
//! YAML read by PyYAML against what an Indexed Job of shards needs (`completionMode: Indexed`,
//! completions equal to the shard count, a restart policy a Job accepts, mounts that name a
//! declared volume), then each pod's command run as written, with `JOB_COMPLETION_INDEX`
//! and the container's environment: the pods together build what one batch builds.

use super::project;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

const EXAMPLE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/pipeline/k8s-indexed-job.yaml"
);

/// The example as JSON, or None (after a SKIPPED line; a failure under CI) without PyYAML.
fn example() -> Option<Value> {
    let o = Command::new("python3")
        .args([
            "-c",
            "import json, sys, yaml; print(json.dumps(yaml.safe_load(open(sys.argv[1]))))",
            EXAMPLE,
        ])
        .output();
    match o {
        Ok(o) if o.status.success() => Some(serde_json::from_slice(&o.stdout).unwrap()),
        _ => {
            assert!(
                std::env::var_os("CI").is_none(),
                "PyYAML is missing (pip install pyyaml)"
            );
            eprintln!("SKIPPED: python3 with PyYAML is not installed");
            None
        }
    }
}

#[test]
fn the_kubernetes_indexed_job_is_a_job_of_shards() {
    let Some(job) = example() else { return };
    assert_eq!(job["apiVersion"], "batch/v1");
    assert_eq!(job["kind"], "Job");
    let spec = &job["spec"];
    assert_eq!(spec["completionMode"], "Indexed");
    let completions = spec["completions"].as_u64().expect("completions");
    assert!(spec["parallelism"].as_u64().unwrap_or(1) <= completions);
    let pod = &spec["template"]["spec"];
    assert!(["Never", "OnFailure"].contains(&pod["restartPolicy"].as_str().unwrap()));
    let containers = pod["containers"].as_array().unwrap();
    assert_eq!(containers.len(), 1);
    let c = &containers[0];
    let env: Vec<(String, String)> = c["env"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| {
            let v = e["value"].as_str().expect("env values are strings");
            (e["name"].as_str().unwrap().to_string(), v.to_string())
        })
        .collect();
    let var = |k: &str| env.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
    assert_eq!(
        var("SHARDS"),
        Some(completions.to_string()),
        "SHARDS != completions"
    );
    let volumes: Vec<&str> = pod["volumes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["name"].as_str().unwrap())
        .collect();
    for m in c["volumeMounts"].as_array().unwrap() {
        assert!(volumes.contains(&m["name"].as_str().unwrap()), "{m}");
    }
    assert!(c["resources"]["limits"]["memory"].is_string());
    let command: Vec<&str> = c["command"]
        .as_array()
        .unwrap()
        .iter()
        .chain(c["args"].as_array().unwrap())
        .map(|a| a.as_str().unwrap())
        .collect();
    assert!(command.join(" ").contains("$JOB_COMPLETION_INDEX"));

    // Each pod's command as written, in a copy of the test project for the volume.
    let t = tempfile::tempdir().unwrap();
    project(&t.path().join("one"));
    project(&t.path().join("pods"));
    let cubeforge = Path::new(env!("CARGO_BIN_EXE_cubeforge"));
    let path = format!(
        "{}:{}",
        cubeforge.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let o = Command::new(cubeforge)
        .args(["batch", "m.toml"])
        .current_dir(t.path().join("one/proj"))
        .env_remove("CUBEFORGE_CACHE")
        .output()
        .unwrap();
    assert!(o.status.success());
    let mut ran = 0;
    for index in 0..completions {
        let o = Command::new(command[0])
            .args(&command[1..])
            .current_dir(t.path().join("pods/proj"))
            .envs(env.iter().cloned())
            .env("MANIFEST", "m.toml")
            .env("JOB_COMPLETION_INDEX", index.to_string())
            .env("PATH", &path)
            .output()
            .unwrap();
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{out}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        ran += out.lines().filter(|l| l.starts_with("ran ")).count();
    }
    assert_eq!(ran, 7);
    assert!(
        super::contents(&t.path().join("one/proj/build"))
            == super::contents(&t.path().join("pods/proj/build"))
    );
}
