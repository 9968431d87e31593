//! The lines that place `ibl --sun`'s light in each engine: a directional light shining from
//! the sun's direction in the engine's world (see `sun::world`), with its intensity and
//! colour in the engine's units and its shadows on.

use super::Engine;
use glam::{Quat, Vec3};

/// The rotation that turns -Z (the way a glTF light shines from its node) to shine along
/// `travel`.
fn shining(travel: Vec3) -> Quat {
    Quat::from_rotation_arc(Vec3::NEG_Z, travel.normalize())
}

/// Numbers as the snippets print them.
fn n(v: f64) -> String {
    format!("{v:.6}")
}

fn v3(v: Vec3) -> String {
    format!("{}, {}, {}", n(v.x as f64), n(v.y as f64), n(v.z as f64))
}

fn rgb(c: [f64; 3]) -> String {
    format!("{}, {}, {}", n(c[0]), n(c[1]), n(c[2]))
}

/// An up vector for a node looking along `dir` (Y, unless it looks nearly straight up or down).
fn up_for(dir: Vec3) -> Vec3 {
    if dir.normalize().y.abs() > 0.99 {
        Vec3::Z
    } else {
        Vec3::Y
    }
}

/// The snippet's lines for `engine`: `w` the unit vector towards the sun in its world,
/// `i` and `c` the intensity and colour in its units, `diameter` degrees across.
pub fn snippet(engine: Engine, w: Vec3, i: f64, c: [f64; 3], diameter: f64) -> String {
    let travel = -w;
    let at = w * 50.0;
    let intensity = n(i);
    let (color, up) = (rgb(c), up_for(w));
    match engine {
        Engine::Bevy => format!(
            r#"
// --sun: the sun, taken out of the maps (sun.json), as a light that casts shadows.
commands.spawn((
    DirectionalLight {{
        illuminance: {intensity}, // lux: the sun's irradiance times the environment's 1000
        color: Color::linear_rgb({color}),
        shadows_enabled: true,
        ..default()
    }},
    Transform::from_xyz({p}).looking_at(Vec3::ZERO, Vec3::new({up})),
));"#,
            p = v3(at),
            up = v3(up),
        ),
        Engine::Three => format!(
            r#"
// --sun: the sun, taken out of the panorama (sun.json), as a light that casts shadows
// (renderer.shadowMap.enabled = true; size sun.shadow.camera to the scene).
const sun = new THREE.DirectionalLight(new THREE.Color({color}), {intensity});
sun.position.set({p}); // towards the sun; it shines at sun.target (the origin)
sun.castShadow = true;
scene.add(sun);"#,
            p = v3(at),
        ),
        Engine::Godot => format!(
            r#"
# --sun: the sun, taken out of the panorama (sun.json), as a light that casts shadows.
var sun := DirectionalLight3D.new()
sun.light_color = Color({color}).linear_to_srgb()
sun.light_energy = {intensity}
sun.shadow_enabled = true
add_child(sun)
sun.look_at_from_position(Vector3({p}), Vector3.ZERO, Vector3({up}))"#,
            p = v3(at),
            up = v3(up),
        ),
        Engine::Filament => format!(
            r#"
// --sun: the sun, taken out of the maps (sun.json): Filament's sun light, its disc and halo.
utils::Entity sunEntity = utils::EntityManager::get().create();
filament::LightManager::Builder(filament::LightManager::Type::SUN)
    .color({{{color}}}).intensity({intensity}f) // lux: the irradiance times the IBL's 30000
    .direction({{{d}}})
    .sunAngularRadius({r}f).sunHaloSize(10.0f).sunHaloFalloff(80.0f)
    .castShadows(true).build(*engine, sunEntity);
scene->addEntity(sunEntity);"#,
            d = v3(travel),
            r = n(diameter / 2.0),
        ),
        Engine::Babylon => format!(
            r#"
// --sun: the sun, taken out of the .env (sun.json), as a light that casts shadows.
const sun = new BABYLON.DirectionalLight("sun", new BABYLON.Vector3({d}), scene);
sun.diffuse = new BABYLON.Color3({color});
sun.intensity = {intensity};
const sunShadows = new BABYLON.ShadowGenerator(2048, sun);"#,
            d = v3(travel),
        ),
        Engine::Unity | Engine::Unreal | Engine::Gltf | Engine::Generic => {
            console_and_gltf(engine, w, &intensity, &color, diameter)
        }
    }
}

/// [`snippet`]'s lines for Unity, Unreal and glTF, and the generic target's for any other.
fn console_and_gltf(
    engine: Engine,
    w: Vec3,
    intensity: &str,
    color: &str,
    diameter: f64,
) -> String {
    let travel = -w;
    match engine {
        Engine::Unity => format!(
            r#"
// --sun: the sun, taken out of the panorama (sun.json). C#: a directional light (its
// forward, +Z, is the way it shines); set RenderSettings.sun to it.
var sunObject = new GameObject("Sun");
var sun = sunObject.AddComponent<Light>();
sun.type = LightType.Directional;
sun.color = new Color({color});
sun.intensity = {intensity}f;
sun.shadows = LightShadows.Soft;
sunObject.transform.rotation = Quaternion.LookRotation(new Vector3({d}));"#,
            d = v3(travel),
        ),
        Engine::Unreal => format!(
            r#"
// --sun: the sun, taken out of the panorama (sun.json). C++: a Directional Light (its
// forward, +X, is the way it shines), intensity in lux for a Sky Light at scale 1.
ADirectionalLight* Sun = GetWorld()->SpawnActor<ADirectionalLight>();
Sun->SetActorRotation(FVector({d}).Rotation());
Sun->GetLightComponent()->SetIntensity({intensity}f);
Sun->GetLightComponent()->SetLightColor(FLinearColor({color}));
Sun->GetLightComponent()->SetCastShadows(true);"#,
            d = v3(travel),
        ),
        Engine::Gltf => {
            let q = shining(travel);
            format!(
                r#"
--sun: the sun, taken out of the maps (sun.json), as a KHR_lights_punctual light (a node
shines along its -Z):
"extensions": {{"KHR_lights_punctual": {{"lights": [{{"type": "directional", "name": "sun", "color": [{color}], "intensity": {intensity}}}]}}}}
"nodes": [{{"name": "sun", "rotation": [{q}], "extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}}]"#,
                q = format_args!(
                    "{}, {}, {}, {}",
                    n(q.x as f64),
                    n(q.y as f64),
                    n(q.z as f64),
                    n(q.w as f64)
                ),
            )
        }
        _ => format!(
            "\n--sun: the sun, taken out of the maps (sun.json): towards ({p}) in cube-map space, \
             irradiance {color} times {intensity} (the map's units), {r} degrees across.",
            p = v3(w),
            r = n(diameter),
        ),
    }
}
