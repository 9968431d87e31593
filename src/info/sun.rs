//! The sun `info` reports (issue 49): the brightest compact light of a map, found by
//! [`crate::flux::sun`], and the other lamps, in units a user can put in an engine.

use crate::cube::Faces;
use crate::flux::{sun, Grid};
use crate::image::Image;
use crate::layout::{self, Kind};
use serde::Serialize;

/// The map scale lux are stated for: a map value of 1 is 1 cd/m^2 (a nit). A map in other
/// units multiplies `illuminance_lux` by its own nits per unit.
pub const NITS_PER_UNIT: f64 = 1.0;

/// One light as `info` prints it (and `ibl --sun` writes in `sun.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LightInfo {
    /// Unit vector towards the light, in cubeforge's frame (docs/conventions.md).
    pub direction: [f32; 3],
    /// RGB irradiance on a surface facing it, in the map's units times steradians: its
    /// radiance above the sky around it, integrated over its texels.
    pub irradiance: [f64; 3],
    /// Degrees across (a disc of the solid angle of its texels above half its peak).
    pub angular_diameter_deg: f64,
    /// Its colour: the irradiance over its largest channel.
    pub color: [f64; 3],
    /// Rec. 709 luminance of the irradiance times [`NITS_PER_UNIT`]: lux.
    pub illuminance_lux: f64,
    /// The map scale the lux are for (cd/m^2 per unit of the map).
    pub nits_per_unit: f64,
    /// How many texels it spans.
    pub texels: usize,
}

impl From<&sun::Light> for LightInfo {
    fn from(l: &sun::Light) -> LightInfo {
        LightInfo {
            direction: l.direction.to_array(),
            irradiance: l.irradiance,
            angular_diameter_deg: l.angular_diameter_deg,
            color: l.color(),
            illuminance_lux: l.luminance() * NITS_PER_UNIT,
            nits_per_unit: NITS_PER_UNIT,
            texels: l.texels,
        }
    }
}

/// The sun (None: none) and the other lights of a map's grid.
pub(crate) fn of_grid(grid: Grid, images: &[&Image]) -> (Option<LightInfo>, Vec<LightInfo>) {
    let lights = sun::find(grid, images);
    (
        lights.sun.as_ref().map(LightInfo::from),
        lights.others.iter().map(LightInfo::from).collect(),
    )
}

/// The lights of six faces.
pub(crate) fn of_faces(faces: &Faces) -> (Option<LightInfo>, Vec<LightInfo>) {
    of_grid(
        Grid::Cube(faces[0].width),
        &faces.iter().collect::<Vec<_>>(),
    )
}

/// The lights of a single image laid out as `kind` (none where the layout is unknown).
pub(crate) fn of_image(kind: Option<Kind>, img: &Image) -> (Option<LightInfo>, Vec<LightInfo>) {
    match kind {
        Some(k) if k.projection().is_some() => {
            let p = k.projection().unwrap_or(layout::Projection::Equirect);
            of_grid(Grid::Projection(p, img.width, img.height), &[img])
        }
        Some(k) => match k.cells() {
            Some(cells) => of_faces(&layout::cross::extract(cells, img)),
            None => (None, Vec::new()),
        },
        None => (None, Vec::new()),
    }
}

/// The `sun:` line (and one per other light) of `info`'s text.
pub(crate) fn lines(
    f: &mut std::fmt::Formatter<'_>,
    sun: Option<&LightInfo>,
    others: &[LightInfo],
) -> std::fmt::Result {
    let one = |l: &LightInfo| {
        let [x, y, z] = l.direction;
        let [r, g, b] = l.irradiance;
        format!(
            "towards ({x:.4}, {y:.4}, {z:.4}), {:.2} degrees across, irradiance {r:.1} {g:.1} {b:.1} \
             ({:.1} lux at 1 cd/m^2 per unit)",
            l.angular_diameter_deg, l.illuminance_lux
        )
    };
    match sun {
        Some(s) => write!(f, "\n  sun:          {}", one(s))?,
        None => write!(
            f,
            "\n  sun:          none (no compact light holds {:.0}% of the light facing it)",
            sun::MIN_SHARE * 100.0
        )?,
    }
    for l in others {
        write!(f, "\n  other light:  {}", one(l))?;
    }
    Ok(())
}
