//! numpy arrays in and out: a file read to float32 RGBA arrays, an array written as a 32-bit
//! EXR (what `cubeforge.write` hands to the CLI's convert job), and an array converted
//! between layouts in memory.

use cubeforge::internals::convert::{self, Loaded, Source};
use cubeforge::internals::layout::{self, Kind};
use cubeforge::{CubeMap, Image};
use glam::Vec4;
use numpy::{PyArray1, PyArray3, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};

/// A library image's texels, owned by the numpy array made of them (its base): handed over
/// without a copy. Vec4's 16-byte alignment is not f32's, so the Vec cannot become numpy's
/// own buffer; numpy reads it in place and drops it with the array.
#[pyclass(frozen)]
struct Texels(Vec<Vec4>);

/// An image as a (height, width, 4) float32 array over its own texels (no copy).
pub fn image_array<'py>(py: Python<'py>, img: Image) -> PyResult<Bound<'py, PyAny>> {
    let (h, w) = (img.height, img.width);
    let owner = Bound::new(py, Texels(img.pixels))?;
    let data = owner.get().0.as_ptr() as *const f32;
    // SAFETY: the texels are h * w Vec4, four f32 each without padding (glam's layout), in
    // row order; the Vec is never touched again until the owner, the array's base, drops.
    let view = unsafe { numpy::ndarray::ArrayView3::from_shape_ptr((h, w, 4), data) };
    Ok(unsafe { PyArray3::borrow_from_array(&view, owner.into_any()) }.into_any())
}

fn bytemuck_cast(p: &[Vec4]) -> &[f32] {
    // SAFETY: Vec4 is four f32 without padding (glam's layout, repr(C) or SIMD of 16 bytes).
    unsafe { std::slice::from_raw_parts(p.as_ptr() as *const f32, p.len() * 4) }
}

/// Six faces (px nx py ny pz nz) as one (6, size, size, 4) array.
fn faces_array<'py>(py: Python<'py>, faces: &[Image; 6]) -> PyResult<Bound<'py, PyAny>> {
    let n = faces[0].width;
    let mut flat = Vec::with_capacity(6 * n * n * 4);
    for f in faces {
        flat.extend_from_slice(bytemuck_cast(&f.pixels));
    }
    Ok(PyArray1::from_vec(py, flat)
        .reshape([6, n, n, 4])?
        .into_any())
}

/// An array of (h, w, c) or (6, n, n, c), c of 1 (grey), 3 (RGB) or 4 (RGBA), to images.
fn images_of(py: Python<'_>, a: &PyReadonlyArrayDyn<'_, f32>) -> PyResult<Vec<Image>> {
    let shape = a.shape().to_vec();
    let (count, h, w, c) = match shape[..] {
        [h, w] => (1, h, w, 1),
        [h, w, c] => (1, h, w, c),
        [6, h, w, c] if h == w => (6, h, w, c),
        _ => {
            return Err(crate::bad_arg(
                py,
                format!("an array of shape {shape:?}: give (height, width[, channels]) or (6, size, size, channels)"),
            ))
        }
    };
    if !matches!(c, 1 | 3 | 4) || h == 0 || w == 0 {
        return Err(crate::bad_arg(
            py,
            format!("an array of shape {shape:?}: 1, 3 or 4 channels and no empty side"),
        ));
    }
    let data = a
        .as_slice()
        .map_err(|e| crate::bad_arg(py, e.to_string()))?;
    let texel = |s: &[f32]| match c {
        1 => Vec4::new(s[0], s[0], s[0], 1.0),
        3 => Vec4::new(s[0], s[1], s[2], 1.0),
        _ => Vec4::new(s[0], s[1], s[2], s[3]),
    };
    Ok(data
        .chunks_exact(h * w * c)
        .take(count)
        .map(|img| Image {
            width: w,
            height: h,
            pixels: img.chunks_exact(c).map(texel).collect(),
        })
        .collect())
}

/// Refuses NaN and infinite values, which an array converted in memory would carry into its
/// output (a file's are replaced by 0 as it is read, with a warning: `write` does that).
fn finite(py: Python<'_>, images: &[Image]) -> PyResult<()> {
    let bad = images
        .iter()
        .flat_map(|i| &i.pixels)
        .filter(|p| !p.is_finite())
        .count();
    if bad > 0 {
        return Err(crate::bad_arg(
            py,
            format!(
                "convert: {bad} texels of the array hold NaN or infinite values: give finite \
                 radiance (numpy.nan_to_num), or write() it, which replaces them by 0 as a file's are"
            ),
        ));
    }
    Ok(())
}

