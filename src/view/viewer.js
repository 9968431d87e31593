// cubeforge view: the preview's scene on the GPU (WebGL2). A unit sphere in front of the
// environment, the source texts' programs (reflect, refract, Fresnel with dispersion, decal,
// control map, LOD bias) and split-sum pbr, ray-cast per pixel with preview's sample pattern,
// so a frame matches `cubeforge preview` with the same options. No third-party code.
'use strict';

(function () {
  const scene = window.cubeforgeScene;
  const canvas = document.getElementById('view');
  const status = document.getElementById('status');

  // One line on the page (a shader's log can run to many: the rest goes to the console).
  function fail(msg) {
    const lines = String(msg).split(/\r?\n/).map((l) => l.trim()).filter(Boolean);
    if (lines.length > 1) console.error(String(msg));
    const line = (lines[0] || 'failed') + (lines.length > 1 ? ' (' + (lines.length - 1) + ' more lines in the console)' : '');
    status.textContent = 'cubeforge view: ' + line;
    status.className = 'error';
    document.title = 'error';
    window.cubeforgeError = line;
  }
  if (!scene) {
    fail('the scene data (data.js) is missing or broken: run cubeforge view again');
    return;
  }
  const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
  if (!gl) {
    fail('this browser has no WebGL2');
    return;
  }

  // ---- the page's state: its URL query, named as preview's options ----
  // Every value is checked as preview checks its option, and a bad one is the page's one-line
  // message (never a default in silence, nor a shader's error). Lookups keyed by the query ask
  // for own properties only: `__proto__`, `constructor` or `toString` is no material.
  const own = (o, k) => Object.prototype.hasOwnProperty.call(o, k);
  const MATERIALS = scene.materials;
  const TONEMAPS = ['none', 'reinhard', 'aces'];
  const q = new URLSearchParams(location.search);
  const problems = [];
  const ANY = [() => true, 'a finite number'];
  const UNIT = [(v) => v >= 0 && v <= 1, 'between 0 and 1'];
  const ANGLE = [(v) => v >= -3600 && v <= 3600, 'between -3600 and 3600 degrees'];
  const POSITIVE = [(v) => v > 0, 'more than 0'];
  // A number, or `d` without the key; `[ok, what]` says which numbers are allowed.
  function num(k, d, [ok, what]) {
    if (!q.has(k)) return d;
    const s = q.get(k).trim();
    const v = s === '' ? NaN : Number(s);
    if (Number.isFinite(v) && ok(v)) return v;
    problems.push(k + ' must be ' + what + ' (got ' + JSON.stringify(q.get(k)) + ')');
    return d;
  }
  // One of `options` (`d`, or else the first, without the key).
  function choice(k, options, d) {
    if (!q.has(k)) return d || options[0];
    const v = q.get(k);
    if (options.includes(v)) return v;
    problems.push('unknown ' + k + ' ' + JSON.stringify(v) + ': use one of ' + options.join(', '));
    return options[0];
  }
  const state = {
    material: q.get('material') || 'chrome',
    size: Math.max(16, Math.min(4096, Math.round(num('size', 512, ANY)))),
    exposure: num('exposure', 0, [(v) => v >= -32 && v <= 32, 'between -32 and 32 stops']),
    // An HDR input shown as it is blows out: ACES unless the query says otherwise.
    tonemap: choice('tonemap', TONEMAPS, scene.hdr ? 'aces' : 'none'),
    lod_bias: num('lod_bias', 0, ANY),
    level: num('level', 0, ANY),
    yaw: num('yaw', 0, ANGLE),
    pitch: num('pitch', 0, ANGLE),
    fov: num('fov', 30, [(v) => v > 0 && v < 179, 'between 0 and 179 degrees']),
    distance: num('distance', 4, [(v) => v > 1, 'more than 1, outside the unit sphere']),
    samples: Math.max(1, Math.min(16, Math.round(num('samples', 4, ANY)))),
    shading: choice('shading', ['per-fragment', 'per-vertex']),
    // preview's --refraction: the texts' one bend, or the solid sphere's exact path (per
    // fragment; a material that names its own wins, as in preview).
    refraction: choice('refraction', ['texts', 'exact']),
    tessellation: Math.max(2, Math.min(256, Math.round(num('tessellation', 16, ANY)))),
    parallax: choice('parallax', ['approx', 'exact']),
    env_radius: num('env_radius', 0, [(v) => v >= 0, 'positive (0: infinitely far)']),
    env_center: [0, 0, 0],
    layout: choice('layout', ['sphere', 'cross']),
    seams: choice('seams', ['0', '1']) === '1',
    sweep: choice('sweep', ['0', '1']) === '1',
  };
  if (q.has('env_center')) {
    const c = q.get('env_center').split(',').map((x) => (x.trim() === '' ? NaN : Number(x)));
    if (c.length === 3 && c.every(Number.isFinite)) state.env_center = c;
    else problems.push('env_center must be three finite numbers X,Y,Z (got ' + JSON.stringify(q.get('env_center')) + ')');
  }
  if (state.env_radius > 0 && state.parallax === 'exact' && state.env_radius <= 1 + Math.hypot(...state.env_center)) {
    problems.push('parallax exact needs the sphere inside the environment: env_radius must exceed 1 + |env_center|');
  }
  if (!own(MATERIALS, state.material)) {
    fail('unknown material ' + JSON.stringify(state.material) + ': use one of ' + Object.keys(MATERIALS).join(', '));
    return;
  }
  const base = MATERIALS[state.material];
  // Material parameters the query may override (the texts' uniforms, pbr's factors), on a
  // copy: the scene's material stays as it came.
  const mat = Object.assign({}, base, { eta_ratio: base.eta_ratio.slice() });
  for (const k of ['reflectivity', 'transmittance', 'metallic', 'roughness']) mat[k] = num(k, base[k], UNIT);
  for (const k of ['fresnel_bias', 'fresnel_scale']) mat[k] = num(k, base[k], ANY);
  mat.fresnel_power = num('fresnel_power', base.fresnel_power, [(v) => v >= 0, 'at least 0']);
  if (q.has('eta')) {
    const e = num('eta', 1.5, POSITIVE);
    mat.eta_ratio = [1 / e, 1 / e, 1 / e];
  }
  for (const [i, k] of [[0, 'eta_red'], [1, 'eta_green'], [2, 'eta_blue']]) {
    if (q.has(k)) mat.eta_ratio[i] = 1 / num(k, 1 / base.eta_ratio[i], POSITIVE);
  }
  if (problems.length) {
    fail(problems.join('; '));
    return;
  }

  // ---- data: base64 half floats (cube chains RGB, images RGBA), level by level, faces +X -X +Y -Y +Z -Z ----
  function halves(b64) {
    // The platform's decoder where it has one (Chromium 140 and later), else atob.
    if (Uint8Array.fromBase64) return new Uint16Array(Uint8Array.fromBase64(b64).buffer);
    const s = atob(b64);
    const bytes = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) bytes[i] = s.charCodeAt(i);
    return new Uint16Array(bytes.buffer);
  }
  function cubeTexture(chain) {
    // Rows of 6-byte texels: small levels' rows are not 4-byte aligned.
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 2);
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_CUBE_MAP, t);
    const data = halves(chain.data);
    let at = 0;
    chain.levels.forEach((n, level) => {
      for (let f = 0; f < 6; f++) {
        const len = n * n * 3;
        gl.texImage2D(gl.TEXTURE_CUBE_MAP_POSITIVE_X + f, level, gl.RGB16F, n, n, 0, gl.RGB,
                      gl.HALF_FLOAT, data.subarray(at, at + len));
        at += len;
      }
    });
    if (at !== data.length) throw new Error('a cube chain holds ' + data.length + ' values, not ' + at);
    gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MAX_LEVEL, chain.levels.length - 1);
    gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MIN_FILTER,
                     chain.levels.length > 1 ? gl.LINEAR_MIPMAP_LINEAR : gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    return t;
  }
  // A 2D image: u repeats (around the sphere), v clamps, bilinear, no mips (as tex2D here).
  function texture2d(img, repeatU) {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA16F, img.width, img.height, 0, gl.RGBA, gl.HALF_FLOAT,
                  halves(img.data));
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, repeatU ? gl.REPEAT : gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    return t;
  }

  const { VS, FS } = window.cubeforgeShaders || {};
  if (!VS || !FS) {
    fail('the shaders (shaders.js) are missing: run cubeforge view again');
    return;
  }

  function compile(type, src) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  }

  // Preview's sample pattern: a rank-1 lattice (camera::sample_offsets).
  function sampleOffsets(s) {
    if (s <= 1) return [[0.5, 0.5]];
    const gcd = (a, b) => { while (b) [a, b] = [b, a % b]; return a; };
    const target = s * 0.618034;
    let g = 1, best = Infinity;
    for (let c = 1; c < s; c++) {
      if (gcd(c, s) === 1 && Math.abs(c - target) < best) { best = Math.abs(c - target); g = c; }
    }
    const out = [];
    for (let k = 0; k < s; k++) out.push([(k + 0.5) / s, ((k * g) % s) / s + 0.5 / s]);
    return out;
  }

  // The roughness -> level table of pbr's chain, read linearly.
  function pbrLod(r) {
    const t = scene.pbr.lod_table;
    const x = Math.max(0, Math.min(1, r)) * (t.length - 1);
    const i = Math.min(t.length - 2, Math.floor(x));
    return t[i] + (t[i + 1] - t[i]) * (x - i);
  }

  // One program per variant (material model, shading, layout, seams), compiled when first
  // asked: SwiftShader takes seconds over a program that holds every path.
  const programs = Object.create(null);
  let program, uniforms, buffer, textures;
  function variant(cross) {
    const model = { reflect: 0, refract: 1, dispersion: 2, pbr: 3 }[mat.model];
    // pbr's own GGX chain goes up when a pbr material first needs it.
    if (model === 3 && scene.pbr.chain && textures[1][2] === textures[0][2]) {
      // Made on its own unit: cubeTexture binds to the active one (the irradiance's, last).
      gl.activeTexture(gl.TEXTURE1);
      textures[1][2] = cubeTexture(scene.pbr.chain);
      gl.bindTexture(gl.TEXTURE_CUBE_MAP, textures[1][2]);
    }
    const perVertex = state.shading === 'per-vertex' && !cross;
    const exact = (mat.refraction || state.refraction) === 'exact' && (model === 1 || model === 2);
    const defs = { MODEL: model, PER_VERTEX: perVertex ? 1 : 0,
                   CROSS: cross ? 1 : 0, SEAMS: state.seams ? 1 : 0,
                   EXACT: exact && !perVertex && !cross ? 1 : 0 };
    const key = JSON.stringify(defs);
    if (!programs[key]) {
      const header = '#version 300 es\n' + Object.entries(defs).map(([k, v]) => '#define ' + k + ' ' + v + '\n').join('');
      const p = gl.createProgram();
      gl.attachShader(p, compile(gl.VERTEX_SHADER, VS));
      gl.attachShader(p, compile(gl.FRAGMENT_SHADER, header + FS));
      gl.linkProgram(p);
      if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
      const cache = Object.create(null);
      programs[key] = { p, u: new Proxy(cache, { get: (c, k) => (k in c ? c[k] : (c[k] = gl.getUniformLocation(p, k))) }) };
    }
    ({ p: program, u: uniforms } = programs[key]);
    gl.useProgram(program);
    const loc = gl.getAttribLocation(program, 'pos');
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 2, gl.FLOAT, false, 0, 0);
    textures.forEach(([name], i) => gl.uniform1i(uniforms[name], i));
  }

  function setup() {
    buffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
    const envTex = cubeTexture(scene.env);
    textures = [['env', gl.TEXTURE_CUBE_MAP, envTex],
                ['chain', gl.TEXTURE_CUBE_MAP, envTex],
                ['decal', gl.TEXTURE_2D, scene.decal ? texture2d(scene.decal, true) : null],
                ['control', gl.TEXTURE_2D, scene.control ? texture2d(scene.control, true) : null],
                ['dfg', gl.TEXTURE_2D, texture2d(scene.dfg, false)],
                ['irradiance', gl.TEXTURE_CUBE_MAP, cubeTexture(scene.pbr.irradiance)]];
    textures.forEach(([, target, tex], i) => {
      gl.activeTexture(gl.TEXTURE0 + i);
      if (tex) gl.bindTexture(target, tex);
    });
  }

  function camera() {
    const r = Math.PI / 180;
    const [sy, cy, sp, cp] = [Math.sin(state.yaw * r), Math.cos(state.yaw * r), Math.sin(state.pitch * r), Math.cos(state.pitch * r)];
    const dir = [cp * sy, sp, cp * cy];
    const up = [-sp * sy, cp, -sp * cy];
    const fwd = dir.map((x) => -x);
    const right = [up[1] * fwd[2] - up[2] * fwd[1], up[2] * fwd[0] - up[0] * fwd[2], up[0] * fwd[1] - up[1] * fwd[0]];
    return { eye: dir.map((x) => x * state.distance), fwd, right, up };
  }

  // The cells of a sweep row: pbr materials at roughness 0 to 1, the others at LOD biases
  // 0 to the chain's last level.
  function sweepCells() {
    if (!state.sweep || state.layout === 'cross') return [null];
    const top = Math.max(1, scene.env.levels.length - 1);
    return [0, 0.25, 0.5, 0.75, 1].map((f) =>
      mat.model === 'pbr' ? { roughness: f, label: 'roughness ' + f } : { lod_bias: f * top, label: 'LOD bias ' + (f * top).toFixed(2) });
  }

  function draw() {
    const n = state.size;
    const cells = sweepCells();
    const cross = state.layout === 'cross';
    canvas.width = cross ? n : n * cells.length;
    canvas.height = cross ? Math.round(n * 3 / 4) : n;
    // A sweep's row of cells is scaled down to the window's width rather than overflowing it.
    const room = Math.max(160, (window.innerWidth || canvas.width) - canvas.offsetLeft - 16);
    canvas.style.width = Math.min(canvas.width / (window.devicePixelRatio || 1), room) + 'px';
    labels(cross, cells, n);
    for (const [k, cell] of cells.entries()) {
      gl.viewport(k * n, 0, cross ? canvas.width : n, canvas.height);
      drawCell(cell, k * n, cross ? canvas.height : n, cross);
    }
  }

  // Face names over the cross, each cell's parameter under a sweep.
  function labels(cross, cells, n) {
    let box = document.getElementById('labels');
    if (!box) {
      box = document.createElement('div');
      box.id = 'labels';
      canvas.parentNode.style.position = 'relative';
      canvas.parentNode.appendChild(box);
    }
    box.textContent = '';
    const put = (text, x, y) => {
      const l = document.createElement('span');
      l.className = 'label';
      l.textContent = text;
      Object.assign(l.style, { left: x + 'px', top: y + 'px' });
      box.appendChild(l);
    };
    // Canvas pixels per CSS pixel, as the canvas is shown (scaled down for a wide sweep).
    const dpr = canvas.width / (parseFloat(canvas.style.width) || canvas.width);
    const at = canvas.offsetLeft, top = canvas.offsetTop;
    if (cross) {
      const c = n / 4 / dpr;
      for (const [name, x, y] of [['+X', 2, 1], ['-X', 0, 1], ['+Y', 1, 0], ['-Y', 1, 2], ['+Z', 1, 1], ['-Z', 3, 1]]) {
        put(name, at + x * c + 4, top + y * c + 2);
      }
    } else if (cells.length > 1) {
      cells.forEach((cell, k) => put(cell.label, at + k * n / dpr + 4, top + 2));
    }
  }

  function drawCell(cell, x0, n, cross) {
    variant(cross);
    const u = uniforms;
    const cam = camera();
    gl.uniform1i(u.hasDecal, scene.decal ? 1 : 0);
    gl.uniform1i(u.hasControl, scene.control ? 1 : 0);
    gl.uniform1i(u.lodOn, scene.env.levels.length > 1 && mat.model !== 'pbr' ? 1 : 0);
    gl.uniform3fv(u.decalColor, mat.decal_color);
    gl.uniform3fv(u.etaRatio, mat.eta_ratio);
    gl.uniform3fv(u.baseColor, mat.base_color);
    gl.uniform1f(u.reflectivity, mat.reflectivity);
    gl.uniform1f(u.transmittance, mat.transmittance);
    gl.uniform1f(u.fresnelBias, mat.fresnel_bias);
    gl.uniform1f(u.fresnelScale, mat.fresnel_scale);
    gl.uniform1f(u.fresnelPower, mat.fresnel_power);
    gl.uniform1f(u.metallic, mat.metallic);
    const rough = cell && cell.roughness !== undefined ? cell.roughness : mat.roughness;
    gl.uniform1f(u.roughness, rough);
    gl.uniform1f(u.f0, mat.f0);
    gl.uniform1f(u.pbrLod, pbrLod(rough));
    gl.uniform1f(u.maxLodBias, scene.control ? scene.control.max_lod_bias : 0);
    gl.uniform1f(u.lodBias, cell && cell.lod_bias !== undefined ? cell.lod_bias : state.lod_bias);
    gl.uniform1f(u.bgLevel, state.level);
    gl.uniform1f(u.exposure, state.exposure);
    gl.uniform1f(u.halfSize, scene.env.levels[0] * 0.5);
    gl.uniform1f(u.size, n);
    gl.uniform1i(u.tonemap, TONEMAPS.indexOf(state.tonemap));
    const offs = sampleOffsets(state.samples);
    gl.uniform1i(u.samples, offs.length);
    gl.uniform2fv(u.offsets, new Float32Array([].concat(...offs, ...Array(2 * (16 - offs.length)).fill(0))));
    gl.uniform3fv(u.eye, cam.eye);
    gl.uniform3fv(u.fwd, cam.fwd);
    gl.uniform3fv(u.right, cam.right);
    gl.uniform3fv(u.up, cam.up);
    gl.uniform1f(u.tanHalf, Math.tan(state.fov * Math.PI / 360));
    gl.uniform1i(u.parallax, state.env_radius > 0 ? (state.parallax === 'exact' ? 2 : 1) : 0);
    gl.uniform1f(u.envRadius, state.env_radius);
    gl.uniform3fv(u.envCenter, state.env_center);
    gl.uniform1i(u.bands, state.tessellation);
    gl.uniform2f(u.origin, x0, 0);
    gl.uniform1f(u.crossCell, state.size / 4);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  function ready() {
    // Reading a pixel back waits for the frame itself (finish alone did not, in Chromium).
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    document.title = 'ready';
    window.cubeforgeReady = true;
  }

  try {
    setup();
    draw();
    ready();
  } catch (e) {
    fail(String(e && e.message ? e.message : e));
    return;
  }
  window.cubeforgeRedraw = function (changes) {
    Object.assign(state, changes || {});
    window.cubeforgeReady = false;
    draw();
    ready();
  };
  if (window.cubeforgeUi) window.cubeforgeUi(state, mat, scene, window.cubeforgeRedraw);
})();
