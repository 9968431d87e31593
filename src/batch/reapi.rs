//! The bytes of an `ac/` entry: Bazel's `build.bazel.remote.execution.v2.ActionResult`
//! (<https://github.com/bazelbuild/remote-apis/blob/main/build/bazel/remote/execution/v2/remote_execution.proto>),
//! so servers that check what they store (bazel-remote without
//! `--disable_http_ac_validation`, BuildBuddy) keep cubeforge's entries. The messages are
//! written by hand with the .proto's field numbers (no protoc, no build script); only the
//! fields cubeforge writes, or must see to refuse an entry, are declared, and prost skips
//! the rest (timestamps, stdout digests) as any reader of a newer message does.

use prost::Message;

/// `ActionResult`: the outputs of an action that ran.
#[derive(Clone, PartialEq, prost::Message)]
pub(crate) struct ActionResult {
    #[prost(message, repeated, tag = "2")]
    pub output_files: Vec<OutputFile>,
    /// `OutputDirectory` entries (trees): cubeforge writes none, and refuses an entry with any.
    #[prost(bytes = "vec", repeated, tag = "3")]
    pub output_directories: Vec<Vec<u8>>,
    #[prost(int32, tag = "4")]
    pub exit_code: i32,
    #[prost(message, optional, tag = "9")]
    pub execution_metadata: Option<ExecutedActionMetadata>,
    /// `output_file_symlinks`, `output_directory_symlinks`, `output_symlinks`: refused too.
    #[prost(bytes = "vec", repeated, tag = "10")]
    pub output_file_symlinks: Vec<Vec<u8>>,
    #[prost(bytes = "vec", repeated, tag = "11")]
    pub output_directory_symlinks: Vec<Vec<u8>>,
    #[prost(bytes = "vec", repeated, tag = "12")]
    pub output_symlinks: Vec<Vec<u8>>,
}

/// `OutputFile`: a path relative to the action's working folder and its bytes' digest.
#[derive(Clone, PartialEq, prost::Message)]
pub(crate) struct OutputFile {
    #[prost(string, tag = "1")]
    pub path: String,
    #[prost(message, optional, tag = "2")]
    pub digest: Option<Digest>,
    #[prost(bool, tag = "4")]
    pub is_executable: bool,
}

/// `Digest`: SHA-256 in lowercase hex and the size in bytes (the blob is `cas/HASH`).
#[derive(Clone, PartialEq, prost::Message)]
pub(crate) struct Digest {
    #[prost(string, tag = "1")]
    pub hash: String,
    #[prost(int64, tag = "2")]
    pub size_bytes: i64,
}

/// `ExecutedActionMetadata`: only `worker`, which names the program that wrote the entry.
#[derive(Clone, PartialEq, prost::Message)]
pub(crate) struct ExecutedActionMetadata {
    #[prost(string, tag = "1")]
    pub worker: String,
}

/// One output of an entry: its path (relative, `/`-separated), SHA-256 (hex) and size.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Output {
    pub path: String,
    pub sha256: String,
    pub size: u64,
}

/// The entry of a successful action with `outputs`, written by this cubeforge.
pub(crate) fn encode(outputs: &[Output]) -> Vec<u8> {
    ActionResult {
        output_files: outputs
            .iter()
            .map(|o| OutputFile {
                path: o.path.clone(),
                digest: Some(Digest {
                    hash: o.sha256.clone(),
                    size_bytes: o.size as i64,
                }),
                is_executable: false,
            })
            .collect(),
        exit_code: 0,
        execution_metadata: Some(ExecutedActionMetadata {
            worker: format!("cubeforge {}", env!("CARGO_PKG_VERSION")),
        }),
        ..Default::default()
    }
    .encode_to_vec()
}

/// The outputs of an entry, or why it is not one cubeforge can use: not an `ActionResult`,
/// a failed action, trees or symlinks, a file without a SHA-256 digest, no files at all.
pub(crate) fn decode(bytes: &[u8]) -> Result<Vec<Output>, String> {
    let r = ActionResult::decode(bytes).map_err(|e| format!("not an ActionResult ({e})"))?;
    if r.exit_code != 0 {
        return Err(format!("the action failed (exit code {})", r.exit_code));
    }
    if !(r.output_directories.is_empty()
        && r.output_file_symlinks.is_empty()
        && r.output_directory_symlinks.is_empty()
        && r.output_symlinks.is_empty())
    {
        return Err("it holds output folders or symlinks, which cubeforge never writes".into());
    }
    if r.output_files.is_empty() {
        return Err("it names no output file".into());
    }
    r.output_files
        .into_iter()
        .map(|f| {
            let d = f
                .digest
                .filter(|d| is_sha256(&d.hash) && d.size_bytes >= 0)
                .ok_or_else(|| format!("{:?} has no SHA-256 digest", f.path))?;
            Ok(Output {
                path: f.path,
                sha256: d.hash,
                size: d.size_bytes as u64,
            })
        })
        .collect()
}

/// 64 lowercase hex digits (a digest that can name a `cas/` blob, nothing else).
fn is_sha256(h: &str) -> bool {
    h.len() == 64 && h.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What cubeforge writes it reads back; a failed action, a tree, a bad digest and
    /// bytes that are not a message are refused.
    #[test]
    fn entries_round_trip_and_bad_ones_are_refused() {
        let out = vec![Output {
            path: "sky/px.png".into(),
            sha256: "ab".repeat(32),
            size: 12,
        }];
        let bytes = encode(&out);
        assert_eq!(decode(&bytes).unwrap(), out);
        let with = |f: &dyn Fn(&mut ActionResult)| {
            let mut r = ActionResult::decode(bytes.as_slice()).unwrap();
            f(&mut r);
            decode(&r.encode_to_vec())
        };
        assert!(with(&|r| r.exit_code = 1).is_err());
        assert!(with(&|r| r.output_directories.push(vec![])).is_err());
        assert!(with(&|r| r.output_files.clear()).is_err());
        assert!(with(&|r| r.output_files[0].digest = None).is_err());
        assert!(
            with(&|r| r.output_files[0].digest.as_mut().unwrap().hash = "AB".repeat(32)).is_err()
        );
        assert!(decode(b"{\"outputs\": []}").is_err());
    }
}
