//! The preview's textures and cells: the decal and control map read once, one render per
//! cell (materials, LOD biases, or roughness and metallic values), and the contact sheet.

use super::PreviewJob;
use crate::error::Result;
use crate::image::Image;
use crate::jobs::Progress;
use crate::preview::material::{Material, Model};
use crate::preview::pbr::PbrSetup;
use crate::preview::{self, grid, Control, LoadedEnv, Options, Surface};
use std::path::PathBuf;

/// The textures on the sphere, each read once.
pub(super) struct Textures {
    /// The job's decal, which overrides the materials' own.
    decal: Option<Image>,
    /// The control map and the LOD bias its blur of 1 means.
    control: Option<(Image, f32)>,
    /// Decals named by material files.
    file_decals: Vec<(PathBuf, Image)>,
}

/// Reads the decal, the control map (and its sidecar) and the materials' decals, adding each
/// file to `inputs` (which the output must not overwrite).
pub(super) fn load_textures(
    job: &PreviewJob,
    materials: &[Material],
    progress: &dyn Progress,
    inputs: &mut Vec<PathBuf>,
) -> Result<Textures> {
    let limits = &job.limits;
    let decal = job
        .decal
        .as_ref()
        .map(|p| preview::read_texture(p, false, limits))
        .transpose()?;
    inputs.extend(job.decal.iter().cloned());
    let control = match &job.control {
        Some(p) => {
            let (img, max, side) = preview::read_control(p, job.max_lod_bias, limits)?;
            inputs.push(p.clone());
            progress.note(&match &side {
                Some(s) => format!("control map blur 1 = LOD bias {max} (from {})", s.display()),
                None => format!(
                    "control map blur 1 = LOD bias {max} ({})",
                    crate::error::param("max_lod_bias")
                ),
            });
            Some((img, max))
        }
        None => None,
    };
    // Decals named by material files, read once each.
    let mut file_decals: Vec<(PathBuf, Image)> = Vec::new();
    if decal.is_none() {
        for m in materials {
            if let Some(p) = &m.decal {
                if !file_decals.iter().any(|(q, _)| q == p) {
                    file_decals.push((p.clone(), preview::read_texture(p, false, limits)?));
                    inputs.push(p.clone());
                }
            }
        }
    }
    Ok(Textures {
        decal,
        control,
        file_decals,
    })
}

/// Blur (a LOD bias, or a control map's) asked of an environment without a chain does
/// nothing: the warning that says so rather than render a sharp picture silently. (pbr
/// materials always sample a chain, made in memory when the environment has none.)
pub(super) fn without_chain(
    job: &PreviewJob,
    env: &LoadedEnv,
    materials: &[Material],
    textures: &Textures,
) -> Option<String> {
    if materials.iter().all(|m| m.model == Model::Pbr) {
        return None;
    }
    let wants_blur = job.view.lod_bias != 0.0
        || job.grid_bias.iter().any(|b| *b != 0.0)
        || textures
            .control
            .as_ref()
            .is_some_and(|(img, max)| *max > 0.0 && img.pixels.iter().any(|p| p.z > 0.0));
    (env.levels() == 1 && wants_blur).then(|| {
        format!(
            "{} has one level: LOD bias and blur need a prefiltered mip chain (make one with `cubeforge prefilter`); rendering without blur",
            job.env.display()
        )
    })
}

/// The cells of a roughness / metallic sweep of `m`, row by row (one row per metallic value),
/// and the row's length.
fn sweep(job: &PreviewJob, m: &Material) -> (Vec<(Material, f32, String)>, usize) {
    let opt = |v: &[f32]| -> Vec<Option<f32>> {
        if v.is_empty() {
            vec![None]
        } else {
            v.iter().copied().map(Some).collect()
        }
    };
    let (metals, roughs) = (opt(&job.grid_metallic), opt(&job.grid_roughness));
    let mut cells = Vec::new();
    for metal in &metals {
        for rough in &roughs {
            let mut cell = m.clone();
            let mut label = Vec::new();
            if let Some(v) = metal {
                cell.metallic = *v;
                label.push(format!("m {v}"));
            }
            if let Some(v) = rough {
                cell.roughness = *v;
                label.push(format!("r {v}"));
            }
            cells.push((cell, job.view.lod_bias, label.join("  ")));
        }
    }
    (cells, roughs.len())
}

/// One render per cell, tone-mapped when the output is; a grid becomes a contact sheet.
pub(super) fn render(
    job: &PreviewJob,
    materials: &[Material],
    env: &LoadedEnv,
    pbr_setup: Option<&PbrSetup>,
    textures: &Textures,
    progress: &dyn Progress,
) -> Result<Image> {
    let swept = !job.grid_roughness.is_empty() || !job.grid_metallic.is_empty();
    let mut columns = None;
    let cells: Vec<(Material, f32, String)> = if swept {
        let (cells, cols) = sweep(job, &materials[0]);
        columns = Some(cols);
        cells
    } else if !job.grid_bias.is_empty() {
        job.grid_bias
            .iter()
            .map(|b| (materials[0].clone(), *b, format!("bias {b}")))
            .collect()
    } else {
        materials
            .iter()
            .map(|m| (m.clone(), job.view.lod_bias, m.name.clone()))
            .collect()
    };
    let tone_mapped = super::tone_mapped(&job.output);
    let mut rendered: Vec<(Image, String)> = Vec::with_capacity(cells.len());
    for (m, bias, label) in cells {
        let decal = textures.decal.as_ref().or_else(|| {
            m.decal.as_ref().and_then(|p| {
                textures
                    .file_decals
                    .iter()
                    .find(|(q, _)| q == p)
                    .map(|(_, i)| i)
            })
        });
        let surface = Surface {
            decal,
            control: textures.control.as_ref().map(|(img, max)| Control {
                map: img,
                max_lod_bias: *max,
            }),
        };
        let o = Options {
            lod_bias: bias,
            ..job.view
        };
        progress.start(o.size as u64, &format!("preview {label}"));
        // pbr materials sample the GGX chain (perhaps made in memory), the others the map.
        let (sampler, split_sum) = match pbr_setup {
            Some(p) if m.model == Model::Pbr => (p.sampler(env), Some(&p.split_sum)),
            _ => (&env.sampler, None),
        };
        let mut img = preview::render_lit(sampler, split_sum, &m, &surface, &o, &|n| {
            progress.advance(n)
        })?;
        progress.finish();
        if tone_mapped {
            crate::tonemap::apply(&mut img, job.tone.1, job.tone.0);
        } else if job.tone.0 != 0.0 {
            // Linear pictures keep radiance, scaled by the exposure alone.
            crate::tonemap::scale(&mut img, job.tone.0);
        }
        rendered.push((img, label));
    }
    Ok(if let Some(cols) = columns {
        grid::contact_sheet_columns(&rendered, cols)
    } else if job.grid.is_empty() && job.grid_bias.is_empty() {
        rendered.swap_remove(0).0
    } else {
        grid::contact_sheet(&rendered)
    })
}