/// What `cubeforge.read` returns: the pixels (an image, or each level's faces) and the file's
/// metadata.
#[pyfunction]
#[pyo3(signature = (argv))]
pub fn read<'py>(py: Python<'py>, argv: Vec<String>) -> PyResult<Bound<'py, PyDict>> {
    use clap::Parser;
    // The words of a `convert` command line: its input flags, read the CLI's way.
    let words = ["cubeforge", "convert"]
        .into_iter()
        .map(String::from)
        .chain(argv)
        .chain(["-o".into(), "unused.exr".into()]);
    let parsed = crate::cli::Cli::try_parse_from(words)
        .map_err(|e| crate::bad_arg(py, crate::cli::one_line(&e)))?;
    let crate::cli::Command::Convert(a) = parsed.command else {
        return Err(crate::bad_arg(py, "not a read"));
    };
    let loaded = py
        .detach(|| {
            let opts = a.input.read_options(&a.inputs)?;
            convert::load(&a.inputs, a.input.from, &opts)
        })
        .map_err(|e| crate::error(py, &e))?;
    let d = PyDict::new(py);
    d.set_item("kind", loaded.kind.name())?;
    d.set_item("layout", loaded.kind.layout().name())?;
    // The pixels move into their arrays (no copy of a single image); the metadata stays.
    match loaded.source {
        Source::Cube(c) => {
            let levels: PyResult<Vec<_>> = c.levels.iter().map(|l| faces_array(py, l)).collect();
            d.set_item("levels", levels?)?;
        }
        Source::Projection(_, img) => d.set_item("image", image_array(py, img)?)?,
        Source::Reduced(_) => return Err(crate::bad_arg(py, "a reduced panorama")),
    }
    let m = &loaded.meta;
    d.set_item("file_format", format!("{:?}", m.file_format).to_lowercase())?;
    d.set_item("pixel_format", &m.pixel_format)?;
    d.set_item("hdr", m.hdr)?;
    d.set_item("stored_levels", m.stored_levels)?;
    d.set_item("replaced_values", m.replaced_values)?;
    d.set_item("part", m.part.clone())?;
    d.set_item("declared", m.declared.clone())?;
    let files: Vec<String> = loaded
        .files
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    d.set_item("files", files)?;
    Ok(d)
}

/// Writes an array as a 32-bit float EXR at `path` (one image), or six (px.exr ... nz.exr)
/// in the folder `path` (a (6, n, n, c) array): the input of `cubeforge.write`'s convert job.
/// Its NaN, infinite and negative values are replaced as a file's are when it is read, and
/// the warning a file's read gives is returned (None: none replaced).
#[pyfunction]
pub fn write_exr(
    py: Python<'_>,
    path: PathBuf,
    array: PyReadonlyArrayDyn<'_, f32>,
) -> PyResult<Option<String>> {
    use cubeforge::internals::io::WriteOptions;
    use cubeforge::internals::output::encode_image;
    use cubeforge::internals::output::{deliver, Files};
    let mut images = images_of(py, &array)?;
    let replaced: usize = images.iter_mut().map(Image::sanitize).sum();
    let note = cubeforge::internals::input::replaced_note(Path::new("array"), replaced as u64);
    py.detach(|| {
        let opts = WriteOptions {
            exr_float: cubeforge::ExrFloat::F32,
            ..WriteOptions::default()
        };
        let mut files = Files::default();
        if images.len() == 6 {
            for (img, name) in images.iter().zip(cubeforge::internals::cube::FACE_NAMES) {
                let p = path.join(format!("{name}.exr"));
                files.files.push((p.clone(), encode_image(&p, img, &opts)?));
            }
            files.folders.push(path.clone());
        } else {
            files
                .files
                .push((path.clone(), encode_image(&path, &images[0], &opts)?));
        }
        deliver(&files, &cubeforge::Destination::Path(path.clone()), &[])
    })
    .map_err(|e| crate::error(py, &e))?;
    Ok(note)
}

/// One image file as it is (a preview, a table: no layout), as a (height, width, 4) array.
#[pyfunction]
pub fn read_image<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    use cubeforge::internals::convert::read;
    use cubeforge::internals::io::Decoded;
    let got = py.detach(|| read(&path, &cubeforge::ReadOptions::default()));
    match got.map_err(|e| crate::error(py, &e))? {
        (Decoded::Image(img), _) => image_array(py, img),
        (Decoded::Cube(c), _) => faces_array(py, &c.levels[0]),
    }
}

/// The layout a single image's aspect ratio says (None when it is square or fits none).
#[pyfunction]
pub fn detect_layout(width: usize, height: usize) -> Option<&'static str> {
    layout::detect(width, height).ok().map(|k| k.name())
}

/// An array converted to layout `to` at face edge `size` (faces: (6, size, size, 4)).
#[pyfunction]
#[pyo3(signature = (array, to, size, from_=None))]
pub fn convert_array<'py>(
    py: Python<'py>,
    array: PyReadonlyArrayDyn<'py, f32>,
    to: &str,
    size: usize,
    from_: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    use clap::ValueEnum;
    let kind = |s: &str| Kind::from_str(s, true).map_err(|e| crate::bad_arg(py, e));
    let to = kind(to)?;
    if size == 0 || size > 16384 {
        return Err(crate::bad_arg(py, format!("size={size}: 1 to 16384")));
    }
    let mut images = images_of(py, &array)?;
    finite(py, &images)?;
    let source = if images.len() == 6 {
        let faces: [Image; 6] =
            std::array::from_fn(|i| std::mem::replace(&mut images[i], Image::new(0, 0)));
        Source::Cube(CubeMap {
            levels: vec![faces],
        })
    } else {
        let img = images.pop().expect("one image");
        let from = match from_ {
            Some(s) => kind(s)?,
            None => layout::detect(img.width, img.height).map_err(|e| crate::bad_arg(py, e))?,
        };
        match (from.projection(), from.cells()) {
            (Some(p), _) => Source::Projection(p, img),
            (None, Some(cells)) => Source::Cube(CubeMap {
                levels: vec![cubeforge::internals::layout::cross::extract(cells, &img)],
            }),
            _ => {
                return Err(crate::bad_arg(
                    py,
                    "from_='faces' needs a (6, n, n, c) array",
                ))
            }
        }
    };
    let placeholder = CubeMap {
        levels: vec![std::array::from_fn(|_| Image::new(1, 1))],
    };
    let mut loaded = Loaded::from_cube(placeholder);
    loaded.source = source;
    let out = py.detach(|| convert::convert(&loaded, to, size, &cubeforge::Resampler::default()));
    match out {
        convert::Output::Image(img) => image_array(py, img),
        convert::Output::Cube(c) => faces_array(py, &c.levels[0]),
    }
}
