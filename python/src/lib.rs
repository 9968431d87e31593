//! cubeforge for Python: the compiled half of the `cubeforge` package (python/cubeforge holds
//! the Python half: errors, keyword arguments turned into flags, py360convert's layouts).
//! Jobs are the command line's own: its flag definitions are compiled in from src/cli, so a
//! keyword argument is a flag and a job writes the bytes the CLI writes.

// The command line, whole: its job builders are what the jobs here run. What only the
// binary calls is dead here.
mod arrays;
mod batch;
#[allow(dead_code, unused_imports)]
#[path = "../../src/cli/mod.rs"]
mod cli;
mod compat;
mod persp;
mod run;

use pyo3::prelude::*;

/// The Python exception for a library error: `cubeforge.FileError` (an `OSError`) when a
/// file could not be read, written or decoded, `cubeforge.ArgumentError` (a `ValueError`)
/// for a bad argument or a limit; the message is the command line's one line.
pub(crate) fn error(py: Python<'_>, e: &cubeforge::Error) -> PyErr {
    use cubeforge::Error as E;
    let class = match e {
        E::Io { .. } | E::Decode { .. } | E::Recipe { .. } => "FileError",
        _ => "ArgumentError",
    };
    let raise = match e {
        E::Limit {
            kind: cubeforge::LimitKind::Pixels,
            ..
        } => "; raise it with max_pixels= if the file is genuine",
        E::Limit {
            kind: cubeforge::LimitKind::Memory,
            ..
        } => "; raise it with max_memory=",
        _ => "",
    };
    let text = format!("{}{raise}", e.with_flags());
    raise_as(py, class, text)
}

/// An exception of class `name` from cubeforge._errors with `text`.
pub(crate) fn raise_as(py: Python<'_>, name: &str, text: String) -> PyErr {
    let made = py
        .import("cubeforge._errors")
        .and_then(|m| m.getattr(name))
        .and_then(|c| c.call1((text.clone(),)));
    match made {
        Ok(obj) => PyErr::from_value(obj),
        Err(e) => e,
    }
}

/// A bad argument caught here (not by the library): `cubeforge.ArgumentError`.
pub(crate) fn bad_arg(py: Python<'_>, text: impl Into<String>) -> PyErr {
    raise_as(py, "ArgumentError", text.into())
}

/// A zeroed output of `dims` floats for `what`, or an `ArgumentError` when their count
/// overflows or their bytes exceed the memory budget (half of what this process may use):
/// `e2c(face_w=10**6)` aborted the interpreter when the allocation failed.
pub(crate) fn zeroed(py: Python<'_>, what: &str, dims: &[usize]) -> PyResult<Vec<f32>> {
    let budget = cubeforge::Limits::default().max_memory;
    let count = dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d));
    let bytes = count.and_then(|n| n.checked_mul(4)).map(|b| b as u64);
    match (count, bytes) {
        (Some(n), Some(b)) if b <= budget => Ok(vec![0f32; n]),
        _ => Err(bad_arg(
            py,
            format!(
                "{what}: an output of {dims:?} floats, more than the memory budget of {} MiB",
                budget >> 20
            ),
        )),
    }
}

#[pymodule]
fn _cubeforge(m: &Bound<'_, PyModule>) -> PyResult<()> {
    run::quiet_cancel_panics();
    m.add_function(wrap_pyfunction!(run::run_job, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch, m)?)?;
    m.add_function(wrap_pyfunction!(run::info, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::read, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::detect_layout, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::convert_array, m)?)?;
    m.add_function(wrap_pyfunction!(compat::e2c_faces, m)?)?;
    m.add_function(wrap_pyfunction!(compat::c2e_faces, m)?)?;
    m.add_function(wrap_pyfunction!(persp::e2p_view, m)?)?;
    Ok(())
}
