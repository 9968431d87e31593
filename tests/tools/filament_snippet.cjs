// Runs the JavaScript half of `cubeforge ibl --target filament`'s printed snippet against
// Filament's own web build (npm `filament`): its Ktx1Bundle reads the file and its "sh" key;
// the engine and scene, which need a WebGL context, are stand-ins that record what the
// snippet hands them. Prints that record as JSON.
// Usage: node filament_snippet.cjs TOOLS_DIR SNIPPET.js FOLDER_WITH_THE_FILES
const fs = require('fs');
const path = require('path');
const [tools, snippetFile, folder] = process.argv.slice(2);
const file = path.join(tools, 'node_modules/filament/filament.js');
const src = fs.readFileSync(file, 'utf8');
const mod = { exports: {} };
// filament.js swaps its `Filament` binding for the loaded module; keep a way to reach it.
const get = new Function('require', 'module', 'exports', '__dirname', '__filename',
    src + '\n;return () => Filament;')(require, mod, mod.exports, path.dirname(file), file);
get().init([], () => {
    const Filament = get();
    for (const name of fs.readdirSync(folder)) {
        Filament.assets[name] = new Uint8Array(fs.readFileSync(path.join(folder, name)));
    }
    const seen = {};
    const engine = {
        createTextureFromKtx1: (url) => { seen.reflections = url; return { url }; },
        createSkyFromKtx1: (url) => { seen.skybox = url; return { url }; },
    };
    const scene = {
        setIndirectLight: (l) => { seen.light = l; },
        setSkybox: (s) => { seen.sky = s.url; },
    };
    Filament.IndirectLight.Builder = () => {
        const b = {};
        b.reflections = (t) => { b.tex = t.url; return b; };
        b.irradianceSh = (n, sh) => { b.bands = n; b.sh = sh; return b; };
        b.intensity = (v) => { b.value = v; return b; };
        b.build = (e) => ({ reflections: b.tex, bands: b.bands, sh: b.sh, intensity: b.value, engine: e === engine });
        return b;
    };
    const snippet = fs.readFileSync(snippetFile, 'utf8');
    new Function('Filament', 'engine', 'scene', snippet)(Filament, engine, scene);
    console.log(JSON.stringify(seen));
});
