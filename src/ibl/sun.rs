//! `ibl --sun` (issue 49): the sun taken out of the map and handed to the engine as a
//! directional light, so that it casts a shadow and is not counted twice.
//!
//! The sun is found in the input (cubeforge's frame) and replaced by the sky around it
//! ([`crate::flux::sun::remove`]); every target's files are made from what is left. Its
//! direction is then carried the way the target's files are: through the target's turn (the
//! lookup's `Orientation`) into its cube or panorama, and from there into the engine's world
//! by the engine's own lookup (docs/engines.md): `world` below is that lookup undone.

use super::Engine;
use crate::convert::{Loaded, Source};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::flux::{sun, Grid};
use crate::info::LightInfo;
use crate::resample::Orientation;
use glam::Vec3;

/// The input without its sun, and the sun (None: the map has none and is left whole).
pub fn take_out(loaded: &Loaded) -> Result<(Option<Loaded>, Option<sun::Light>)> {
    let (source, light) = match &loaded.source {
        Source::Projection(p, img) => {
            let grid = Grid::Projection(*p, img.width, img.height);
            let lights = sun::find(grid, &[img]);
            let Some(s) = lights.sun else {
                return Ok((None, None));
            };
            let mut img = img.clone();
            sun::remove(grid, std::slice::from_mut(&mut img), &s, lights.threshold);
            (Source::Projection(*p, img), s)
        }
        Source::Cube(c) => {
            let grid = Grid::Cube(c.size());
            let lights = sun::find(grid, &c.levels[0].iter().collect::<Vec<_>>());
            let Some(s) = lights.sun else {
                return Ok((None, None));
            };
            let mut faces = c.levels[0].clone();
            sun::remove(grid, &mut faces, &s, lights.threshold);
            (
                Source::Cube(CubeMap {
                    levels: vec![faces],
                }),
                s,
            )
        }
        Source::Reduced(_) => {
            return Err(Error::usage(
                "--sun needs the whole input, not one reduced as it was read",
            ))
        }
    };
    let without = Loaded {
        source,
        kind: loaded.kind,
        hdr: loaded.hdr,
        meta: loaded.meta.clone(),
        files: loaded.files.clone(),
    };
    Ok((Some(without), Some(light)))
}

/// Where the sun lies in `engine`'s world (a unit vector towards it), the input's direction
/// `s` carried through the target's turn `o` and the engine's lookup.
pub fn world(engine: Engine, o: Orientation, s: Vec3) -> Vec3 {
    // The file's direction d whose lookup reads the input at s: M d = s.
    let d = (o.lookup_matrix().inverse() * s).normalize();
    match engine {
        // Bevy samples (x, y, -z) of the world direction.
        Engine::Bevy => Vec3::new(d.x, d.y, -d.z),
        // The Sample Viewer samples its 90-degree u_EnvRotation of w: (w.z, w.y, -w.x).
        Engine::Gltf => Vec3::new(-d.z, d.y, d.x),
        // three.js's equirectUv: u = 0.5 + atan2(w.z, w.x) / 2pi against cubeforge's
        // atan2(d.x, d.z): d = (w.z, w.y, w.x).
        Engine::Three => Vec3::new(d.z, d.y, d.x),
        // Godot's sky: u = atan2(w.x, -w.z) / 2pi, a half turn from cubeforge's: d = (-w.x,
        // w.y, w.z).
        Engine::Godot => Vec3::new(-d.x, d.y, d.z),
        // Unreal (left-handed, Z up): the centre +Z at world -Y, up at +Z, right at +X.
        Engine::Unreal => Vec3::new(d.x, -d.z, d.y),
        // Babylon, Filament and Unity look up with the world direction; generic is the cube.
        Engine::Babylon | Engine::Filament | Engine::Unity | Engine::Generic => d,
    }
}

/// `sun.json`: `info`'s fields, the engine's direction towards the sun and its light's
/// intensity and colour in the engine's units, as the snippet sets them.
#[derive(serde::Serialize)]
struct SunFile<'a> {
    sun: Option<&'a LightInfo>,
    engine: &'static str,
    /// Unit vector towards the sun in the engine's world (None: no sun).
    engine_direction: Option<[f32; 3]>,
    /// The light's intensity in the engine's units, and what they are.
    engine_intensity: Option<f64>,
    engine_units: &'static str,
    /// The light's colour (linear RGB) the intensity multiplies.
    engine_color: Option<[f64; 3]>,
}

/// Each engine's scale of the map (what its environment intensity in the snippet makes of a
/// map unit): Bevy's 1000 cd/m^2 and Filament's 30000; the others take the map as it is.
fn map_scale(engine: Engine) -> f64 {
    match engine {
        Engine::Bevy => 1000.0,
        Engine::Filament => 30000.0,
        _ => 1.0,
    }
}

/// The light's intensity, colour and units for `engine`: luminous engines (Bevy, Filament,
/// Unreal) take lux and a colour of luminance 1; the others the largest channel and a colour
/// at most 1; Unity's lights have no 1/pi in their diffuse term, so its intensity is over pi.
fn intensity(engine: Engine, l: &LightInfo) -> (f64, [f64; 3], &'static str) {
    let e = l.irradiance;
    let scale = map_scale(engine);
    let lum = 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2];
    let max = e.iter().cloned().fold(0.0, f64::max);
    let per = |v: f64| e.map(|c| if v > 0.0 { c / v } else { 0.0 });
    match engine {
        Engine::Bevy | Engine::Filament | Engine::Unreal => (
            lum * scale,
            per(lum),
            "lux (the map's units times the snippet's environment scale)",
        ),
        Engine::Unity => (
            max / std::f64::consts::PI,
            per(max),
            "Unity intensity (irradiance over pi)",
        ),
        _ => (
            max,
            per(max),
            "irradiance in the map's units (intensity times colour)",
        ),
    }
}

/// `sun.json`'s bytes and the snippet's lines that place the light for `engine` (a line saying
/// so when the map has no sun).
pub fn deliver(engine: Engine, o: Orientation, light: Option<&sun::Light>) -> (Vec<u8>, String) {
    let info = light.map(LightInfo::from);
    let Some(l) = &info else {
        let file = SunFile {
            sun: None,
            engine: engine.name(),
            engine_direction: None,
            engine_intensity: None,
            engine_units: "",
            engine_color: None,
        };
        let text = format!(
            "\n// --sun: the map has no sun (no compact light holds {:.0}% of the light facing it): \
             the maps are the input's, and no light is added.",
            sun::MIN_SHARE * 100.0
        );
        return (serde_json::to_vec_pretty(&file).unwrap_or_default(), text);
    };
    let w = world(engine, o, Vec3::from_array(l.direction));
    let (i, c, units) = intensity(engine, l);
    let file = SunFile {
        sun: Some(l),
        engine: engine.name(),
        engine_direction: Some(w.to_array()),
        engine_intensity: Some(i),
        engine_units: units,
        engine_color: Some(c),
    };
    let text = super::sun_snippets::snippet(engine, w, i, c, l.angular_diameter_deg);
    (serde_json::to_vec_pretty(&file).unwrap_or_default(), text)
}
