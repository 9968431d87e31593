//! Image sources: one channel of an image file, read while the recipe is parsed (so a missing
//! or unreadable file is an error naming the recipe's line) and resized to the output.

#![warn(missing_docs)]

use super::resize::resize;
use crate::image::{luminance, srgb_to_linear, Image};
use crate::io::{self, Decoded, Limits, ReadOptions};
use glam::Vec4;
use rayon::prelude::*;
use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;
use std::cell::RefCell;
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One channel of an image file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageChannel {
    /// The image, read while the recipe was parsed (the recipe gives its path).
    pub path: ImageFile,
    /// Which channel becomes the values, luminance by default.
    #[serde(default)]
    pub channel: Channel,
    /// Decode sRGB (painted colour) before taking the channel; 8- and 16-bit files only.
    #[serde(default)]
    pub srgb: bool,
}

/// Which channel of an image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    /// The red channel (`r` or `red` in a recipe).
    #[serde(alias = "red")]
    R,
    /// The green channel (`g` or `green` in a recipe).
    #[serde(alias = "green")]
    G,
    /// The blue channel (`b` or `blue` in a recipe).
    #[serde(alias = "blue")]
    B,
    /// The alpha channel (`a` or `alpha` in a recipe).
    #[serde(alias = "alpha")]
    A,
    /// Rec. 709 luminance of R, G and B.
    #[default]
    Luminance,
}

impl Channel {
    pub(super) fn name(self) -> &'static str {
        match self {
            Channel::R => "r",
            Channel::G => "g",
            Channel::B => "b",
            Channel::A => "a",
            Channel::Luminance => "luminance",
        }
    }
}

/// An image read while the recipe was parsed: as stored (no sRGB decode), at full size.
#[derive(Clone)]
pub struct ImageFile {
    /// The path as the recipe writes it.
    pub name: String,
    /// Where it was read from.
    pub path: PathBuf,
    /// The decoded texels, shared by every source that names the same file.
    pub image: Arc<Image>,
    /// Float data (EXR, HDR, float KTX2/DDS): never sRGB-decoded.
    pub float: bool,
}

impl fmt::Debug for ImageFile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "ImageFile({}, {}x{})",
            self.path.display(),
            self.image.width,
            self.image.height
        )
    }
}

struct ParseContext {
    base: PathBuf,
    limits: Limits,
    cache: HashMap<PathBuf, (Arc<Image>, bool)>,
    /// Bytes the images read so far keep: each next one is checked against the budget
    /// with them, before it is decoded.
    held: u64,
}

thread_local! {
    static CONTEXT: RefCell<Option<ParseContext>> = const { RefCell::new(None) };
}

/// Sets the folder image paths are relative to (and the size limit) for one parse.
pub(super) struct ContextGuard(Option<ParseContext>);

impl ContextGuard {
    pub(super) fn enter(base: &Path, limits: &Limits) -> ContextGuard {
        let ctx = ParseContext {
            base: base.to_path_buf(),
            limits: *limits,
            cache: HashMap::new(),
            held: 0,
        };
        ContextGuard(CONTEXT.with(|c| c.replace(Some(ctx))))
    }
}

impl Drop for ContextGuard {
    fn drop(&mut self) {
        let previous = self.0.take();
        CONTEXT.with(|c| *c.borrow_mut() = previous);
    }
}

fn load_image(name: &str) -> std::result::Result<ImageFile, String> {
    if name.is_empty() {
        return Err("the image path is empty".into());
    }
    CONTEXT.with(|c| {
        let mut guard = c.borrow_mut();
        let ctx = guard.get_or_insert_with(|| ParseContext {
            base: PathBuf::from("."),
            limits: Limits::default(),
            cache: HashMap::new(),
            held: 0,
        });
        let path = if ctx.base == Path::new(".") {
            PathBuf::from(name)
        } else {
            ctx.base.join(name)
        };
        if let Some((image, float)) = ctx.cache.get(&path) {
            return Ok(ImageFile {
                name: name.to_string(),
                path,
                image: image.clone(),
                float: *float,
            });
        }
        if !path.is_file() {
            let what = if path.exists() {
                "is not a file"
            } else {
                "image not found"
            };
            return Err(format!("{}: {what}", path.display()));
        }
        let read = ReadOptions {
            limits: ctx.limits,
            linear: true,
            as_stored: false,
            ..Default::default()
        };
        // The recipe's images together within the budget, each checked before its decode.
        let claim = io::claim(&path, &read).map_err(|e| e.to_string())?;
        if let Some(c) = claim {
            ctx.limits
                .check_memory(
                    format_args!("{} with the recipe's other images", path.display()),
                    ctx.held.saturating_add(c.decode_bytes),
                )
                .map_err(|e| e.to_string())?;
            ctx.held = ctx.held.saturating_add(c.held_bytes);
        }
        let (decoded, meta) = crate::convert::read(&path, &read).map_err(|e| e.to_string())?;
        let image = match decoded {
            Decoded::Image(img) => Arc::new(img),
            Decoded::Cube(_) => {
                return Err(format!(
                    "{}: holds a cube map; a control-map source must be a 2D image",
                    path.display()
                ))
            }
        };
        ctx.cache.insert(path.clone(), (image.clone(), meta.hdr));
        Ok(ImageFile {
            name: name.to_string(),
            path,
            image,
            float: meta.hdr,
        })
    })
}

impl<'de> Deserialize<'de> for ImageFile {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<ImageFile, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = ImageFile;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("the path of an image file")
            }
            fn visit_str<E: de::Error>(self, name: &str) -> std::result::Result<ImageFile, E> {
                load_image(name).map_err(E::custom)
            }
        }
        d.deserialize_str(V)
    }
}

impl ImageChannel {
    /// The channel at full size, decoded as asked and clamped to [0, 1], then resized.
    pub(super) fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        let img = &self.path.image;
        let decode = self.srgb && !self.path.float;
        let tf = |v: f32| if decode { srgb_to_linear(v) } else { v };
        let channel = self.channel;
        let values: Vec<f32> = img
            .pixels
            .par_iter()
            .map(|p| {
                let v = match channel {
                    Channel::R => tf(p.x),
                    Channel::G => tf(p.y),
                    Channel::B => tf(p.z),
                    Channel::A => p.w,
                    Channel::Luminance => luminance(Vec4::new(tf(p.x), tf(p.y), tf(p.z), 0.0)),
                };
                v.clamp(0.0, 1.0)
            })
            .collect();
        resize(&values, img.width, img.height, width, height)
    }
}
