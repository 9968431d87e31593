"""Reads and writes cubeforge's team cache the way Bazel does, with REAPI's own generated classes
(buildgrid's remote_execution_pb2), never with cubeforge's code: tests/it/batch/reapi.rs runs it.

  python3 reapi_cache.py check URL STORE      every ac/ entry under STORE/ac fetched from URL, parsed
                                              with ActionResult.FromString, every output's blob
                                              fetched from URL/cas/HASH and its hash and size checked
  python3 reapi_cache.py rewrite URL STORE    every ac/ entry replaced by one this script builds: the
                                              same paths, digests computed here from the blobs' bytes,
                                              its own worker name and timestamps cubeforge never writes

The bearer token is CUBEFORGE_CACHE_TOKEN. Exit status 3 (and one line): the module is missing.
"""
import hashlib, json, os, sys, urllib.error, urllib.request

try:
    from buildgrid._protos.build.bazel.remote.execution.v2 import remote_execution_pb2 as re
except ImportError as e:
    print(f"buildgrid's REAPI classes are missing ({e}): pip install --no-deps buildgrid; pip install protobuf")
    sys.exit(3)

TOKEN = os.environ.get("CUBEFORGE_CACHE_TOKEN", "")


def request(url, data=None, method="GET"):
    req = urllib.request.Request(url, data=data, method=method, headers={"Authorization": f"Bearer {TOKEN}"})
    with urllib.request.urlopen(req) as r:
        return r.read()


def fail(text):
    print("reapi: " + text)
    sys.exit(1)


def entries(url, store):
    """Each ac/ key the store holds, with the ActionResult fetched over HTTP."""
    for key in sorted(os.listdir(os.path.join(store, "ac"))):
        raw = request(f"{url}/ac/{key}")
        result = re.ActionResult.FromString(raw)
        yield key, raw, result


def blob(url, digest):
    data = request(f"{url}/cas/{digest.hash}")
    if hashlib.sha256(data).hexdigest() != digest.hash or len(data) != digest.size_bytes:
        fail(f"cas/{digest.hash}: the bytes do not match the digest ({len(data)} bytes)")
    return data


def check(url, store):
    n_entries = n_blobs = lists = 0
    for key, raw, r in entries(url, store):
        if len(key) != 64 or r.exit_code != 0 or not r.output_files:
            fail(f"ac/{key}: not a successful action with outputs: {r}")
        if r.output_directories or r.output_symlinks or r.output_file_symlinks:
            fail(f"ac/{key}: trees or symlinks")
        if not r.execution_metadata.worker.startswith("cubeforge "):
            fail(f"ac/{key}: worker {r.execution_metadata.worker!r}")
        # Canonical bytes: what Python's protobuf writes for the same message.
        if r.SerializeToString(deterministic=True) != raw:
            fail(f"ac/{key}: not protobuf's canonical encoding")
        for f in r.output_files:
            parts = f.path.split("/")
            if f.path.startswith("/") or any(p in ("", ".", "..") for p in parts):
                fail(f"ac/{key}: path {f.path!r} is not a plain relative path")
            data = blob(url, f.digest)
            n_blobs += 1
            if f.path == "inputs.json":
                json.loads(data)["reads"]
                lists += 1
        n_entries += 1
    print(f"reapi: {n_entries} ActionResult entries, {lists} lists of inputs, {n_blobs} blobs checked")


def rewrite(url, store):
    n = 0
    for key, raw, old in entries(url, store):
        new = re.ActionResult(exit_code=0)
        for f in old.output_files:
            data = request(f"{url}/cas/{f.digest.hash}")
            d = re.Digest(hash=hashlib.sha256(data).hexdigest(), size_bytes=len(data))
            new.output_files.append(re.OutputFile(path=f.path, digest=d, is_executable=False))
        new.execution_metadata.worker = "buildgrid's remote_execution_pb2"
        new.execution_metadata.worker_start_timestamp.seconds = 1700000000
        new.execution_metadata.worker_completed_timestamp.seconds = 1700000003
        data = new.SerializeToString()
        if data == raw:
            fail(f"ac/{key}: the rewritten entry has the same bytes")
        request(f"{url}/ac/{key}", data=data, method="PUT")
        n += 1
    print(f"reapi: {n} entries rewritten by ActionResult.SerializeToString")


if __name__ == "__main__":
    mode, url, store = sys.argv[1:4]
    {"check": check, "rewrite": rewrite}[mode](url.rstrip("/"), store)
