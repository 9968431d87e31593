// cubeforge view: the preview's scene on the GPU (WebGL2). A unit sphere in front of the
// environment, the source texts' programs (reflect, refract, Fresnel with dispersion, decal,
// control map, LOD bias) and split-sum pbr, ray-cast per pixel with preview's sample pattern,
// so a frame matches `cubeforge preview` with the same options. No third-party code.
'use strict';

(function () {
  const scene = window.cubeforgeScene;
  const canvas = document.getElementById('view');
  const status = document.getElementById('status');

  function fail(msg) {
    status.textContent = 'cubeforge view: ' + msg;
    status.className = 'error';
    document.title = 'error';
    window.cubeforgeError = msg;
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
  const MATERIALS = scene.materials;
  const TONEMAPS = ['none', 'reinhard', 'aces'];
  const q = new URLSearchParams(location.search);
  const num = (k, d) => (q.has(k) && isFinite(parseFloat(q.get(k))) ? parseFloat(q.get(k)) : d);
  const state = {
    material: q.get('material') || 'chrome',
    size: Math.max(16, Math.min(4096, Math.round(num('size', 512)))),
    exposure: num('exposure', 0),
    tonemap: TONEMAPS.includes(q.get('tonemap')) ? q.get('tonemap') : 'none',
    lod_bias: num('lod_bias', 0),
    level: num('level', 0),
    yaw: num('yaw', 0),
    pitch: num('pitch', 0),
    fov: num('fov', 30),
    distance: num('distance', 4),
    samples: Math.max(1, Math.min(16, Math.round(num('samples', 4)))),
    shading: q.get('shading') === 'per-vertex' ? 'per-vertex' : 'per-fragment',
    tessellation: Math.max(2, Math.min(256, Math.round(num('tessellation', 16)))),
    parallax: ['approx', 'exact'].includes(q.get('parallax')) ? q.get('parallax') : 'approx',
    env_radius: num('env_radius', 0),
    env_center: (q.get('env_center') || '0,0,0').split(',').map(parseFloat),
    layout: q.get('layout') === 'cross' ? 'cross' : 'sphere',
    seams: q.get('seams') === '1',
    sweep: q.get('sweep') === '1',
  };
  if (state.env_center.length !== 3 || state.env_center.some((x) => !isFinite(x))) state.env_center = [0, 0, 0];
  if (!MATERIALS[state.material]) {
    fail('unknown material "' + state.material + '": use one of ' + Object.keys(MATERIALS).join(', '));
    return;
  }
  const base = MATERIALS[state.material];
  // Material parameters the query may override (the texts' uniforms, pbr's factors).
  const mat = Object.assign({}, base);
  for (const k of ['reflectivity', 'transmittance', 'fresnel_bias', 'fresnel_scale', 'fresnel_power',
                   'metallic', 'roughness']) {
    mat[k] = num(k, base[k]);
  }
  if (q.has('eta')) {
    const e = num('eta', 1.5);
    mat.eta_ratio = [1 / e, 1 / e, 1 / e];
  }
  for (const [i, k] of [[0, 'eta_red'], [1, 'eta_green'], [2, 'eta_blue']]) {
    if (q.has(k)) mat.eta_ratio[i] = 1 / num(k, 1 / base.eta_ratio[i]);
  }

  // ---- data: base64 RGBA16F, level by level, faces +X -X +Y -Y +Z -Z ----
  function halves(b64) {
    const s = atob(b64);
    const bytes = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) bytes[i] = s.charCodeAt(i);
    return new Uint16Array(bytes.buffer);
  }
  function cubeTexture(chain) {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_CUBE_MAP, t);
    const data = halves(chain.data);
    let at = 0;
    chain.levels.forEach((n, level) => {
      for (let f = 0; f < 6; f++) {
        const len = n * n * 4;
        gl.texImage2D(gl.TEXTURE_CUBE_MAP_POSITIVE_X + f, level, gl.RGBA16F, n, n, 0, gl.RGBA,
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

  const VS = `#version 300 es
  in vec2 pos;
  void main() { gl_Position = vec4(pos, 0.0, 1.0); }`;

  const FS = `#version 300 es
  precision highp float;
  precision highp samplerCube;
  uniform samplerCube env;
  uniform samplerCube chain;      // pbr's GGX chain
  uniform sampler2D decal;
  uniform sampler2D control;
  uniform sampler2D dfg;
  uniform int model;              // 0 reflect, 1 refract, 2 dispersion, 3 pbr
  uniform bool hasDecal, hasControl, lodOn;
  uniform vec3 decalColor, etaRatio, baseColor;
  uniform float reflectivity, transmittance, fresnelBias, fresnelScale, fresnelPower;
  uniform float metallic, roughness, f0, pbrLod, maxLodBias;
  uniform float lodBias, bgLevel, exposure, halfSize, size;
  uniform int tonemap, samples;
  uniform vec2 offsets[16];
  uniform vec3 eye, fwd, right, up, sh[9];
  uniform float tanHalf;
  uniform int parallax;           // 0 none, 1 approx, 2 exact (Brennan)
  uniform float envRadius;
  uniform vec3 envCenter;
  uniform bool perVertex;
  uniform int mapLayout;             // 0 the sphere, 1 the map as a horizontal cross
  uniform bool seams;             // tint lookups near a face's edge
  uniform vec2 origin;            // this cell's corner in the canvas (a sweep's row)
  uniform float crossCell;
  uniform int bands;              // the per-vertex mesh's latitude bands
  out vec4 color;

  const float PI = 3.14159265358979;

  vec3 ray(vec2 s) {
    float x = (2.0 * s.x / size - 1.0) * tanHalf;
    float y = (1.0 - 2.0 * s.y / size) * tanHalf;
    return fwd + right * x + up * y;
  }
  // The nearest point where the ray meets the unit sphere (preview's sphere::hit).
  bool hit(vec3 o, vec3 d, out vec3 p) {
    vec3 dn = normalize(d);
    float b = dot(o, dn);
    if (b >= 0.0) return false;
    vec3 w = o - dn * b;
    float h2 = dot(w, w);
    if (h2 > 1.0) return false;
    p = w - dn * sqrt(1.0 - h2);
    return true;
  }
  vec2 sphereUv(vec3 p) {
    float u = 0.5 + atan(p.x, p.z) / (2.0 * PI);
    float v = acos(clamp(p.y / length(p), -1.0, 1.0)) / PI;
    return vec2(min(u, 1.0 - 0.5 * 1.1920929e-7), v);
  }
  vec3 refr(vec3 i, vec3 n, float eta) {
    float ci = dot(-i, n);
    float ct2 = 1.0 - eta * eta * (1.0 - ci * ci);
    vec3 t = eta * i + (eta * ci - sqrt(abs(ct2))) * n;
    return ct2 > 0.0 ? t : vec3(0.0);
  }
  float fres(vec3 i, vec3 n) {
    return clamp(fresnelBias + fresnelScale * pow(max(1.0 + dot(i, n), 0.0), fresnelPower), 0.0, 1.0);
  }
  // Brennan's correction for an environment of radius envRadius around envCenter.
  vec3 correct(vec3 v, vec3 p) {
    if (parallax == 0 || v == vec3(0.0)) return v;
    vec3 d = normalize(v);
    vec3 cp = p - envCenter;
    if (parallax == 1) return d + cp / envRadius;
    float b = dot(cp, d);
    float c = dot(cp, cp) - envRadius * envRadius;
    float disc = b * b - c;
    if (disc < 0.0) return d;
    float t = -b + sqrt(disc);
    return t <= 0.0 ? d : cp + d * t;
  }
  // The vertex programs: lookup vectors v[0..3] and the Fresnel factor at point p, normal n.
  void vertexStage(vec3 p, vec3 n, out vec3 v[4], out float factor) {
    vec3 i = p - eye;
    factor = 0.0;
    v[1] = vec3(0.0); v[2] = vec3(0.0); v[3] = vec3(0.0);
    if (model == 1) {
      v[0] = correct(refr(normalize(i), n, etaRatio.x), p);
    } else {
      v[0] = correct(reflect(i, n), p);
      if (model == 2) {
        vec3 iu = normalize(i);
        v[1] = correct(refr(iu, n, etaRatio.x), p);
        v[2] = correct(refr(iu, n, etaRatio.y), p);
        v[3] = correct(refr(iu, n, etaRatio.z), p);
        factor = fres(iu, n);
      } else if (model == 3) {
        v[1] = n;
        v[2] = -normalize(i);
      }
    }
  }
  // The level a GPU picks for v with neighbours vx, vy (preview's cube_lod).
  float cubeLod(vec3 v, vec3 vx, vec3 vy) {
    vec3 a = abs(v);
    int axis = (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
    ivec2 uw = axis == 0 ? ivec2(2, 1) : (axis == 1 ? ivec2(0, 2) : ivec2(0, 1));
    float ma = v[axis];
    if (ma == 0.0) return 0.0;
    vec2 pv = vec2(v[uw.x], v[uw.y]) / a[axis];
    float rho = 0.0;
    for (int k = 0; k < 2; k++) {
      vec3 q = k == 0 ? vx : vy;
      float m = q[axis] / sign(ma);
      if (!(m > 0.0)) return 1e30;
      rho = max(rho, length(vec2(q[uw.x], q[uw.y]) / m - pv));
    }
    return log2(rho * halfSize);
  }
  // With seams on: magenta where a lookup lands within a texel and a half of a face's edge.
  vec4 seamTint(vec3 d, vec4 c) {
    if (!seams) return c;
    vec3 a = abs(d);
    float ma = max(a.x, max(a.y, a.z));
    vec2 st = a.x == ma ? d.yz : (a.y == ma ? d.xz : d.xy);
    float edge = max(abs(st.x), abs(st.y)) / ma;
    return edge > 1.0 - 3.0 / (2.0 * halfSize) ? mix(c, vec4(4.0, 0.0, 4.0, 1.0), 0.7) : c;
  }
  vec4 texCube(vec3 v, float lod) {
    return v == vec3(0.0) ? vec4(0.0) : seamTint(v, textureLod(env, v, lod));
  }
  vec4 background(vec3 d) {
    return seamTint(d, textureLod(env, d, bgLevel));
  }
  vec3 shIrradiance(vec3 n) {
    float x = n.x, y = n.y, z = n.z;
    vec3 c = sh[0] * 0.282095
      + sh[1] * 0.488603 * y + sh[2] * 0.488603 * z + sh[3] * 0.488603 * x
      + sh[4] * 1.092548 * x * y + sh[5] * 1.092548 * y * z
      + sh[6] * 0.315392 * (3.0 * z * z - 1.0)
      + sh[7] * 1.092548 * x * z + sh[8] * 0.546274 * (x * x - y * y);
    return max(c, vec3(0.0));
  }
  // The fragment programs, with the lookup vectors one pixel right (vx) and below (vy) for
  // the level of detail (ok false: unbounded footprint, the coarsest level).
  vec3 fragmentStage(vec3 v[4], float factor, vec2 uv, vec3 vx[4], vec3 vy[4], bool ok) {
    float refl = reflectivity, trans = transmittance, blur = 0.0, mask = 1.0;
    if (hasControl) {
      vec4 t = texture(control, uv);
      refl = t.x; trans = t.y; blur = t.z * maxLodBias; mask = t.w;
    }
    vec4 dc = hasDecal ? texture(decal, uv) : vec4(decalColor, 1.0);
    if (model == 3) {
      vec3 bc = hasDecal ? baseColor * dc.rgb : baseColor;
      vec3 nn = normalize(v[1]);
      float nv = clamp(dot(nn, normalize(v[2])), 0.0, 1.0);
      vec3 f0c = mix(vec3(f0), bc, metallic);
      vec2 ab = texture(dfg, vec2(nv, clamp(roughness, 0.0, 1.0))).xy;
      vec3 pre = v[0] == vec3(0.0) ? vec3(0.0) : textureLod(chain, v[0], pbrLod + lodBias + blur).rgb;
      vec3 diffuse = bc * (1.0 - metallic) * shIrradiance(nn);
      return diffuse + pre * (f0c * ab.x + vec3(ab.y));
    }
    float lods[4] = float[4](0.0, 0.0, 0.0, 0.0);
    if (lodOn) {
      for (int k = 0; k < 4; k++) {
        float b = ok ? cubeLod(v[k], vx[k], vy[k]) : 1e30;
        lods[k] = b + lodBias + blur;
      }
    }
    if (model == 0) return mix(dc, texCube(v[0], lods[0]), refl).rgb;
    if (model == 1) return mix(dc, texCube(v[0], lods[0]), trans).rgb;
    vec3 reflected = texCube(v[0], lods[0]).rgb;
    vec3 refracted = vec3(texCube(v[1], lods[1]).x, texCube(v[2], lods[2]).y, texCube(v[3], lods[3]).z);
    float f = mask * factor + (1.0 - mask) * refl;
    return mix(refracted, reflected, f);
  }
  // Per fragment: the vertex stage at the exact hit, and where the rays one pixel right and
  // below meet the hit's tangent plane.
  vec3 shadeFragment(vec2 s, vec3 p) {
    vec3 n = normalize(p);
    vec2 uv = sphereUv(n);
    vec3 v[4], vx[4], vy[4]; float factor, f2;
    vertexStage(p, n, v, factor);
    bool ok = false;
    if (lodOn) {
      float plane = dot(p - eye, n);
      vec3 d2 = ray(s + vec2(1.0, 0.0));
      vec3 d3 = ray(s + vec2(0.0, 1.0));
      float den2 = dot(d2, n), den3 = dot(d3, n);
      ok = den2 < -1e-9 && den3 < -1e-9;
      if (ok) {
        vec3 p2 = eye + d2 * (plane / den2), p3 = eye + d3 * (plane / den3);
        vertexStage(p2, normalize(p2), vx, f2);
        vertexStage(p3, normalize(p3), vy, f2);
      }
    }
    return fragmentStage(v, factor, uv, vx, vy, ok);
  }
  // The per-vertex mesh (preview's sphere::tessellate): vertex (i, j) of bands latitude
  // bands and 2 bands columns; pole vertices take their cell's middle u.
  vec3 meshPos(int i, int j) {
    if (i == 0) return vec3(0.0, 1.0, 0.0);
    if (i == bands) return vec3(0.0, -1.0, 0.0);
    float th = PI * float(i) / float(bands);
    float ph = 2.0 * PI * float(j) / float(2 * bands) - PI;
    return vec3(sin(th) * sin(ph), cos(th), sin(th) * cos(ph));
  }
  vec2 meshUv(int i, int j) {
    int m = 2 * bands;
    float u = ((i == 0 || i == bands) && j < m) ? (float(j) + 0.5) / float(m) : float(j) / float(m);
    return vec2(u, float(i) / float(bands));
  }
  // Barycentrics of the ray's meeting with the plane of (a, b, c), and its distance t.
  vec4 plane3(vec3 o, vec3 d, vec3 a, vec3 b, vec3 c) {
    vec3 e1 = b - a, e2 = c - a;
    vec3 h = cross(d, e2);
    float det = dot(e1, h);
    if (abs(det) < 1e-12) return vec4(-1.0, -1.0, -1.0, -1.0);
    vec3 sv = o - a;
    float u = dot(sv, h) / det;
    vec3 qv = cross(sv, e1);
    float w = dot(d, qv) / det;
    float t = dot(e2, qv) / det;
    return vec4(1.0 - u - w, u, w, t);
  }
  void blend(vec3 va[4], vec3 vb[4], vec3 vc[4], vec3 l, out vec3 o[4]) {
    for (int k = 0; k < 4; k++) o[k] = va[k] * l.x + vb[k] * l.y + vc[k] * l.z;
  }
  // Per vertex: the mesh triangle the ray meets (front faces, the hit's cell and its
  // neighbours), the vertex stage at its corners, varyings interpolated at the hit and, for
  // the level of detail, where the rays one pixel right and below meet its plane.
  vec3 shadeVertex(vec2 s, vec3 p, inout bool covered) {
    vec3 d = ray(s);
    int m = 2 * bands;
    float th = acos(clamp(p.y, -1.0, 1.0));
    int ci = int(floor(th / PI * float(bands)));
    int cj = int(floor((atan(p.x, p.z) + PI) / (2.0 * PI) * float(m)));
    float best = 1e30;
    ivec2 tri[3]; vec3 bary;
    bool found = false;
    for (int di = -1; di <= 1; di++) {
      int i = ci + di;
      if (i < 0 || i >= bands) continue;
      for (int dj = -1; dj <= 1; dj++) {
        int j = (cj + dj + m) % m;
        ivec2 A = ivec2(i, j), B = ivec2(i, j + 1), C = ivec2(i + 1, j), D = ivec2(i + 1, j + 1);
        for (int k = 0; k < 2; k++) {
          ivec2 t0 = A, t1 = C, t2 = D;
          if (i == 0) { if (k == 1) continue; }
          else if (i == bands - 1) { if (k == 1) continue; t2 = B; }
          else if (k == 1) { t1 = D; t2 = B; }
          vec3 a = meshPos(t0.x, t0.y), b = meshPos(t1.x, t1.y), c = meshPos(t2.x, t2.y);
          vec3 nrm = cross(b - a, c - a);
          if (dot(nrm, a + b + c) < 0.0) nrm = -nrm;
          if (dot(a - eye, nrm) >= 0.0) continue;
          vec4 h = plane3(eye, d, a, b, c);
          if (h.x < 0.0 || h.y < 0.0 || h.z < 0.0 || h.w <= 0.0 || h.w >= best) continue;
          best = h.w; tri[0] = t0; tri[1] = t1; tri[2] = t2; bary = h.xyz; found = true;
        }
      }
    }
    if (!found) { covered = false; return vec3(0.0); }
    vec3 P[3]; vec3 va[4], vb[4], vc[4]; float fa, fb, fc;
    for (int k = 0; k < 3; k++) P[k] = meshPos(tri[k].x, tri[k].y);
    vertexStage(P[0], P[0], va, fa);
    vertexStage(P[1], P[1], vb, fb);
    vertexStage(P[2], P[2], vc, fc);
    vec2 uv = meshUv(tri[0].x, tri[0].y) * bary.x + meshUv(tri[1].x, tri[1].y) * bary.y + meshUv(tri[2].x, tri[2].y) * bary.z;
    vec3 v[4], vx[4], vy[4];
    blend(va, vb, vc, bary, v);
    float factor = fa * bary.x + fb * bary.y + fc * bary.z;
    bool ok = lodOn;
    if (lodOn) {
      vec4 hx = plane3(eye, ray(s + vec2(1.0, 0.0)), P[0], P[1], P[2]);
      vec4 hy = plane3(eye, ray(s + vec2(0.0, 1.0)), P[0], P[1], P[2]);
      blend(va, vb, vc, hx.xyz, vx);
      blend(va, vb, vc, hy.xyz, vy);
    }
    return fragmentStage(v, factor, uv, vx, vy, ok);
  }
  vec3 shade(vec2 s) {
    vec3 d = ray(s);
    vec3 p;
    if (!hit(eye, d, p)) return background(d).rgb;
    if (!perVertex) return shadeFragment(s, p);
    bool covered = true;
    vec3 c = shadeVertex(s, p, covered);
    return covered ? c : background(d).rgb;
  }
  float curve(float x) {
    x = max(x, 0.0);
    if (tonemap == 1) return x / (1.0 + x);
    if (tonemap == 2) { x = min(x, 1e4); return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); }
    return min(x, 1.0);
  }
  float srgb(float v) {
    v = clamp(v, 0.0, 1.0);
    return v <= 0.0031308 ? v * 12.92 : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
  }
  // The map as a horizontal cross (cubeforge's hcross: +Y above +Z, -X +Z +X -Z, -Y below),
  // each face as its image; black where no face is (as convert writes it).
  vec3 crossTexel(vec2 s) {
    ivec2 cell = ivec2(floor(s / crossCell));
    int face = -1;
    if (cell.y == 1) face = cell.x == 0 ? 1 : (cell.x == 1 ? 4 : (cell.x == 2 ? 0 : 5));
    else if (cell.x == 1) face = cell.y == 0 ? 2 : 3;
    if (face < 0) return vec3(0.0);
    vec2 st = (s - vec2(cell) * crossCell) / crossCell;
    float sc = 2.0 * st.x - 1.0, tc = 2.0 * st.y - 1.0;
    vec3 d = face == 0 ? vec3(1.0, -tc, -sc) : face == 1 ? vec3(-1.0, -tc, sc)
           : face == 2 ? vec3(sc, 1.0, tc) : face == 3 ? vec3(sc, -1.0, -tc)
           : face == 4 ? vec3(sc, -tc, 1.0) : vec3(-sc, -tc, -1.0);
    return background(d).rgb;
  }
  void main() {
    // Pixel (i, j) from the top left of this cell, as the CPU renderer counts them.
    vec2 px = vec2(floor(gl_FragCoord.x) - origin.x, size - 1.0 - floor(gl_FragCoord.y) + origin.y);
    vec3 acc = vec3(0.0);
    for (int k = 0; k < 16; k++) {
      if (k >= samples) break;
      acc += mapLayout == 1 ? crossTexel(px + offsets[k]) : shade(px + offsets[k]);
    }
    vec3 c = acc / float(samples) * exp2(exposure);
    color = vec4(srgb(curve(c.r)), srgb(curve(c.g)), srgb(curve(c.b)), 1.0);
  }`;

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

  let program, uniforms;
  function setup() {
    program = gl.createProgram();
    gl.attachShader(program, compile(gl.VERTEX_SHADER, VS));
    gl.attachShader(program, compile(gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
    gl.useProgram(program);
    const buf = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buf);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
    const loc = gl.getAttribLocation(program, 'pos');
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 2, gl.FLOAT, false, 0, 0);
    uniforms = new Proxy({}, { get: (c, k) => (k in c ? c[k] : (c[k] = gl.getUniformLocation(program, k))) });
    const units = [['env', gl.TEXTURE_CUBE_MAP, cubeTexture(scene.env)],
                   ['chain', gl.TEXTURE_CUBE_MAP, scene.pbr.chain ? cubeTexture(scene.pbr.chain) : null],
                   ['decal', gl.TEXTURE_2D, scene.decal ? texture2d(scene.decal, true) : null],
                   ['control', gl.TEXTURE_2D, scene.control ? texture2d(scene.control, true) : null],
                   ['dfg', gl.TEXTURE_2D, texture2d(scene.dfg, false)]];
    units.forEach(([name, target, tex], i) => {
      gl.activeTexture(gl.TEXTURE0 + i);
      if (name === 'chain' && !tex) tex = units[0][2];
      if (tex) gl.bindTexture(target, tex);
      gl.uniform1i(uniforms[name], i);
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
    canvas.style.width = canvas.width / (window.devicePixelRatio || 1) + 'px';
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
    const dpr = window.devicePixelRatio || 1;
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
    const u = uniforms;
    const cam = camera();
    const models = { reflect: 0, refract: 1, dispersion: 2, pbr: 3 };
    gl.uniform1i(u.model, models[mat.model]);
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
    gl.uniform3fv(u.sh, new Float32Array([].concat(...scene.pbr.sh)));
    gl.uniform1f(u.tanHalf, Math.tan(state.fov * Math.PI / 360));
    gl.uniform1i(u.parallax, state.env_radius > 0 ? (state.parallax === 'exact' ? 2 : 1) : 0);
    gl.uniform1f(u.envRadius, state.env_radius);
    gl.uniform3fv(u.envCenter, state.env_center);
    gl.uniform1i(u.perVertex, state.shading === 'per-vertex' ? 1 : 0);
    gl.uniform1i(u.bands, state.tessellation);
    gl.uniform1i(u.mapLayout, cross ? 1 : 0);
    gl.uniform1i(u.seams, state.seams ? 1 : 0);
    gl.uniform2f(u.origin, x0, 0);
    gl.uniform1f(u.crossCell, state.size / 4);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  function ready() {
    gl.finish();
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
